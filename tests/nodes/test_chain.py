"""The Pointing-at chain on the simulated glove, against its ground truth."""

import math
import socket
import sys
from pathlib import Path

import numpy as np
import pytest

from pointat.devices.glove_sim import GloveSimulator
from pointat.maths.calibration import Calibration
from pointat.maths.quaternion import matrix_to_quat, quat_angle
from pointat.message import make, vector
from pointat.testing import patch

LIB = Path(__file__).resolve().parents[2] / "patches" / "lib"

FRONT_END = """
node glove simulate rate=100 seed={seed}
node nulls offset samples=150
node units scaling
node truth collect
glove.truth -> truth
glove.adc -> nulls -> units
"""


def units_into(fusion):
    """The wires from node ``units`` (a ``scaling``) to node ``fusion``'s mag, accel and gyro inlets."""
    return "".join(f"units.{s} -> {fusion}.{s}\n" for s in ("mag", "accel", "gyro"))


def glove_into(fusion, seed, text):
    """The simulated glove's front end into node ``fusion``'s mag, accel and gyro inlets, plus ``text``."""
    return patch(FRONT_END.format(seed=seed) + text + units_into(fusion))


def fusion_half(fusion, seed, text):
    """A shipped fusion half (patches/lib/FUSION.pat) as node ``f`` on the simulated glove, plus ``text``."""
    return glove_into("f", seed, f"node f {LIB / fusion}.pat rate=100\n" + text)


def by_time(rt, name):
    """What a collect node received, by its time stamp to 10 ms."""
    return {round(m.time, 2): m.value for m in rt.nodes[name].messages}


def _errors(rt, est_name, t_from=3.0):
    est = {round(m.time, 6): m.value for m in rt.nodes[est_name].messages}
    pairs = [
        (est[round(m.time, 6)], m.value)
        for m in rt.nodes["truth"].messages
        if m.time >= t_from and round(m.time, 6) in est
    ]
    q_est = np.array([p[0] for p in pairs])
    q_true = np.array([p[1] for p in pairs])
    if q_est.shape[1:] == (9,):  # rotation matrices, row major
        q_est = matrix_to_quat(q_est.reshape(-1, 3, 3))
    return np.degrees(quat_angle(q_est, q_true))


@pytest.mark.parametrize("mode, mean_bound, max_bound", [("robust", 1.5, 4.0), ("paper", 3.0, 8.0)])
def test_tqt_tracks_the_simulated_glove(mode, mean_bound, max_bound):
    rt = glove_into(
        "fuse",
        1,
        f"""
node fuse tqt mode={mode}
node est collect
fuse.quat -> est
""",
    )
    rt.advance(45.0)  # the whole demo script: sweeps, holds, raise, the roll gesture
    err = _errors(rt, "est")
    assert len(err) > 4000
    assert err.mean() < mean_bound and err.max() < max_bound, (err.mean(), err.max())


def test_torre_chain_tracks_the_simulated_glove():
    rt = patch(
        FRONT_END.format(seed=2)
        + """
node gyro gyro_integrator mode=torre
node accmag accmag_matrix
node fuse complementary crossover=0.2
node est collect
units.mag -> accmag.mag
units.accel -> accmag.accel
units.gyro -> gyro
accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> est
"""
    )
    rt.advance(45.0)
    err = _errors(rt, "est")
    assert len(err) > 4000
    assert err.mean() < 3.0 and err.max() < 10.0, (err.mean(), err.max())


def test_gyro_integrator_alone_drifts_with_the_bias():
    rt = patch(
        FRONT_END.format(seed=3)
        + """
node gyro gyro_integrator mode=exact
node est collect
units.gyro -> gyro -> est
"""
    )
    rt.advance(45.0)
    err = _errors(rt, "est", t_from=0)
    # the offset node removed the bias it saw at rest, so what remains is noise integrated: small but growing
    assert err[-1] < 15.0
    assert err[-1] > err[100]


def test_azimuth_elevation_follow_the_script():
    rt = glove_into(
        "fuse",
        4,
        """
node fuse tqt
node dir azi_ele
node az collect
node el collect
fuse.quat -> dir
dir.azimuth -> az
dir.elevation -> el
""",
    )
    rt.advance(25.0)
    az = by_time(rt, "az")
    el = by_time(rt, "el")
    # the script holds at +30 (3.5-4.5 s), +110 (6.5-7.5 s), -110 (11.5-12.5 s), up 45 (18.5-19.5 s)
    assert az[4.0] == pytest.approx(30.0, abs=2.0)
    assert az[7.0] == pytest.approx(110.0, abs=2.0)
    assert az[12.0] == pytest.approx(-110.0, abs=2.0)
    assert el[19.0] == pytest.approx(45.0, abs=2.0)


def test_roll_gesture_switches_azimuth_to_distance():
    rt = glove_into(
        "fuse",
        5,
        """
node fuse tqt
node roll roll_distance
node az collect
node dist collect
node mode collect
fuse.quat -> roll
roll.azimuth -> az
roll.distance -> dist
roll.mode -> mode
""",
    )
    rt.advance(40.0)
    modes = [(round(m.time, 1), m.value) for m in rt.nodes["mode"].messages]
    assert [m for _, m in modes] == ["distance", "azimuth"]  # once in, once out: no flicker
    t_in, t_out = modes[0][0], modes[1][0]
    assert 25.0 < t_in < 26.0 and 32.5 < t_out < 33.5  # roll 25-26 s, roll back 32.5-33.5 s
    dist = by_time(rt, "dist")
    az = by_time(rt, "az")
    # rolled, the hand sweeps 0 -> 60 deg left (distance rises by ~60), then back to 20
    assert dist[29.5] == pytest.approx(60.0, abs=3.0)
    assert dist[32.0] == pytest.approx(20.0, abs=3.0)
    assert az[29.5] == pytest.approx(0.0, abs=2.0)  # the azimuth holds while rolled


@pytest.mark.parametrize("fusion", ["tqt_fusion", "torre_fusion"])
def test_the_shipped_fusion_halves_hold_the_azimuth_while_the_roll_sets_the_distance(fusion):
    # Torre §5.2: rolled 90 deg, the azimuth is *read as* distance: the source stays where it was
    rt = fusion_half(
        fusion,
        5,
        """
node az collect
node dist collect
f.azimuth -> az
f.distance -> dist
""",
    )
    rt.advance(40.0)
    az = by_time(rt, "az")
    dist = by_time(rt, "dist")
    # rolled (25-26 s), the hand sweeps 0 -> 60 deg left: the distance follows, the azimuth does not
    assert dist[29.5] == pytest.approx(60.0, abs=5.0)
    assert az[29.5] == az[27.0]  # held, to the bit
    assert abs(az[29.5]) < 5.0
    assert az[34.0] == pytest.approx(20.0, abs=5.0)  # unrolled, the azimuth follows the hand again


@pytest.mark.parametrize("fusion", ["tqt_fusion", "torre_fusion"])
def test_a_bang_at_the_fusion_halves_reference_inlet_makes_where_the_hand_points_azimuth_0(fusion):
    rt = fusion_half(
        fusion,
        4,
        """
node press msg bang
node az collect
node el collect
press -> f.reference
f.azimuth -> az
f.elevation -> el
""",
    )
    rt.advance(4.0)  # the hand holds at the front-left speaker, +30 (3.5-4.5 s)
    assert by_time(rt, "az")[4.0] == pytest.approx(30.0, abs=3.0)
    rt.send("press", "bang")  # "point at the front speaker and press"
    rt.advance(15.0)
    az, el = by_time(rt, "az"), by_time(rt, "el")
    assert az[4.2] == pytest.approx(0.0, abs=1.0)  # where it pointed is the front now
    assert az[7.0] == pytest.approx(80.0, abs=3.0)  # the +110 speaker, 80 to the left of it
    assert el[7.0] == pytest.approx(0.0, abs=3.0)  # heading only: the horizon stays the horizon


@pytest.mark.parametrize("fusion", ["tqt_fusion", "torre_fusion"])
def test_the_fusion_halves_deliver_elevation_before_the_hot_azimuth(fusion):
    # a receiver (osc_out, pack) takes its update when the azimuth arrives: the elevation stored by then
    # must be this sample's, not the previous one's
    rt = fusion_half(
        fusion,
        4,
        """
node both pack 0 0
node pairs collect
node el collect
f.elevation -> el
f.elevation -> both.1
f.azimuth -> both.0
both -> pairs
""",
    )
    rt.advance(20.0)  # through the raise (17-18.5 s), where the elevation changes every sample
    el = by_time(rt, "el")
    pairs = by_time(rt, "pairs")
    raising = [t for t in pairs if 17.2 < t < 18.3]
    assert len(raising) > 100
    assert all(pairs[t][1] == el[t] for t in raising)


def test_bad_samples_never_reach_downstream_as_nan():
    from pointat.message import vector

    rt = patch("""
node fuse tqt
node out collect
node flags collect
fuse.quat -> out
fuse.flags -> flags
""")
    f = rt.nodes["fuse"]
    good = ([0.0, 0.0, 0.0], [0.0, 0.0, 9.8], [0.2, 0.0, -0.4])
    nan = [float("nan")] * 3
    for k, (g, a, m) in enumerate([good, (nan, [0, 0, 0], good[2]), good]):
        f.receive(2, vector(m, k * 0.01))
        f.receive(1, vector(a, k * 0.01))
        f.receive(0, vector(g, k * 0.01))
    assert all(np.all(np.isfinite(q)) for q in rt.nodes["out"].values)
    assert rt.nodes["flags"].values[0].startswith("gyro_invalid")
    assert rt.nodes["flags"].values[-1] == "ok"


def test_tqt_gains_are_live():
    from pointat.message import method

    rt = patch("node fuse tqt\n")
    f = rt.nodes["fuse"]
    rt.start()
    f.receive(0, method("k_heading", 0.2))
    f.receive(0, method("k", 3.0))
    assert (f.filter.k_heading, f.filter.k) == (0.2, 3.0)
    with pytest.raises(ValueError, match="cannot change while running"):
        f.receive(0, method("mode", "paper"))


def test_tqt_steps_of_a_packet_counter_clock_are_the_nominal_step(monkeypatch):
    """Sensor time t0 + n / rate differs from 1 / rate by rounding from sample to sample; the node takes
    the nominal step then, and a real gap as it is (the filter's coefficients follow the step)."""
    from pointat.maths.tqt import TQTFilter
    from pointat.message import floats

    steps = []
    original = TQTFilter.update
    monkeypatch.setattr(
        TQTFilter, "update", lambda self, g, a, m, dt: steps.append(dt) or original(self, g, a, m, dt)
    )
    rt = patch("node fuse tqt rate=1000\n")
    f = rt.nodes["fuse"]
    rt.start()
    t0 = 12345.678901  # a host time stamp, as the mote node anchors its clock
    times = [t0 + n / 1000.0 for n in range(300)] + [t0 + 0.3005]  # then one and a half periods
    assert len({b - a for a, b in zip(times[:-1], times[1:], strict=True)}) > 1  # the rounding is there
    for t in times:
        f.receive(2, floats((0.2, 0.0, -0.4), t))
        f.receive(1, floats((0.0, 0.0, 9.81), t))
        f.receive(0, floats((0.01, 0.0, 0.0), t))
    assert set(steps[:-1]) == {0.001}
    assert steps[-1] == pytest.approx(0.0015, abs=1e-9)


FRAME_FUNCTIONS = {
    ("nwu", "enu"): ["nwu_to_enu"],
    ("enu", "nwu"): ["enu_to_nwu"],
    ("nwu", "ned"): ["nwu_to_ned"],
    ("ned", "nwu"): ["ned_to_nwu"],
    ("enu", "ned"): ["enu_to_nwu", "nwu_to_ned"],
    ("ned", "enu"): ["ned_to_nwu", "nwu_to_enu"],
    ("enu", "enu"): [],
}


@pytest.mark.parametrize("pair", list(FRAME_FUNCTIONS), ids="->".join)
@pytest.mark.parametrize("positive", [True, False])
def test_reframe_matches_the_reference_conversions(pair, positive):
    from pointat.maths import quaternion as qm
    from pointat.message import floats

    source, target = pair
    rt = patch(f"node f reframe source={source} target={target} positive={str(positive).lower()}\n")
    rt.start()
    f = rt.nodes["f"]
    out = []
    f.out = lambda outlet, msg: out.append(msg)  # what leaves, exactly
    rng = np.random.default_rng(7)
    qs = rng.normal(size=(50, 4))
    qs /= np.linalg.norm(qs, axis=1, keepdims=True)
    for q in qs:
        f.receive(0, floats(tuple(q.tolist()), 0.0))
    expected = qs
    for name in FRAME_FUNCTIONS[pair]:
        expected = getattr(qm, name)(expected)
    if positive:
        expected = qm.quat_positive(expected)
    got = np.array([m.value for m in out])
    assert got.shape == (50, 4)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    if positive:
        assert (got[:, 0] >= 0).all()
    else:
        assert (got[:, 0] < 0).any()  # the sign as it comes: some of the random ones have w < 0


def _numpy_calls(frame, event, arg, seen):
    """A profile hook: note every numpy function called (Python-level, or numpy's C functions and methods)."""
    if event == "call":
        if "numpy" in frame.f_code.co_filename:
            seen.append(frame.f_code.co_name)
    elif event == "c_call":
        owner = getattr(arg, "__self__", None)
        module = getattr(arg, "__module__", None) or type(owner).__module__
        if module and module.split(".")[0] == "numpy":
            seen.append(arg.__name__)


@pytest.mark.parametrize("fusion", ["torre_fusion", "tqt_fusion"])
def test_the_per_sample_path_calls_no_numpy(fusion):
    """From the ADC vector to the OSC datagram every sample is plain floats: a numpy call costs a few
    microseconds warm and far more in a process that slept between samples, and a periodic one (a
    re-orthonormalisation every 100 samples) sits right at the p99 of the latency."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as hole:
        hole.bind(("127.0.0.1", 0))
        rt = patch(
            f"""
node nulls offset samples=100
node units scaling
node f {LIB / fusion}.pat rate=1000
node out osc_out host=127.0.0.1 port={hole.getsockname()[1]}
nulls -> units
f.azimuth -> out.azimuth
f.elevation -> out.elevation
f.distance -> out.distance
"""
            + units_into("f")
        )
        rt.start()
        sim = GloveSimulator(rate_hz=1000.0, seed=3)
        adc = [vector(s.frame.channels, k / 1000.0) for k, s in enumerate(sim.samples(700))]
        first = rt.nodes["nulls"]
        seen: list[str] = []
        try:
            for m in adc[:300]:  # the nulls are averaged, the filters are started
                first.receive(0, m)
            sent = rt.nodes["out"].sent
            sys.setprofile(lambda frame, event, arg: _numpy_calls(frame, event, arg, seen))
            try:
                for m in adc[300:]:  # 400 samples: the integrator's renormalisation (every 100) is among them
                    first.receive(0, m)
            finally:
                sys.setprofile(None)
        finally:
            rt.shutdown()
    assert rt.nodes["out"].sent - sent == 400  # every sample went the whole way
    assert seen == []


def test_scaling_tells_tqt_the_adcs_full_scale_so_a_clipped_axis_is_known(tmp_path):
    """scaling's range (the ADC's rails through its resolutions) reaches tqt at start; with a calibration
    file's nulls it is their nearer rail's, without them mid-scale less 5 % (said early, never late)."""
    wires = "fuse.quat -> est\nunits.range -> fuse.range\nunits.range -> scale\n"
    rt = glove_into("fuse", 1, "node fuse tqt\nnode est collect\nnode scale collect\n" + wires)
    rt.start()
    (acc, gyro), rail = rt.nodes["scale"].values[-1], 2048 - 0.05 * 4095
    assert (acc, gyro) == pytest.approx((rail * 0.0192, rail * math.radians(0.1)))
    f = rt.nodes["fuse"].filter
    assert (f.acc_range, f.gyro_range) == (acc, gyro)
    path = tmp_path / "cal.json"
    Calibration(gyro_null=[2050.0, 2040.0, 2049.0], acc_null=[2000.0, 2100.0, 2048.0]).save(path)
    rt = patch(f"node units scaling calibration={path}\nnode scale collect\nunits.range -> scale\n")
    rt.start()
    acc, gyro = rt.nodes["scale"].values[-1]
    assert (acc, gyro) == pytest.approx(((4095 - 2100) * 0.0192, 2040 * math.radians(0.1)))  # nearest rails


def test_tqt_full_scale_parameters_are_in_g_and_degrees_and_live():
    from pointat.message import method

    rt = patch("node fuse tqt acc_range=4 gyro_range=2000\n")
    f = rt.nodes["fuse"]
    assert f.filter.acc_range == pytest.approx(4.0 * 9.80665)
    assert f.filter.gyro_range == pytest.approx(math.radians(2000.0))
    rt.start()
    f.receive(0, method("acc_range", 16.0))
    assert f.filter.acc_range == pytest.approx(16.0 * 9.80665)
    f.receive(0, method("k", 0.0))  # 0: the mode's own gain
    assert f.filter.k == f.filter.default_k("robust")
    with pytest.raises(ValueError, match="acc_range must be a finite number >= 0"):
        f.receive(3, make([-1.0, 3.0]))
    assert f.filter.acc_range == pytest.approx(16.0 * 9.80665)  # a refused range changes nothing
