"""Device layer: the glove's mote frames, a serial reader, and a virtual glove.

Nothing here imports the engine; the modules use only the standard library, numpy, pyserial and
:mod:`pointat.maths`.

Cheat sheet
-----------
Wire format (:mod:`pointat.devices.mote_frame`)::

    frame = Frame(mote=1, n_pack=0, channels=(g_x, g_y, g_z, a_x, a_y, a_z, m_x, m_y, m_z))  # 0..4095
    encode_frame(frame)          # 21 bytes: A5 5A id n_pack(u16) 9x12-bit packed CRC-16/CCITT-FALSE
    encode_text(frame)           # b"$1 0 g_x ... m_z\\n"
    parser = FrameParser()       # "auto" | "binary" | "text"
    parser.feed(data)            # -> [Frame, ...]; parser.pop_events() -> [LostPackets(...), ...]
    parser.stats.motes[1].lost   # per-mote received / lost / corrupt
    DEFAULT_SPEC.to_units(frame.channels)   # counts -> °/s, m/s², gauss (Torre Table 1)

Serial port (:mod:`pointat.devices.serial_reader`)::

    with SerialMoteReader("/dev/ttyUSB0", on_frame=lambda frame, t: ..., on_event=print_event):
        ...                      # a thread reads, parses, stamps time.monotonic(), reopens after unplug

Virtual glove (:mod:`pointat.devices.glove_sim`)::

    sim = GloveSimulator(default_script(), rate_hz=100, seed=0)
    t, frame, q_true = sim.sample(k)
    drum = GloveSimulator(bursts=[Burst(start=5, duration=2, peak_g=10, rate=5, kind="strokes")])
    drum.truth(k).linear_acceleration        # m/s², NWU; drum.truth(k).specific_force includes it
    with PtyGlove(sim) as glove:             # a pseudo-terminal that streams the frames in real time
        SerialMoteReader(glove.device_path, on_frame=...)

Examples
--------
>>> from pointat.devices import Frame, FrameParser, encode_frame
>>> FrameParser().feed(encode_frame(Frame(2, 9, (2048,) * 9)))[0].n_pack
9
"""

from pointat.devices.glove_sim import (
    GRAVITY,
    Burst,
    GloveSimulator,
    MotionScript,
    PtyGlove,
    Sample,
    Segment,
    SensorModel,
    Truth,
    adc_full_scale,
    burst_acceleration,
    default_script,
    hold,
)
from pointat.devices.mote_frame import (
    ADC_MAX,
    ADC_NULL,
    CHANNELS,
    DEFAULT_RESOLUTION,
    DEFAULT_SPEC,
    FRAME_LEN,
    MAX_LINE,
    SYNC,
    CorruptFrame,
    CounterJump,
    Frame,
    FrameEvent,
    FrameParser,
    Garbage,
    LostPackets,
    MoteSpec,
    MoteStats,
    NewMote,
    ParserStats,
    crc16_ccitt_false,
    encode_frame,
    encode_text,
)
from pointat.devices.serial_reader import (
    DeviceLost,
    DeviceOpened,
    OpenFailed,
    ReaderError,
    ReaderEvent,
    SerialMoteReader,
)

__all__ = [
    "ADC_MAX",
    "ADC_NULL",
    "CHANNELS",
    "DEFAULT_RESOLUTION",
    "DEFAULT_SPEC",
    "FRAME_LEN",
    "GRAVITY",
    "MAX_LINE",
    "SYNC",
    "Burst",
    "CorruptFrame",
    "CounterJump",
    "DeviceLost",
    "DeviceOpened",
    "Frame",
    "FrameEvent",
    "FrameParser",
    "Garbage",
    "GloveSimulator",
    "LostPackets",
    "MoteSpec",
    "MoteStats",
    "MotionScript",
    "NewMote",
    "OpenFailed",
    "ParserStats",
    "PtyGlove",
    "ReaderError",
    "ReaderEvent",
    "Sample",
    "Segment",
    "SensorModel",
    "SerialMoteReader",
    "Truth",
    "adc_full_scale",
    "burst_acceleration",
    "crc16_ccitt_false",
    "default_script",
    "encode_frame",
    "encode_text",
    "hold",
]
