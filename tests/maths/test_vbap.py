"""VBAP (pointat.maths.vbap) and the vbap node: textbook cases, triangulation, outside the hull, spread."""

import json
import math

import numpy as np
import pytest

import pointat.nodes.spatial  # noqa: F401  (registers the vbap node)
from pointat.maths.vbap import (
    Panner,
    direction_vector,
    format_layout,
    make_layout,
    pairs_2d,
    parse_layout,
    pd_messages,
    read_layout,
    triangulate,
    vbap_gains,
)
from pointat.message import make, method
from pointat.testing import patch

RING = [0, 45, 90, 135, 180, -135, -90, -45]
DOME = make_layout(RING + [45, 135, -135, -45], [0] * 8 + [45] * 4)
S = 1 / math.sqrt(2)


def _sphere(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def _angles(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.degrees(np.arctan2(v[:, 1], v[:, 0])), np.degrees(np.arcsin(np.clip(v[:, 2], -1, 1)))


def _sphere_layout(n: int = 20, seed: int = 3):
    az, el = _angles(_sphere(n, seed))
    return make_layout(az, el)


def _containing(layout, points: np.ndarray, tol: float) -> np.ndarray:
    """How many sets hold each point with every gain >= -tol."""
    g = np.einsum("kij,nj->nki", layout.inverses, points[:, : layout.dim])
    return (g.min(axis=2) >= -tol).sum(axis=1)


# --------------------------------------------------------------------------- textbook cases
@pytest.mark.parametrize("layout", [make_layout(RING), make_layout([30, -30, 110, -110, 0]), DOME])
def test_a_source_at_a_loudspeaker_plays_from_that_loudspeaker_alone(layout):
    for i, (az, el) in enumerate(zip(layout.azimuths, layout.elevations, strict=True)):
        g = vbap_gains(layout, az, el)
        expected = np.zeros(layout.n)
        expected[i] = 1.0
        np.testing.assert_allclose(g, expected, atol=1e-12)


def test_halfway_between_a_pair_gives_equal_gains():
    ring = make_layout(RING)
    for k in range(8):
        g = vbap_gains(ring, RING[k] + 22.5)
        np.testing.assert_allclose(g[[k, (k + 1) % 8]], [S, S], atol=1e-12)
        assert np.count_nonzero(g > 1e-12) == 2
    # and at the centre of a 3-D triplet, three equal gains
    for s in DOME.sets:
        centre = DOME.vectors[s].sum(axis=0)
        az, el = (
            math.degrees(math.atan2(centre[1], centre[0])),
            math.degrees(math.asin(centre[2] / np.linalg.norm(centre))),
        )
        g = vbap_gains(DOME, az, el)
        np.testing.assert_allclose(g[s], [1 / math.sqrt(3)] * 3, atol=1e-9)


def test_2d_gains_follow_the_tangent_law():
    """Pulkki's 2-D VBAP is the tangent law: (g1 - g2) / (g1 + g2) = tan(phi) / tan(phi0)."""
    stereo = make_layout([30, -30])  # + left: loudspeaker 1 is the left one
    for phi in np.linspace(-30, 30, 25):
        g_left, g_right = vbap_gains(stereo, phi)
        assert (g_left - g_right) / (g_left + g_right) == pytest.approx(
            math.tan(math.radians(phi)) / math.tan(math.radians(30)), abs=1e-12
        )


@pytest.mark.parametrize("layout", [make_layout(RING), make_layout([30, -30]), DOME, _sphere_layout()])
@pytest.mark.parametrize("spread", [0.0, 15.0, 50.0, 85.0, 100.0])
def test_unit_power_and_no_negative_gain_in_every_direction(layout, spread):
    az, el = _angles(_sphere(60, seed=11))
    panner = Panner(layout)
    for a, e in zip(az, el, strict=True):
        g = panner.gains(a, e, spread)
        assert (g**2).sum() == pytest.approx(1.0, abs=1e-12)
        assert g.min() >= 0.0


# --------------------------------------------------------------------------- sets
def test_2d_pairs_are_neighbours_and_skip_gaps_wider_than_170_degrees():
    assert pairs_2d(RING).tolist() == [[5, 6], [6, 7], [7, 0], [0, 1], [1, 2], [2, 3], [3, 4], [4, 5]]
    assert pairs_2d([0, 90, 180]).tolist() == [[0, 1], [1, 2]]  # 180 .. 0 through the right: 180 wide
    assert pairs_2d([-60, 60]).tolist() == [[0, 1]]


def test_full_sphere_triangulation_has_2n_minus_4_triplets_and_no_overlap():
    layout = _sphere_layout(20, seed=3)
    assert layout.encloses and len(layout.sets) == 2 * 20 - 4  # Euler: a triangulated sphere
    counts = _containing(layout, _sphere(4000, seed=5), 1e-12)
    assert counts.tolist() == [1] * 4000  # every direction in exactly one triplet


def test_dome_triplets_never_overlap_and_cover_the_upper_hemisphere_once():
    assert len(DOME.sets) == 14  # 12 loudspeakers, 8 on the border: 2 * 12 - 8 - 2
    assert DOME.border_edges.tolist() == [[0, 1], [0, 7], [1, 2], [2, 3], [3, 4], [4, 5], [5, 6], [6, 7]]
    v = _sphere(4000, seed=6)
    counts = _containing(DOME, v, 1e-12)
    above, below = v[:, 2] > 1e-9, v[:, 2] < -1e-9
    assert set(counts[above].tolist()) == {1}
    assert set(counts[below].tolist()) == {0}
    # strictly inside two triplets at once: never
    assert _containing(DOME, v, -1e-9).max() == 1


def test_a_top_square_is_split_into_two_triangles_not_four():
    assert [s for s in DOME.sets.tolist() if min(s) >= 8] == [[8, 9, 10], [8, 10, 11]]


def test_triangulate_rejects_a_flat_3d_layout():
    with pytest.raises(ValueError, match="one plane through the listener"):
        make_layout(RING, dim=3)
    with pytest.raises(ValueError, match="one plane through the listener"):
        triangulate(direction_vector(np.array(RING, dtype=float), 0.0))


def test_a_single_triplet_in_front_works():
    front = make_layout([30, -30, 0], [0, 0, 40])
    assert front.sets.tolist() == [[0, 1, 2]] and not front.encloses
    assert vbap_gains(front, 0, 40).round(12).tolist() == [0.0, 0.0, 1.0]


# --------------------------------------------------------------------------- outside the loudspeakers
def test_below_a_dome_the_gains_are_those_of_the_ring_straight_above():
    panner = Panner(DOME)
    for az in np.arange(-180, 180, 12.5):
        ring = vbap_gains(DOME, az, 0.0)
        for el in (-5.0, -40.0, -85.0):
            g = panner.gains(az, el)
            np.testing.assert_allclose(g, ring, atol=1e-12)
            assert panner.direction == pytest.approx((az if az > -180 else 180.0, 0.0), abs=1e-9)


def test_outside_a_2d_arc_the_nearest_end_loudspeaker_plays():
    stereo = Panner(make_layout([30, -30]))
    assert stereo.gains(100.0).tolist() == [1.0, 0.0] and stereo.direction == (30.0, 0.0)
    assert stereo.gains(-150.0).tolist() == [0.0, 1.0] and stereo.direction == (-30.0, 0.0)
    assert stereo.gains(179.0).tolist() == [1.0, 0.0]  # nearer to +30 than to -30 round the back


def test_outside_a_single_triplet_the_nearest_border_point_is_used():
    front = make_layout([30, -30, 0], [0, 0, 40])
    g = vbap_gains(front, 0.0, -20.0)  # straight below the bottom edge: between the two lower ones
    np.testing.assert_allclose(g, [S, S, 0.0], atol=1e-12)


# --------------------------------------------------------------------------- spread
def test_spread_widens_the_source():
    ring = make_layout(RING)
    counts, peaks = [], []
    for s in (0, 10, 30, 60, 90, 100):
        g = vbap_gains(ring, 10.0, 0.0, s)
        counts.append(int(np.count_nonzero(g > 1e-9)))
        peaks.append(g.max())
    assert counts == sorted(counts) and counts[0] == 2 and counts[-1] == 8
    assert peaks == sorted(peaks, reverse=True)
    spread_all = vbap_gains(ring, 10.0, 0.0, 100)
    assert spread_all.max() / spread_all.min() < 1.3  # nearly every loudspeaker alike
    dome = [int(np.count_nonzero(vbap_gains(DOME, 20.0, 30.0, s) > 1e-9)) for s in (0, 20, 50, 90)]
    assert dome == sorted(dome) and dome[0] == 3 and dome[-1] == 12


# Recorded from Pd 0.53.1 + pd-vbap 1.2.0 (examples/pd receivers; float32, 6 decimals): a fresh [vbap]
# fed these directions in this order (the 3-D spread base carries over from one to the next).
PD_RING = [
    ((10, 0, 30), [0.88678, 0.444359, 0.0, 0.0, 0.0, 0.0, 0.0, 0.127145]),
    ((-100, 0, 80), [0.275033, 0.161822, 0.161822, 0.161822, 0.327031, 0.477681, 0.574508, 0.424982]),
    ((170, 0, 100), [0.317956, 0.337958, 0.357288, 0.385838, 0.39011, 0.36408, 0.349752, 0.317956]),
]
PD_DOME = [
    ((30, 20, 25), [0.489568, 0.485664, 0.032572, 0, 0, 0, 0, 0, 0.721977, 0, 0, 0.046273]),
    (
        (100, 50, 60),
        [0.027228, 0.182416, 0.339209, 0.164573, 0.140125, 0, 0, 0, 0.634846, 0.486144, 0.38134, 0.139341],
    ),
    (
        (-60, 10, 90),
        [
            0.23206,
            0.227492,
            0.224866,
            0.224866,
            0.311375,
            0.350561,
            0.251655,
            0.263713,
            0.394048,
            0.280806,
            0.383812,
            0.243116,
        ],
    ),
]


@pytest.mark.parametrize(("layout", "recorded"), [(make_layout(RING), PD_RING), (DOME, PD_DOME)])
def test_spread_matches_recorded_pd_vbap_output(layout, recorded):
    panner = Panner(layout)
    for (az, el, s), expected in recorded:
        np.testing.assert_allclose(panner.gains(az, el, s), expected, atol=2e-6)


def test_panner_reset_restores_pd_vbaps_initial_spread_base():
    p = Panner(DOME)
    first = p.gains(100, 50, 60)
    p.gains(-60, 10, 90)
    p.reset()
    np.testing.assert_allclose(p.gains(100, 50, 60), first, atol=1e-15)


# --------------------------------------------------------------------------- layouts
def test_layout_forms_from_a_patch_parameter():
    assert parse_layout(RING).dim == 2
    pairs = parse_layout([[a, e] for a, e in zip(DOME.azimuths, DOME.elevations, strict=True)])
    flat = parse_layout(
        [x for a, e in zip(DOME.azimuths, DOME.elevations, strict=True) for x in (a, e)], dim=3
    )
    assert pairs.dim == flat.dim == 3
    assert pairs.sets.tolist() == flat.sets.tolist() == DOME.sets.tolist()
    assert parse_layout([[a, 0] for a in RING]).dim == 2  # all elevations 0: a ring


@pytest.mark.parametrize(
    ("values", "dim", "message"),
    [
        ([0, 90, 90], 0, "point the same way"),
        ([0], 0, "at least 2"),
        ([0, 1, 2], 3, "even count"),
        ([[0, 0], 90], 0, "numbers"),
        ([[0, 10], [90, 0], [180, 0]], 2, "azimuths only"),
        ([0, 10, 20], 0, "every gap is wider"),
    ],
)
def test_bad_layouts_say_what_is_wrong(values, dim, message):
    if message == "every gap is wider":
        values, dim = [0, 175], 0
    with pytest.raises(ValueError, match=message):
        parse_layout(values, dim=dim)


def test_layout_files_json_and_pd_text(tmp_path):
    j = tmp_path / "dome.json"
    j.write_text(
        json.dumps(
            {
                "name": "dome",
                "dim": 3,
                "speakers": [
                    [a, e] for a, e in zip(DOME.azimuths.tolist(), DOME.elevations.tolist(), strict=True)
                ],
            }
        )
    )
    assert read_layout(j).sets.tolist() == DOME.sets.tolist()
    t = tmp_path / "dome.txt"
    t.write_text("# my dome\n" + format_layout(DOME) + "\n")
    again = read_layout(t)
    assert again.sets.tolist() == DOME.sets.tolist()
    np.testing.assert_array_equal(again.azimuths, DOME.azimuths)
    ring = tmp_path / "ring.txt"
    ring.write_text("define_loudspeakers 2 0 45 90 135 180 -135 -90 -45;")
    assert read_layout(ring).sets.tolist() == make_layout(RING).sets.tolist()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"speakers": RING, "speaker_gain": 1}))
    with pytest.raises(ValueError, match="unknown keys"):
        read_layout(bad)


def test_user_triplets_are_used_as_given():
    # the other diagonal of the top square
    mine = DOME.sets.tolist()
    mine[mine.index([8, 9, 10])] = [8, 9, 11]
    mine[mine.index([8, 10, 11])] = [9, 10, 11]
    layout = make_layout(DOME.azimuths, DOME.elevations, triplets=np.array(mine) + 1)
    assert layout.sets.tolist() == mine
    with pytest.raises(ValueError, match="from 1 to 12"):
        make_layout(DOME.azimuths, DOME.elevations, triplets=[[0, 1, 2]])


def test_pd_messages_number_loudspeakers_from_one():
    (sel, args), (sel2, trip) = pd_messages(DOME)
    assert sel == "ls-directions" and args[:5] == [3, 0, 0, 45, 0]
    assert sel2 == "ls-triplets" and trip[:3] == [1, 2, 9] and min(trip) == 1 and max(trip) == 12
    assert pd_messages(make_layout(RING)) == [("define_loudspeakers", [2, *RING])]


# --------------------------------------------------------------------------- the vbap node
def _node(params: str):
    rt = patch(f"""
node spk vbap {params}
node g collect
node s collect
node d collect
spk.gains -> g
spk.speaker -> s
spk.direction -> d
""")
    rt.start()
    return rt


def test_vbap_node_outputs_gains_per_loudspeaker_lists_and_the_direction():
    rt = _node("layout=[0, 45, 90, 135, 180, -135, -90, -45]")
    spk = rt.nodes["spk"]
    spk.receive(0, make(22.5))
    np.testing.assert_allclose(rt.nodes["g"].values[-1], [S, S, 0, 0, 0, 0, 0, 0], atol=1e-12)
    assert [i for i, _ in rt.nodes["s"].values] == list(range(8))
    assert rt.nodes["s"].values[1][1] == pytest.approx(S)
    assert rt.nodes["d"].values == [(22.5, 0.0)]
    spk.receive(2, make(100.0))  # spread inlet
    spk.receive(0, make(None))  # bang: again, now spread
    assert np.count_nonzero(rt.nodes["g"].values[-1]) == 8


def test_vbap_node_3d_from_a_file_and_a_list_at_the_left_inlet(tmp_path):
    f = tmp_path / "dome.txt"
    f.write_text(format_layout(DOME))
    rt = _node(f"file={f}")
    spk = rt.nodes["spk"]
    spk.receive(1, make(-30.0))
    spk.receive(0, make(10.0))  # below the ring: the ring straight above
    np.testing.assert_allclose(rt.nodes["g"].values[-1], vbap_gains(DOME, 10.0, 0.0), atol=1e-12)
    assert rt.nodes["d"].values[-1] == pytest.approx((10.0, 0.0))
    spk.receive(0, make((45.0, 45.0, 0.0)))
    assert list(rt.nodes["g"].values[-1]) == [0.0] * 8 + [1.0, 0.0, 0.0, 0.0]


def test_vbap_node_layout_can_change_while_running_and_a_bad_one_changes_nothing():
    rt = _node("layout=[0, 90, 180, -90]")
    spk = rt.nodes["spk"]
    spk.receive(0, method("layout", 0, 120, -120))
    spk.receive(0, make(60.0))
    np.testing.assert_allclose(rt.nodes["g"].values[-1], [S, S, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="point the same way"):
        spk.receive(0, method("layout", 0, 0))
    assert spk.p.layout == (0, 120, -120) and spk.layout.n == 3


def test_vbap_node_refuses_a_bad_direction_whole_and_goes_on_with_the_last_good_one():
    rt = _node("layout=[0, 90, 180, -90]")
    spk = rt.nodes["spk"]
    spk.receive(0, make((30.0, 0.0)))
    for bad in ((30.0, math.nan), (math.inf,), (10.0, 0.0, math.nan)):  # the last: a NaN spread
        with pytest.raises(ValueError):
            spk.receive(0, make(bad))
    with pytest.raises(ValueError, match="elevation nan refused"):
        spk.receive(1, make(math.nan))
    assert (spk._az, spk._el, spk.p.spread) == (30.0, 0.0, 0.0)  # nothing of them was kept
    spk.receive(0, make(45.0))  # and the next direction is panned
    np.testing.assert_allclose(rt.nodes["g"].values[-1], [S, S, 0.0, 0.0], atol=1e-12)


def test_vbap_node_refuses_a_missing_or_doubled_layout():
    from pointat.errors import PointatError

    with pytest.raises(PointatError, match="no loudspeakers"):
        patch("node spk vbap\n")
    with pytest.raises(PointatError, match="not both"):
        patch("node spk vbap layout=[0, 90, 180] file=x.json\n")
