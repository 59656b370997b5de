"""MIDI out and in: exact bytes, a capturing mido port, .mid files read back, and the no-MIDI-system error."""

from __future__ import annotations

import logging
import math
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import mido
import mido.ports
import numpy as np
import pytest

from pointat.errors import PatchError
from pointat.maths.quaternion import azimuth_elevation, pointing_direction
from pointat.maths.scalar import fold_front
from pointat.message import bang, make, method
from pointat.midi_bridge import ports as midi_ports
from pointat.midi_bridge.file_writer import MidiFileWriter
from pointat.midi_bridge.mapping import MidiSender, scale_to_int
from pointat.midi_bridge.ports import MidiUnavailable
from pointat.testing import patch, test_registry, wait_until

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "midi_pan.pat"


def hexes(messages):
    return [m.hex() for m in messages]


# --------------------------------------------------------------------------- port-less messages
def test_cc7_pan_bytes_left_centre_right_and_clipping():
    s = MidiSender("cc", channel=1, number=10, in_range=(90.0, -90.0))
    assert hexes(s.value(90.0)) == ["B0 0A 00"]  # + left -> hard left
    assert hexes(s.value(0.0)) == ["B0 0A 40"]  # front -> centre 64
    assert hexes(s.value(-90.0)) == ["B0 0A 7F"]  # right -> 127
    assert s.value(-170.0) == []  # behind-right clips to 127, already sent
    assert hexes(s.value(45.0)) == ["B0 0A 20"]  # half left: 128 * 0.25 = 32
    assert hexes(s.value(170.0)) == ["B0 0A 00"]  # behind-left clips to hard left


def test_fold_turning_round_pans_back_through_the_centre_instead_of_jumping(tmp_path):
    # a hand turning left from the front round to the back: without fold the pan sits hard left, then
    # jumps to hard right as the azimuth crosses 180; with fold it returns through the centre
    turn = [0.0, 45.0, 90.0, 135.0, 179.0, -179.0, -135.0, -90.0]
    for fold, expected in ((False, [64, 32, 0, 127]), (True, [64, 32, 0, 32, 63, 65, 96, 127])):
        path = tmp_path / f"fold_{fold}.mid"
        rt = patch(f'node pan midi_out number=10 range=[90, -90] fold={str(fold).lower()} file="{path}"')
        rt.advance(0.0)
        for i, az in enumerate(turn):
            rt.nodes["pan"].receive(0, make(az, i * 0.1))
        rt.shutdown()
        sent = [m.value for m in mido.MidiFile(path).tracks[0] if m.type == "control_change"]
        assert sent == expected


def test_centre_has_a_symmetric_rounding_bin():
    # one 7-bit step is 180/128 deg: 64 covers about -0.70..+0.70 deg, symmetric around the front
    values = {scale_to_int(az, 90.0, -90.0, 127) for az in np.linspace(-0.69, 0.69, 101)}
    assert values == {64}
    assert scale_to_int(0.71, 90.0, -90.0, 127) == 63 and scale_to_int(-0.71, 90.0, -90.0, 127) == 65


def test_send_on_change_and_channel():
    s = MidiSender("cc", channel=16, number=7, in_range=(0.0, 1.0))
    assert hexes(s.value(0.5)) == ["BF 07 40"]
    assert s.value(0.501) == []  # maps to 64 again: not resent
    assert hexes(s.resend()) == ["BF 07 40"]  # a bang resends
    always = MidiSender("cc", channel=1, number=7, change=False)
    assert len(always.value(0.5) + always.value(0.5)) == 2


def test_cc14_splits_msb_on_cc_and_lsb_on_cc_plus_32():
    s = MidiSender("cc14", channel=1, number=10, in_range=(0.0, 16383.0))
    assert hexes(s.value(300.0)) == ["B0 0A 02", "B0 2A 2C"]  # 300 = 2 * 128 + 44
    c = MidiSender("cc14", channel=2, number=10, in_range=(90.0, -90.0))
    assert hexes(c.value(0.0)) == ["B1 0A 40", "B1 2A 00"]  # 8192
    assert hexes(c.value(90.0)) == ["B1 0A 00", "B1 2A 00"]
    assert hexes(c.value(-90.0)) == ["B1 0A 7F", "B1 2A 7F"]  # 16383
    with pytest.raises(ValueError, match="0..31"):
        MidiSender("cc14", number=32)


def test_nrpn_sequence_99_98_6_38():
    s = MidiSender("nrpn", channel=3, number=300, in_range=(-180.0, 180.0))
    assert hexes(s.value(0.0)) == ["B2 63 02", "B2 62 2C", "B2 06 40", "B2 26 00"]
    assert hexes(s.value(180.0)) == ["B2 63 02", "B2 62 2C", "B2 06 7F", "B2 26 7F"]
    assert hexes(s.value(-180.0)) == ["B2 63 02", "B2 62 2C", "B2 06 00", "B2 26 00"]


def test_pitch_bend_extremes_and_centre():
    s = MidiSender("pitchbend", channel=1, in_range=(-45.0, 45.0))
    lo, mid, hi = s.value(-45.0), s.value(0.0), s.value(45.0)
    assert hexes(lo + mid + hi) == ["E0 00 00", "E0 00 40", "E0 7F 7F"]
    assert [m.pitch for m in lo + mid + hi] == [-8192, 0, 8191]
    assert s.value(60.0) == []  # clipped to the top, already sent


def test_note_gate_on_off_and_repeats():
    s = MidiSender("note", channel=10, number=60, velocity=90)
    assert hexes(s.value(1.0)) == ["99 3C 5A"]
    assert s.value(1.0) == []  # held: not struck again
    assert hexes(s.value(0.0)) == ["89 3C 00"]
    assert s.value(0.0) == []
    assert hexes(s.hit() + s.hit()) == ["99 3C 5A", "89 3C 00", "99 3C 5A"]  # a hit retriggers
    assert hexes(s.note(62, 30) + s.release()) == ["99 3E 1E", "89 3C 00", "89 3E 00"]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"channel": 0}, "channel must be 1..16"),
        ({"channel": 17}, "channel must be 1..16"),
        ({"kind": "cc", "number": 128}, "0..127"),
        ({"kind": "nrpn", "number": 16384}, "0..16383"),
        ({"in_range": (1.0, 1.0)}, "range"),
        ({"kind": "sysex"}, "kind must be one of"),
        ({"kind": "cc", "number": 121}, "121 reset all controllers.*choose 0..119"),
        ({"kind": "cc", "number": 123}, "a channel-mode message, not a controller"),
    ],
)
def test_bad_mappings_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MidiSender(**kwargs)


def test_a_controller_that_is_a_command_is_taken_with_a_warning(caplog):
    MidiSender(kind="cc14", number=6)  # data entry: rewrites the pitch-bend range, say
    MidiSender(kind="cc", number=7)  # volume: a value to follow
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1 and "kind=cc14 number=6 streams data entry" in said[0]


def test_nan_is_refused():
    with pytest.raises(ValueError):
        MidiSender("cc").value(math.nan)


def test_bad_parameters_fail_the_patch_check_with_the_place():
    with pytest.raises(PatchError, match="channel must be 1..16"):
        patch("node m midi_out channel=17 file=x.mid")
    with pytest.raises(PatchError, match="not both"):
        patch("node m midi_out port=synth file=x.mid")


# --------------------------------------------------------------------------- a capturing port
class CapturePort(mido.ports.BaseOutput):
    """A real mido output port that keeps what it is sent."""

    def _open(self, **kwargs):
        self.sent: list[mido.Message] = []
        self.virtual = kwargs.get("virtual", False)

    def _send(self, msg):
        self.sent.append(msg)


@pytest.fixture
def capture(monkeypatch):
    """Replace the MIDI system by two named capturing ports; returns the ports opened."""
    opened: list[CapturePort] = []

    def fake_open_output(name, *, virtual=False):
        if not virtual and name not in ("Capture Port 1", "Other Synth"):
            raise OSError(f"unknown port {name!r}")
        port = CapturePort(name, virtual=virtual)
        opened.append(port)
        return port

    monkeypatch.setattr(midi_ports, "open_output", fake_open_output)
    monkeypatch.setattr(midi_ports, "output_names", lambda: ["Capture Port 1", "Other Synth"])
    return opened


def test_capturing_port_receives_the_mapped_messages(capture):
    rt = patch("node pan midi_out kind=cc14 number=10 range=[90, -90] port=capture")
    rt.advance(0.0)
    node = rt.nodes["pan"]
    (port,) = capture
    assert port.name == "Capture Port 1"  # a unique part of the name is enough
    for az in (0.0, 0.0001, 90.0):
        node.receive(0, make(az))
    node.receive(0, bang())  # resend the last value
    rt.shutdown()
    assert hexes(port.sent) == ["B0 0A 40", "B0 2A 00", "B0 0A 00", "B0 2A 00", "B0 0A 00", "B0 2A 00"]
    assert port.closed and node.sent == 6


def test_virtual_port_and_notes_released_at_the_end(capture):
    rt = patch("node hit midi_out kind=note number=64 length=200 virtual=true")
    rt.advance(0.0)
    (port,) = capture
    assert port.virtual and port.name == "pointat"
    hit = rt.nodes["hit"]
    hit.receive(0, bang(0.0))  # strike: note off 200 ms later
    rt.advance(0.1)
    assert hexes(port.sent) == ["90 40 64"]
    rt.advance(0.15)
    assert hexes(port.sent) == ["90 40 64", "80 40 00"]
    hit.receive(0, make([67, 50]))  # list: note velocity, still held at the end
    rt.shutdown()
    assert hexes(port.sent)[2:] == ["90 43 32", "80 43 00"]


def test_live_channel_change_releases_held_notes_and_bad_values_are_refused(capture):
    rt = patch("node g midi_out kind=note number=60 port=other")
    rt.advance(0.0)
    (port,) = capture
    g = rt.nodes["g"]
    g.receive(0, make(1))
    g.receive(0, method("channel", 2))
    g.receive(0, make(1))
    with pytest.raises(ValueError, match="channel must be 1..16"):
        g.receive(0, method("channel", 40))  # refused as a whole: nothing changes
    assert g.p.channel == 2 and g.sender.channel == 2
    g.receive(0, method("off"))
    assert hexes(port.sent) == ["90 3C 64", "80 3C 00", "91 3C 64", "81 3C 00"]
    rt.shutdown()  # (its port's watch thread ends with it, not at the end of the test session)


# --------------------------------------------------------------------------- .mid files
def test_mid_file_from_a_patch_with_a_manual_clock(tmp_path):
    path = tmp_path / "out.mid"
    rt = patch(
        f"""
node vol midi_out kind=cc number=7 range=[0, 1] file="{path}"
node hit midi_out kind=note number=60 length=250 file="{path}"
"""
    )
    rt.advance(0.0)
    vol, hit = rt.nodes["vol"], rt.nodes["hit"]
    vol.receive(0, make(0.0, 0.0))
    vol.receive(0, make(0.5, 0.5))
    vol.receive(0, make(0.5001, 0.75))  # the same MIDI value: not written
    vol.receive(0, make(1.0, 1.0))
    rt.advance(1.25)
    hit.receive(0, bang(1.25))  # note on now, off 250 ms later by the scheduler
    rt.advance(1.0)
    vol.receive(0, make(0.25, 2.5))
    rt.shutdown()  # what Ctrl-C does: close every node

    f = mido.MidiFile(path)
    assert f.type == 0 and f.ticks_per_beat == 480
    track = f.tracks[0]
    assert [m.type for m in track if m.is_meta] == ["track_name", "set_tempo", "end_of_track"]
    tempo = next(m.tempo for m in track if m.type == "set_tempo")
    assert tempo == mido.bpm2tempo(120)
    events = [m for m in track if not m.is_meta]
    # 120 bpm x 480 ticks per beat = 960 ticks per second
    assert [(m.hex(), m.time) for m in events] == [
        ("B0 07 00", 0),
        ("B0 07 40", 480),
        ("B0 07 7F", 480),
        ("90 3C 64", 240),
        ("80 3C 00", 240),
        ("B0 07 20", 960),
    ]
    absolute = np.cumsum([m.time for m in events]) / 960.0
    assert absolute.tolist() == [0.0, 0.5, 1.0, 1.25, 1.5, 2.5]


def test_mid_file_tempo_and_resolution_are_parameters(tmp_path):
    path = tmp_path / "ms.mid"
    rt = patch(f'node b midi_out kind=pitchbend range=[-1, 1] bpm=60 ppq=1000 file="{path}"')
    rt.advance(0.0)
    for t, v in [(0.0, -1.0), (0.001, 0.0), (0.0015, 1.0), (0.0012, -1.0)]:
        rt.nodes["b"].receive(0, make(v, t))
    rt.shutdown()
    f = mido.MidiFile(path)
    events = [m for m in f.tracks[0] if not m.is_meta]
    # 1 tick = 1 ms; 1.5 ms rounds to 2; a time stamp going back is written at the same tick
    assert [(m.pitch, m.time) for m in events] == [(-8192, 0), (0, 1), (8191, 1), (-8192, 0)]
    assert next(m.tempo for m in f.tracks[0] if m.type == "set_tempo") == 1_000_000


def test_file_is_readable_after_every_message_before_it_is_closed(tmp_path):
    path = tmp_path / "live.mid"
    w = MidiFileWriter(path)
    w.write(mido.Message("control_change", control=10, value=1), 0.5)
    w.write(mido.Message("control_change", control=10, value=2), 1.0)
    assert [m.value for m in mido.MidiFile(path).tracks[0] if not m.is_meta] == [1, 2]  # as a crash leaves it
    w.close()
    w.close()  # idempotent
    assert mido.MidiFile(path).tracks[0][-1].type == "end_of_track"


def test_a_damaged_time_stamp_is_refused_and_the_file_still_reads(tmp_path):
    # a replayed row stamped 1e300 wrote a delta of ~1e302 ticks: no MIDI reader took the file after it
    path = tmp_path / "take.mid"
    w = MidiFileWriter(path)
    w.write(mido.Message("control_change", control=10, value=1), 0.5)
    for bad in (1e300, math.inf, math.nan):
        with pytest.raises(ValueError, match="not written"):
            w.write(mido.Message("control_change", control=10, value=9), bad)
    w.write(mido.Message("control_change", control=10, value=2), 1.0)
    w.close()
    got = [(m.value, m.time) for m in mido.MidiFile(path).tracks[0] if not m.is_meta]
    assert got == [(1, 480), (2, 480)]  # 120 bpm, 480 per beat: 0.5 s apart


def test_a_full_disk_leaves_the_file_as_it_was_and_never_half_a_14_bit_value(tmp_path):
    # the buffered bytes of a failed write landed later: a 60 s take read as 3434 s, CC1 without its CC33
    import errno

    class FullDisk:  # the file, with room for `room` more bytes at the end of the track
        def __init__(self, fh, room):
            self.fh, self.room = fh, room

        def write(self, data):
            if self.fh.tell() >= self.room:  # a raw write takes what fits, then fails
                raise OSError(errno.ENOSPC, "No space left on device")
            n = self.fh.write(bytes(data[: self.room - self.fh.tell()]))
            return n

        def __getattr__(self, name):
            return getattr(self.fh, name)

    path = tmp_path / "take.mid"
    w = MidiFileWriter(path)
    pair = [
        mido.Message("control_change", control=1, value=64),
        mido.Message("control_change", control=33, value=5),
    ]
    w.write_all(pair, 0.5)
    w._fh = FullDisk(w._fh, w._fh.tell() + 5)  # room for half of the next pair
    for t in (1.0, 1.5):
        with pytest.raises(OSError):
            w.write_all(pair, t)
    w._fh = w._fh.fh  # room again (a file deleted elsewhere)
    w.write_all(pair, 2.0)
    w.close()
    got = [(m.control, m.time) for m in mido.MidiFile(path).tracks[0] if not m.is_meta]
    assert got == [(1, 480), (33, 0), (1, 1440), (33, 0)]  # 0.5 s, then 2.0 s: nothing of the failed ones


def test_a_write_interrupted_midway_is_cut_off_too(tmp_path):
    # Ctrl-C in a notebook between the events and the track's length: their bytes were left behind the
    # end-of-track that close() wrote over the first of them
    class Interrupted:
        def __init__(self, fh):
            self.fh, self.calls = fh, 0

        def write(self, data):
            self.calls += 1
            if self.calls == 2:  # the events went in; the length did not
                raise KeyboardInterrupt
            return self.fh.write(data)

        def __getattr__(self, name):
            return getattr(self.fh, name)

    path = tmp_path / "take.mid"
    w = MidiFileWriter(path)
    w.write(mido.Message("control_change", control=7, value=1), 0.5)
    size = path.stat().st_size
    w._fh = Interrupted(w._fh)
    with pytest.raises(KeyboardInterrupt):
        w.write(mido.Message("control_change", control=7, value=2), 1.0)
    w._fh = w._fh.fh
    assert path.stat().st_size == size
    w.close()
    data = path.read_bytes()
    assert len(data) == 14 + 8 + int.from_bytes(data[18:22], "big")  # nothing behind the track
    assert [m.value for m in mido.MidiFile(path).tracks[0] if not m.is_meta] == [1]


def test_what_a_full_disk_refused_is_still_owed_when_room_comes(tmp_path, monkeypatch):
    # the fader's value was taken for sent though the disk refused it: with change=true the take held the
    # old value until the fader moved; a note-off refused was forgotten, and the note hung to the end
    import errno

    path = tmp_path / "take.mid"
    rt = patch(
        f"""
node vol midi_out kind=cc number=7 range=[0, 1] file="{path}"
node gate midi_out kind=note number=60 file="{path}"
"""
    )
    rt.advance(0.0)
    vol, gate = rt.nodes["vol"], rt.nodes["gate"]
    writer = vol._sink.writer
    vol.receive(0, make(0.0, 0.0))
    gate.receive(0, make(1.0, 0.0))  # note on

    def full(messages, time):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(writer, "write_all", full)
    with pytest.raises(OSError):
        vol.receive(0, make(1.0, 0.5))
    with pytest.raises(OSError):
        gate.receive(0, make(0.0, 0.5))  # note off
    monkeypatch.undo()  # room again
    vol.receive(0, make(1.0, 1.0))  # the fader stayed up: written now
    rt.shutdown()  # the note still sounding in the file is released at the end
    events = [m.hex() for m in mido.MidiFile(path).tracks[0] if not m.is_meta]
    assert events == ["B0 07 00", "90 3C 64", "B0 07 7F", "80 3C 00"]


def test_no_port_and_no_file_falls_back_to_a_file_when_there_is_no_midi_system(tmp_path, monkeypatch, caplog):
    def no_system():
        raise ImportError("No module named 'rtmidi'")

    monkeypatch.setattr(midi_ports, "output_names", no_system)
    monkeypatch.chdir(tmp_path)
    rt = patch("node pan midi_out number=10 range=[90, -90]")
    with caplog.at_level(logging.WARNING, logger="pointat.midi"):
        rt.advance(0.0)
    assert "writing" in caplog.text and "pan.mid" in caplog.text
    rt.nodes["pan"].receive(0, make(-90.0))
    rt.shutdown()
    assert hexes(m for m in mido.MidiFile(tmp_path / "pan.mid").tracks[0] if not m.is_meta) == ["B0 0A 7F"]


def test_with_no_midi_system_the_file_goes_beside_the_patch_not_into_the_working_directory(
    tmp_path, monkeypatch
):
    """A patch kept in a folder of its own and run from another: ``NODE.mid`` is written beside the patch,
    as a ``file=NODE.mid`` written in it would be, and the folder it was run from gets nothing."""

    def no_system():
        raise ImportError("No module named 'rtmidi'")

    monkeypatch.setattr(midi_ports, "output_names", no_system)
    show, elsewhere = tmp_path / "show", tmp_path / "elsewhere"
    show.mkdir()
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    rt = patch("node n1 midi_out kind=note number=60", file=str(show / "notes.pat"))
    rt.advance(0.0)
    rt.nodes["n1"].receive(0, make(1.0))
    rt.shutdown()
    events = [m.hex() for m in mido.MidiFile(show / "n1.mid").tracks[0] if not m.is_meta]
    assert events == ["90 3C 64", "80 3C 00"]  # the note held is released as the patch stops
    assert list(elsewhere.iterdir()) == []


def test_a_shipped_patch_names_its_midi_files_in_its_out_folder(tmp_path):
    """A shipped patch is read-only: its files go to ``pointat run --out`` (the working directory by
    default), the fallback MIDI file too."""
    from pointat.checking import check
    from pointat.expansion import read_spec
    from pointat.loader import build

    spec = read_spec(str(ROOT / "patches" / "gestures.pat"))
    spec.out = str(tmp_path)
    checked = check(spec, test_registry())
    assert {checked.nodes[n].folder for n in ("n1", "n2", "n3")} == {tmp_path}
    rt = build(checked, realtime=False)
    try:
        assert rt.nodes["n1"]._fallback_file() == tmp_path.resolve() / "n1.mid"
    finally:
        rt.shutdown()


# --------------------------------------------------------------------------- no MIDI system
def _start_error(text: str) -> str:
    rt = patch(text)
    node = next(iter(rt.nodes.values()))
    with pytest.raises(MidiUnavailable) as info:
        node.start()
    rt.shutdown()
    return str(info.value)


def test_a_port_without_a_midi_system_is_a_clear_error_real_mido():
    """Through the real mido and whatever backend this machine has (none here: no python-rtmidi or
    no /dev/snd; a real system still has no port of this name)."""
    msg = _start_error('node pan midi_out port="pointat-test-no-such-port"')
    assert "midi_out 'pan'" in msg and "pointat-test-no-such-port" in msg
    assert "To fix" in msg and "file=pan.mid" in msg


class RtMidiSystemError(OSError):
    """What python-rtmidi raises without /dev/snd (rtmidi.SystemError derives from OSError)."""


def test_rtmidi_system_error_names_the_node_and_the_fix(monkeypatch):
    def alsa_down(*args, **kwargs):
        raise RtMidiSystemError("MidiOutAlsa::initialize: error creating ALSA sequencer client object.")

    monkeypatch.setattr(midi_ports, "open_output", alsa_down)
    monkeypatch.setattr(midi_ports, "output_names", alsa_down)
    msg = _start_error('node synth midi_out port="IAC Bus 1"')
    assert msg.startswith("midi_out 'synth': cannot open MIDI output port 'IAC Bus 1': no MIDI system")
    assert "ALSA sequencer" in msg  # the backend's own words
    assert (
        "/dev/snd/seq" in msg
        and "CoreMIDI" in msg
        and "; or write a MIDI file instead with file=synth.mid" in msg
    )


def test_missing_python_rtmidi_and_unknown_port_messages(monkeypatch, capture):
    msg = _start_error("node synth midi_out port=Moog")
    assert "Output ports: 'Capture Port 1', 'Other Synth'" in msg and "virtual=true" in msg

    def no_rtmidi(*args, **kwargs):
        raise ModuleNotFoundError("No module named 'rtmidi'")

    monkeypatch.setattr(midi_ports, "open_output", no_rtmidi)
    msg = _start_error("node synth midi_out virtual=true")
    assert "python-rtmidi, the backend mido uses, is not installed" in msg
    assert "pip install 'pointat[midi]'" in msg and "file=synth.mid" in msg


def test_a_port_that_cannot_open_stops_the_patch_before_it_runs():
    from pointat.runtime import StartError

    rt = patch('node pan midi_out port="pointat-test-no-such-port"')
    with pytest.raises(StartError, match=r"node 'pan' \(midi_out\): cannot start: .*To fix"):
        rt.advance(0.01)
    assert not rt.running


def test_midi_in_without_a_midi_system_is_a_clear_error():
    msg = _start_error('node foot midi_in port="pointat-test-no-such-port"')
    assert "midi_in 'foot'" in msg and "To fix" in msg and "file=" not in msg


# --------------------------------------------------------------------------- midi_in
class FootPort(mido.ports.BaseInput):
    """A real mido input port; the test plays the foot controller by calling its callback."""

    def _open(self, callback=None, **kwargs):
        self.callback = callback


def test_midi_in_outputs_cc_lists_and_note_events(monkeypatch):
    ports: list[FootPort] = []

    def fake_open_input(name, *, virtual=False, callback=None):
        ports.append(FootPort(name, callback=callback))
        return ports[-1]

    monkeypatch.setattr(midi_ports, "open_input", fake_open_input)
    monkeypatch.setattr(midi_ports, "input_names", lambda: ["FCB1010 MIDI 1"])
    rt = patch(
        """
node foot midi_in port=FCB1010 channel=1
node cc collect
node note collect
node bend collect
node other collect
foot.cc -> cc
foot.note -> note
foot.bend -> bend
foot.other -> other
"""
    )
    rt.advance(0.0)
    (port,) = ports
    assert port.name == "FCB1010 MIDI 1"
    played = [
        mido.Message("control_change", control=64, value=127),
        mido.Message("control_change", control=64, value=0),
        mido.Message("control_change", channel=1, control=7, value=5),  # channel 2: filtered out
        mido.Message("note_on", note=36, velocity=100),
        mido.Message("note_on", note=36, velocity=0),
        mido.Message("note_off", note=38, velocity=64),
        mido.Message("pitchwheel", pitch=-8192),
        mido.Message("program_change", program=5),
    ]
    th = threading.Thread(target=lambda: [port.callback(m) for m in played])  # as the backend's thread
    th.start()
    th.join(timeout=5)
    rt.advance(0.01)
    nodes = rt.nodes
    assert nodes["cc"].values == [(64, 127), (64, 0)]
    assert nodes["note"].values == [(36, 100), (36, 0), (38, 0)]
    assert nodes["bend"].values == [-8192]
    assert [m.describe() for m in nodes["other"].messages] == ["program_change 5"]
    assert rt.nodes["foot"].active
    rt.shutdown()
    assert port.closed and not rt.nodes["foot"].active


def _settle(rt, predicate):
    """Advance the manual clock (which runs what the watch thread posted) until ``predicate`` holds."""

    def step():
        rt.advance(0.0)
        return predicate()

    return wait_until(step, timeout=5.0)


def test_midi_in_unplugged_mid_show_is_reported_and_reopened_when_it_is_back(monkeypatch, caplog):
    ports: list[FootPort] = []
    names = ["FCB1010:FCB1010 MIDI 1 20:0"]

    def fake_open_input(name, *, virtual=False, callback=None):
        if name not in names:
            raise OSError(f"no port {name!r}")
        ports.append(FootPort(name, callback=callback))
        return ports[-1]

    monkeypatch.setattr(midi_ports, "open_input", fake_open_input)
    monkeypatch.setattr(midi_ports, "input_names", lambda: list(names))
    monkeypatch.setattr(midi_ports, "WATCH_PERIOD", 0.01)
    rt = patch("node foot midi_in port=FCB1010\nnode cc collect\nfoot.cc -> cc")
    foot = rt.nodes["foot"]
    caplog.set_level(logging.INFO, logger="pointat.midi")
    rt.advance(0.0)
    assert foot.active and ports[0].name == names[0]

    names.clear()  # the cable is pulled
    assert _settle(rt, lambda: not foot.active)
    assert ports[0].closed
    gone = [r.getMessage() for r in caplog.records if "is gone" in r.getMessage()]
    assert gone == [
        "midi_in 'foot': MIDI input port 'FCB1010:FCB1010 MIDI 1 20:0' is gone (unplugged?); waiting for it to come back"
    ]

    names.append("FCB1010:FCB1010 MIDI 1 24:0")  # plugged back in: ALSA gives it a new client number
    assert _settle(rt, lambda: foot.active)
    assert [p.name for p in ports] == ["FCB1010:FCB1010 MIDI 1 20:0", "FCB1010:FCB1010 MIDI 1 24:0"]
    assert any("is back" in r.getMessage() for r in caplog.records)
    th = threading.Thread(
        target=ports[1].callback, args=(mido.Message("control_change", control=64, value=127),)
    )
    th.start()
    th.join(timeout=5)
    assert _settle(rt, lambda: rt.nodes["cc"].values == [(64, 127)])
    assert len([r for r in caplog.records if "is gone" in r.getMessage()]) == 1  # said once, not every second
    rt.shutdown()
    assert ports[1].closed


class SynthPort(mido.ports.BaseOutput):
    """A real mido output port that keeps what it is sent."""

    def _open(self, **kwargs):
        self.sent = []

    def _send(self, msg):
        self.sent.append(msg)


def test_midi_out_drops_while_unplugged_and_catches_the_receiver_up_when_it_is_back(monkeypatch, caplog):
    ports: list[SynthPort] = []
    names = ["Synth:Synth MIDI 1 28:0"]

    def fake_open_output(name, *, virtual=False):
        if name not in names:
            raise OSError(f"no port {name!r}")
        ports.append(SynthPort(name))
        return ports[-1]

    monkeypatch.setattr(midi_ports, "open_output", fake_open_output)
    monkeypatch.setattr(midi_ports, "output_names", lambda: list(names))
    monkeypatch.setattr(midi_ports, "WATCH_PERIOD", 0.01)
    rt = patch("node vol midi_out kind=cc number=7 range=[0, 1] port=Synth")
    vol = rt.nodes["vol"]
    caplog.set_level(logging.WARNING)
    rt.advance(0.0)
    vol.receive(0, make(0.5, 0.0))
    assert hexes(ports[0].sent) == ["B0 07 40"]

    names.clear()
    assert _settle(rt, lambda: any("is gone" in r.getMessage() for r in caplog.records))
    vol.receive(0, make(1.0, 0.1))  # the hand moves on while the synth is unplugged: no error, counted
    assert vol.dropped == 1 and ports[0].closed and hexes(ports[0].sent) == ["B0 07 40"]
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]

    names.append("Synth:Synth MIDI 1 32:0")
    assert _settle(rt, lambda: len(ports) == 2)
    assert hexes(ports[1].sent) == ["B0 07 7F"]  # the value it missed, sent again when it is back
    vol.receive(0, make(0.0, 0.2))
    assert hexes(ports[1].sent) == ["B0 07 7F", "B0 07 00"]
    rt.shutdown()
    assert ports[1].closed


# --------------------------------------------------------------------------- the example patch
def test_example_passes_pointat_check():
    exe = shutil.which("pointat")
    cmd = [exe] if exe else [sys.executable, "-m", "pointat.cli"]
    done = subprocess.run([*cmd, "check", str(EXAMPLE)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "ok" in done.stdout


def test_example_pans_with_the_true_azimuth(tmp_path):
    """Run the example on the manual clock into a file; CC10 follows the simulated glove's true azimuth."""
    out = tmp_path / "pan.mid"
    text = EXAMPLE.read_text().replace("file=midi_pan.mid", f'file="{out}"')
    assert str(out) in text
    rt = patch(text + "\nnode truth collect\nglove.truth -> truth\n")
    rt.advance(12.0)
    rt.shutdown()
    track = mido.MidiFile(out).tracks[0]
    times = np.cumsum([m.time for m in track]) / 960.0
    cc = [(t, m.value) for t, m in zip(times, track, strict=True) if m.type == "control_change"]
    assert all(m.control == 10 and m.channel == 0 for m in track if m.type == "control_change")
    assert len(cc) > 50 and {v for _, v in cc} >= {0, 64}  # swept from the front to hard left
    truth = {round(m.time, 4): m.value for m in rt.nodes["truth"].messages}
    errors = []
    for t, value in cc:
        if t < 3.0:  # the nulls and the filter settle first
            continue
        sample = round(round(t * 100.0) / 100.0, 4)  # ticks are 1/960 s; samples every 10 ms
        az, _ = azimuth_elevation(pointing_direction(truth[sample]))
        errors.append(abs(value - scale_to_int(fold_front(float(az)), 90.0, -90.0, 127)))
    assert len(errors) > 30 and max(errors) <= 2, max(errors)  # 2 steps = 2.8 deg of filter error


# --------------------------------------------------------------------------- the banner's words
def test_the_banner_names_the_port_or_file_each_midi_node_uses(capture, tmp_path, monkeypatch):
    from pointat.console import describe

    monkeypatch.chdir(tmp_path)
    rt = patch(
        "node a midi_out number=10\nnode b midi_out port=other\nnode c midi_out file=pan.mid\n"
        'node d midi_out virtual=true port="Show"\n'
    )
    said = {name: describe(rt.nodes[name]) for name in "abcd"}
    assert said["a"] == "midi_out 'a': MIDI port 'Capture Port 1' (the system's first)", said
    assert said["b"] == "midi_out 'b': MIDI port 'other'", said
    assert said["c"].startswith("midi_out 'c': MIDI file ") and said["c"].endswith("pan.mid"), said
    assert said["d"] == "midi_out 'd': a virtual MIDI port 'Show' for other programs to connect to", said
    rt.advance(0.0)  # started: the port each opened, by its whole name
    assert describe(rt.nodes["b"]) == "midi_out 'b': MIDI port 'Other Synth'"
    rt.shutdown()


def test_the_banner_says_which_file_is_written_when_there_is_no_midi_system(tmp_path, monkeypatch):
    from pointat.console import describe

    def no_rtmidi():
        raise ImportError("No module named 'rtmidi'")

    monkeypatch.setattr(midi_ports, "output_names", no_rtmidi)
    monkeypatch.chdir(tmp_path)
    rt = patch("node pan midi_out number=10")
    assert describe(rt.nodes["pan"]) == (
        f"midi_out 'pan': MIDI file {tmp_path.resolve() / 'pan.mid'} "
        "(no MIDI port: python-rtmidi is not installed: pip install 'pointat[midi]')"
    )
    rt.shutdown()
