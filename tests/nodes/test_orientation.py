"""Orientation nodes on hand-made orientations: what the glove chain cannot easily put them through."""

import math

import numpy as np
import pytest

from pointat.errors import PatchError
from pointat.maths import scalar as sq
from pointat.message import floats, make
from pointat.testing import patch

ROLL = """
node roll roll_distance {params}
node az collect
node mode collect
roll.azimuth -> az
roll.mode -> mode
"""


def pointing(elevation_deg, roll_deg=0.0, azimuth_deg=0.0):
    """The hand's orientation (NWU): heading, then pitch up by the elevation, then roll about itself."""
    yaw = sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(azimuth_deg))
    pitch = sq.axis_angle_quat(0.0, 1.0, 0.0, -math.radians(elevation_deg))  # +y is west: x turns up
    roll = sq.axis_angle_quat(1.0, 0.0, 0.0, math.radians(roll_deg))
    return sq.multiply(sq.multiply(yaw, pitch), roll)


def jittered(q, deg, rng):
    """``q`` turned by ``deg`` about a random axis (sensor noise, a hand that is never quite still)."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return sq.multiply(q, sq.axis_angle_quat(*axis, math.radians(deg)))


def feed(rt, quats):
    node = rt.nodes["roll"]
    for k, q in enumerate(quats):
        node.receive(0, floats(tuple(q), k / 100.0))
    return [m.value for m in rt.nodes["mode"].messages]


@pytest.mark.parametrize("max_elevation, expected", [(75.0, []), (90.0, ["distance"])])
def test_a_hand_pointing_at_the_zenith_does_not_switch_to_distance(max_elevation, expected):
    # 0.5 deg of jitter at 89.5 deg up swings the Euler roll past 70 deg on some samples: the roll of a
    # hand pointing straight up is its heading, not a gesture
    rng = np.random.default_rng(3)
    up = pointing(89.5)
    rt = patch(ROLL.format(params=f"max_elevation={max_elevation}"))
    modes = feed(rt, [jittered(up, 0.5, rng) for _ in range(2000)])
    assert modes[:1] == expected


def test_the_roll_gesture_still_works_with_the_hand_raised():
    rt = patch(ROLL.format(params=""))
    ramp = [pointing(40.0, r, azimuth_deg=30.0) for r in np.linspace(0.0, 90.0, 50)]
    assert feed(rt, ramp + [pointing(40.0, 90.0, azimuth_deg=50.0)] * 5) == ["distance"]
    assert rt.nodes["az"].messages[-1].value == pytest.approx(30.0, abs=0.5)  # held while rolled


def test_leave_above_enter_is_refused_at_load_and_live():
    with pytest.raises(PatchError, match="leave=45.0 enter=30.0"):
        patch(ROLL.format(params="enter=30"))
    rt = patch(ROLL.format(params=""))
    with pytest.raises(ValueError, match="leave < enter"):
        rt.nodes["roll"].set_param("leave", 80.0)
    assert rt.nodes["roll"].p.leave == 45.0  # nothing changed


def test_an_orientation_in_is_a_unit_quaternion_and_nan_or_infinity_is_refused():
    from pointat.nodes.orientation import as_quat

    unit = (0.5, 0.5, -0.5, 0.5)
    assert as_quat(floats(unit)) is unit  # a unit quaternion (what the nodes send) passes as it is
    assert as_quat(floats((2.0, 0.0, 0.0, 0.0))) == (1.0, 0.0, 0.0, 0.0)
    assert as_quat(floats((0.0, 0.0, 0.0, 1.0 + 1e-9))) == (0.0, 0.0, 0.0, 1.0)  # off by more: normalised
    for bad in ((math.nan, 0.0, 0.0, 1.0), (math.inf, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, math.nan)):
        with pytest.raises(ValueError, match="NaN or infinite"):
            as_quat(floats(bad))
    # a list is read as numbers, a matrix becomes its quaternion, any other size or kind is an error
    assert as_quat(make([0, 0, 0, 2])) == (0.0, 0.0, 0.0, 1.0)
    assert as_quat(floats(sq.quat_matrix(unit))) == pytest.approx(unit, abs=1e-15)
    for wrong, error in (
        (floats((1.0, 0.0, 0.0)), "4 or 9 numbers, got 3"),
        (make(1.0), "expected a vector"),
    ):
        with pytest.raises(TypeError, match=error):
            as_quat(wrong)


def test_azi_ele_and_roll_distance_on_one_outlet_each_get_their_own_direction():
    # the two share the last azimuth_elevation computed; with other axes and poles each must still get
    # what it alone would compute, the hand straight up included (where the previous azimuth holds)
    rt = patch(
        """
node src  reference
node dir  azi_ele axis=[0, 1, 0] pole=5
node roll roll_distance pole=1
node az   collect
node el   collect
node raz  collect
src -> dir
src -> roll
dir.azimuth -> az
dir.elevation -> el
roll.azimuth -> raz
"""
    )
    rng = np.random.default_rng(3)
    quats = [jittered(pointing(e, 0.0, a), 2.0, rng) for e, a in ((10, 30), (40, -60), (88, 0), (89.5, 10))]
    for k, q in enumerate(quats):
        rt.nodes["src"].receive(0, floats(tuple(q), k / 100.0))  # out unchanged: no reference set
    prev_dir = prev_roll = None
    for k, q in enumerate(quats):
        az, el = sq.azimuth_elevation(q, (0.0, 1.0, 0.0), prev_dir, 5.0)
        assert (rt.nodes["az"].values[k], rt.nodes["el"].values[k]) == pytest.approx((az, el), abs=1e-12)
        prev_dir = az
        raz, _ = sq.azimuth_elevation(q, previous=prev_roll, pole_deg=1.0)
        assert rt.nodes["raz"].values[k] == pytest.approx(raz, abs=1e-12)
        prev_roll = raz
    assert rt.nodes["az"].values != rt.nodes["raz"].values


def test_matrix2quat_reads_back_the_quaternion_of_a_matrix_made_here_and_only_of_that_one():
    # complementary -> matrix2quat (Torre's chain) reads back the quaternion the matrix was made from;
    # a matrix made anywhere else is worked out, and w >= 0 either way
    rt = patch(
        """
node q2m quat2matrix
node m2q matrix2quat
node out collect
q2m -> m2q -> out
"""
    )
    rng = np.random.default_rng(5)
    quats = [tuple(q / np.linalg.norm(q)) for q in rng.normal(size=(20, 4))]
    for k, q in enumerate(quats):
        rt.nodes["q2m"].receive(0, floats(q, k / 100.0))  # made here: read back
        m = sq.quat_matrix(quats[-1 - k])  # made after it, elsewhere: worked out
        rt.nodes["m2q"].receive(0, floats(m, k / 100.0))
    got = rt.nodes["out"].values
    for k, q in enumerate(quats):
        for w in (got[2 * k], got[2 * k + 1]):
            assert w[0] >= 0.0
        assert got[2 * k] == pytest.approx(q if q[0] >= 0 else tuple(-c for c in q), abs=1e-15)
        other = quats[-1 - k]
        assert got[2 * k + 1] == pytest.approx(sq.matrix_quat(sq.quat_matrix(other)), abs=1e-15)


def test_gyro_integrator_reports_a_glitch_and_holds_its_orientation():
    rt = patch(
        "node gyro gyro_integrator\nnode out collect\nnode flags collect\ngyro -> out\ngyro.flags -> flags\n"
    )
    node = rt.nodes["gyro"]
    for k, rate in enumerate([(0.0, 0.0, 1.0), (1e30, 0.0, 0.0), (0.0, 0.0, 1.0)]):
        node.receive(0, floats(rate, k / 100.0))
    first, held, after = rt.nodes["out"].values
    assert held == first and after != first
    assert rt.nodes["flags"].values == ["bad_gyro", "ok"]  # (reported when it changes)


CHAIN = """
node gyro gyro_integrator mode=exact
node am   accmag_matrix accel_tolerance=0 mag_tolerance=0 dip_tolerance=0
node fuse complementary crossover={crossover}
node out  collect
gyro -> fuse.gyro_orientation
am -> fuse.accmag
fuse -> out
"""


@pytest.mark.parametrize("crossover", [0.05, 0.2, 2.0])
def test_the_complementary_chain_is_the_complementary_filter(crossover):
    """Torre's chain as a patch wires it (gyro_integrator, accmag_matrix, complementary) and
    ComplementaryFilter.update on the raw samples run one algorithm (the node runs the filter's fuse):
    the same orientation at every sample, to rounding."""
    from pointat.maths.fusion import ComplementaryFilter

    rng = np.random.default_rng(7)
    n, dt = 600, 0.01
    gyro = rng.normal(0.0, 1.5, (n, 3))
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, 0.3, (n, 3))
    mag = np.array([0.2, 0.0, -0.4]) + rng.normal(0.0, 0.02, (n, 3))
    rt = patch(CHAIN.format(crossover=crossover))
    f = ComplementaryFilter(crossover)
    expected = []
    for k in range(n):
        rt.nodes["am"].receive(1, floats(tuple(mag[k]), k * dt))
        rt.nodes["am"].receive(0, floats(tuple(acc[k]), k * dt))
        rt.nodes["gyro"].receive(0, floats(tuple(gyro[k]), k * dt))
        q, used = f.update(gyro[k], acc[k], mag[k], dt)
        assert used
        expected.append(sq.quat_matrix(tuple(q.tolist())))
    got = np.array(rt.nodes["out"].values)
    assert got.shape == (n, 9)
    np.testing.assert_allclose(got, np.array(expected), rtol=0, atol=1e-9)
