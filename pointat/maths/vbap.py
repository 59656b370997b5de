r"""Vector base amplitude panning (VBAP, Pulkki 1997), in 2-D and 3-D, with pd-vbap's spreading.

A virtual source in direction :math:`\mathbf p` (unit vector) is played by the loudspeakers of one *set*,
a pair (2-D) or a triplet (3-D) whose directions :math:`\mathbf l_1 \dots \mathbf l_d` enclose it.  The
gains solve

.. math::
    \mathbf p = L\,\mathbf g = g_1\mathbf l_1 + \dots + g_d\mathbf l_d, \qquad
    \mathbf g = L^{-1}\mathbf p, \qquad \mathbf g \leftarrow \mathbf g / \lVert\mathbf g\rVert

(Pulkki, "Virtual sound source positioning using vector base amplitude panning", J. Audio Eng. Soc.
45(6), 1997): :math:`\mathbf p` lies inside the set when every :math:`g_i \ge 0`, and the gains are
scaled to **unit power**, :math:`\sum g_i^2 = 1`.  Every other loudspeaker gets 0.

Conventions
-----------
Directions are pointat's (ADM-OSC): azimuth in degrees, 0 = front, **positive = left**; elevation in
degrees, positive = up.  The unit vector is

.. math:: \mathbf p = (\cos e \cos a,\; \cos e \sin a,\; \sin e)

(x front, y left, z up: pointat's NWU earth frame with the front along x).  pd-vbap's ``angle_to_cart``
is the same formula (0 = +x, positive toward +y), so **pointat azimuths are pd-vbap angles** as long as
the loudspeakers are written in the same convention (a loudspeaker on the left at +90).  pd-vbap's help
text calls -45 "front left", i.e. it is often used clockwise-positive: such a layout must have its
azimuths negated before it is used with pointat's directions (or with the ``vbap`` OSC profile).

Loudspeaker sets
----------------
* **2-D**: the loudspeakers sorted by azimuth; each adjacent pair (and the last with the first) is a
  set unless they are more than :data:`MAX_PAIR_GAP` (170°) apart, as in pd-vbap.  A 2-D layout
  ignores the source's elevation (pd-vbap too).
* **3-D**: the triplets are the faces of the convex hull of the loudspeaker directions (Delaunay on the
  sphere), found exactly by testing every triple, with coplanar faces (four loudspeakers on one circle)
  fanned into triangles.  Only the hull's **outer faces**, those whose plane passes on the far side of
  the listener (distance from the centre > 0), are used: for loudspeakers all around, that is every
  face; for a ring plus elevated loudspeakers (a dome), the flat bottom face through the listener is
  dropped and the outer faces cover exactly the upper hemisphere.  Outer faces of a convex hull never
  overlap as seen from the centre (a ray from the centre leaves a convex body once), so every covered
  direction lies in exactly one triplet (two or three on a shared edge or corner, with equal gains).
  pd-vbap's own triangulation (``define_loudspeakers 3``) can keep overlapping triplets for such
  layouts; :func:`pd_messages` gives the ``ls-directions`` / ``ls-triplets`` messages that make pd-vbap
  use these triplets instead.

Outside the loudspeakers
------------------------
A direction that no set covers (below a dome's ring, in a 2-D gap wider than 170°) gets the gains of
the **nearest covered direction**: the closest point of the covered region's border, an edge between
two loudspeakers or a loudspeaker.  Below a ring of loudspeakers that is the point straight above, on
the ring.  Gains are never negative.  (pd-vbap instead keeps the best set's gains, with tiny negative
values or 0.0001 in place of negative ones.)  :class:`Panner` reports the direction actually panned.

Spread
------
``spread`` (0..100) follows pd-vbap (after Pulkki, "Uniform spreading of amplitude panned virtual
sources", WASPAA 1999): the unit-power gains of extra directions around the source are added to its
own gains, and the sum is scaled back to unit power.  In 2-D the extra directions are at azimuth
:math:`\pm s, \pm s/2, \pm s/4` degrees; in 3-D there are 16, on rings at the angles pd-vbap uses around
the source, oriented by a *spread base* vector that pd-vbap keeps from one call to the next
(:class:`Panner` keeps it too, so a moving source's spread pattern turns with it and matches pd-vbap).
Above 70, :math:`10\,((s - 70)/30)^2` is added to every loudspeaker before the scaling, so that 100
is almost all loudspeakers equally.  Extra directions outside every set (a gain below -0.01) are
skipped, as in pd-vbap.  Two departures, both where pd-vbap misbehaves: small negative gains are 0
here, and a spread base within 1° of opposite the source (pd-vbap divides by about zero there) is
replaced like one within 1° of the source.

Layouts from files
------------------
:func:`read_layout` reads JSON, ``{"dim": 3, "speakers": [[0, 0], [45, 0], ...]}`` (2-D: a list of
azimuths; optional ``"triplets": [[1, 2, 9], ...]`` numbered from 1 as in pd-vbap), or text in Pd's
messages, ``define_loudspeakers 3 0 0 45 0 ...;`` (or ``ls-directions``) and an optional
``ls-triplets 1 2 9 ...;``, with ``#`` comments.  :func:`format_layout` writes the text form.

>>> ring = make_layout([0, 45, 90, 135, 180, -135, -90, -45])
>>> vbap_gains(ring, 45.0).round(6).tolist()
[0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
>>> vbap_gains(ring, 22.5).round(6).tolist()
[0.707107, 0.707107, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
>>> dome = make_layout([0, 45, 90, 135, 180, -135, -90, -45, 45, 135, -135, -45],
...                    [0, 0, 0, 0, 0, 0, 0, 0, 45, 45, 45, 45])
>>> dome.dim, len(dome.sets), dome.encloses
(3, 14, False)
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pointat.userfiles import read_text

__all__ = [
    "Layout",
    "Panner",
    "make_layout",
    "parse_layout",
    "read_layout",
    "format_layout",
    "pd_messages",
    "vbap_gains",
    "triangulate",
    "pairs_2d",
    "direction_vector",
    "vector_direction",
    "MAX_PAIR_GAP",
    "MAX_SPEAKERS",
]

#: Adjacent 2-D loudspeakers further apart than this (degrees) make no pair (as in pd-vbap).
MAX_PAIR_GAP = 170.0
#: The 3-D hull tests every triple of loudspeakers: O(n^4) work, fine up to this many.
MAX_SPEAKERS = 128

#: A direction is inside a set when its smallest gain is at least ``-INSIDE_TOL`` (before scaling).
INSIDE_TOL = 1e-9
#: pd-vbap's threshold for a spread direction to count as inside a set.
PD_NEGATIVE = -0.01
_PLANE_TOL = 1e-9  # points this close to a face's plane are on it (unit vectors)
_OUTER_TOL = 1e-6  # faces whose plane passes closer than this to the centre are not outer faces


def direction_vector(azimuth: ArrayLike, elevation: ArrayLike = 0.0) -> np.ndarray:
    r"""Unit vector(s) of a direction: :math:`(\cos e\cos a, \cos e\sin a, \sin e)`, x front, y left, z up.

    Parameters
    ----------
    azimuth, elevation : array_like
        Degrees (pointat / pd-vbap convention: azimuth + left, elevation + up); broadcast together.

    Returns
    -------
    numpy.ndarray, shape (..., 3)

    >>> direction_vector(90.0).round(12).tolist()
    [0.0, 1.0, 0.0]
    """
    a = np.radians(np.asarray(azimuth, dtype=float))
    e = np.radians(np.asarray(elevation, dtype=float))
    a, e = np.broadcast_arrays(a, e)
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


def vector_direction(vector: ArrayLike) -> tuple[float, float]:
    """Azimuth and elevation (degrees) of a 3-vector; azimuth in ``(-180, 180]``, 0 straight up or down.

    >>> vector_direction([0.0, -2.0, 0.0])
    (-90.0, 0.0)
    """
    v = np.asarray(vector, dtype=float)
    horizontal = math.hypot(v[0], v[1])
    az = math.degrees(math.atan2(v[1], v[0])) if horizontal > 1e-12 else 0.0
    el = math.degrees(math.atan2(v[2], horizontal))
    if az <= -180.0:
        az += 360.0
    return az, el


def _wrap180(az: np.ndarray) -> np.ndarray:
    """Degrees into (-180, 180]."""
    w = np.mod(np.asarray(az, dtype=float) + 180.0, 360.0) - 180.0
    return np.where(w <= -180.0, w + 360.0, w)


def pairs_2d(azimuths: ArrayLike, *, max_gap: float = MAX_PAIR_GAP) -> np.ndarray:
    """The loudspeaker pairs of a horizontal layout: neighbours in azimuth, at most ``max_gap`` apart.

    Parameters
    ----------
    azimuths : array_like, shape (n,)
        Degrees.
    max_gap : float
        Degrees; wider gaps are not panned across (pd-vbap uses 170).

    Returns
    -------
    numpy.ndarray of int, shape (k, 2)
        Indices into ``azimuths`` (0-based), going round counter-clockwise (toward + azimuth).

    >>> pairs_2d([30, -30, 110, -110]).tolist()
    [[3, 1], [1, 0], [0, 2], [2, 3]]
    >>> pairs_2d([30, -30]).tolist()
    [[1, 0]]
    """
    az = _wrap180(np.asarray(azimuths, dtype=float).ravel())
    n = az.size
    order = np.argsort(az, kind="stable")
    pairs = []
    for i in range(n if n > 2 else n - 1):
        a, b = order[i], order[(i + 1) % n]
        gap = (az[b] - az[a]) % 360.0
        if 1e-9 < gap <= max_gap:
            pairs.append((int(a), int(b)))
    if n == 2:
        a, b = order[1], order[0]
        gap = (az[b] - az[a]) % 360.0
        if 1e-9 < gap <= max_gap:
            pairs.append((int(a), int(b)))
    return np.array(pairs, dtype=int).reshape(-1, 2)


def triangulate(vectors: ArrayLike) -> np.ndarray:
    """The loudspeaker triplets of a 3-D layout: the outer faces of the convex hull of its directions.

    Each triple of directions whose plane has every other direction on one side is a hull face; faces
    with more than three directions on one plane (on one circle of the sphere) are fanned into
    triangles.  Faces whose plane passes through (or behind) the centre are dropped: they are not seen
    from the listener as a part of the sphere.  No two triplets overlap as seen from the centre.

    Parameters
    ----------
    vectors : array_like, shape (n, 3)
        Unit direction vectors, n >= 3, no two equal.

    Returns
    -------
    numpy.ndarray of int, shape (k, 3)
        0-based indices, each row sorted, rows sorted.

    Raises
    ------
    ValueError
        When no face is an outer face (every loudspeaker in one plane through the listener).

    >>> octahedron = [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    >>> len(triangulate(octahedron))
    8
    """
    U = np.asarray(vectors, dtype=float)
    n = len(U)
    if U.ndim != 2 or U.shape[1] != 3 or n < 3:
        raise ValueError(f"triangulate needs at least 3 direction vectors, shape (n, 3); got {U.shape}")
    if n > MAX_SPEAKERS:
        raise ValueError(f"at most {MAX_SPEAKERS} loudspeakers in 3-D; got {n}")
    triples = np.array(list(itertools.combinations(range(n), 3)), dtype=int)
    polygons: set[tuple[int, ...]] = set()
    normals: dict[tuple[int, ...], np.ndarray] = {}
    flat = True
    for start in range(0, len(triples), 8192):
        t = triples[start : start + 8192]
        a, b, c = U[t[:, 0]], U[t[:, 1]], U[t[:, 2]]
        nrm = np.cross(b - a, c - a)
        length = np.linalg.norm(nrm, axis=1)
        ok = length > 1e-12
        t, a, nrm = t[ok], a[ok], nrm[ok] / length[ok, None]
        offset = np.einsum("ij,ij->i", nrm, a)
        s = U @ nrm.T - offset  # signed distance of every point to every plane, (n, T)
        hi, lo = s.max(axis=0), s.min(axis=0)
        if np.any((hi > _PLANE_TOL) | (lo < -_PLANE_TOL)):
            flat = False
        inward = (lo >= -_PLANE_TOL) & (hi > _PLANE_TOL)  # all points on the + side: flip
        face = (hi <= _PLANE_TOL) | inward
        level = (hi <= _PLANE_TOL) & (lo >= -_PLANE_TOL)  # every point on this plane: face the centre away
        sign = np.where(inward | (level & (offset < 0.0)), -1.0, 1.0)
        outer = face & (sign * offset > _OUTER_TOL)
        for j in np.nonzero(outer)[0]:
            members = tuple(int(i) for i in np.nonzero(np.abs(s[:, j]) <= _PLANE_TOL)[0])
            if members not in polygons:
                polygons.add(members)
                normals[members] = sign[j] * nrm[j]
    if not polygons:
        why = "all in one plane through the listener (use dim 2)" if flat else "not around the listener"
        raise ValueError(f"no loudspeaker triplets: the loudspeakers are {why}")
    triplets: list[tuple[int, ...]] = []
    for members in sorted(polygons):
        if len(members) == 3:
            triplets.append(members)
            continue
        pts = U[list(members)]
        centre = pts.mean(axis=0)
        e1 = pts[0] - centre
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(normals[members], e1)
        ang = np.arctan2((pts - centre) @ e2, (pts - centre) @ e1)
        ring = [members[i] for i in np.argsort(ang)]
        k = ring.index(min(ring))
        ring = ring[k:] + ring[:k]
        triplets += [tuple(sorted((ring[0], ring[i], ring[i + 1]))) for i in range(1, len(ring) - 1)]
    return np.array(sorted(triplets), dtype=int)


@dataclass(frozen=True, eq=False)
class Layout:
    """A loudspeaker layout with its sets, ready for panning.  Build it with :func:`make_layout`.

    Attributes
    ----------
    azimuths, elevations : numpy.ndarray, shape (n,)
        Degrees, as given (elevations 0 in 2-D).
    dim : int
        2 (pairs, elevation ignored) or 3 (triplets).
    vectors : numpy.ndarray, shape (n, 3)
        Unit direction of each loudspeaker.
    sets : numpy.ndarray of int, shape (k, dim)
        The pairs or triplets, 0-based loudspeaker indices.
    inverses : numpy.ndarray, shape (k, dim, dim)
        :math:`L^{-1}` of each set (columns of :math:`L` = the set's loudspeaker vectors, x y [z]).
    border_edges : numpy.ndarray of int, shape (m, 2)
        3-D: the edges of the covered region (in one triplet only); empty when it is the whole sphere.
    border_speakers : numpy.ndarray of int, shape (m,)
        Loudspeakers at the end of a covered 2-D arc or in no set at all.
    """

    azimuths: np.ndarray
    elevations: np.ndarray
    dim: int
    vectors: np.ndarray
    sets: np.ndarray
    inverses: np.ndarray
    border_edges: np.ndarray
    border_speakers: np.ndarray

    @property
    def n(self) -> int:
        """The number of loudspeakers."""
        return len(self.azimuths)

    @property
    def encloses(self) -> bool:
        """True when every direction is covered by a set (no nearest-direction fallback is needed)."""
        return len(self.border_edges) == 0 and len(self.border_speakers) == 0

    def set_gains(self, point: np.ndarray) -> np.ndarray:
        """Unscaled gains of every set for a unit vector (x y [z]): ``inverses @ p``, shape (k, dim)."""
        return self.inverses @ point[: self.dim]

    def __repr__(self) -> str:
        return f"<Layout {self.dim}-D, {self.n} loudspeakers, {len(self.sets)} sets>"


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


def make_layout(
    azimuths: ArrayLike,
    elevations: ArrayLike | None = None,
    *,
    dim: int | None = None,
    triplets: ArrayLike | None = None,
    max_gap: float = MAX_PAIR_GAP,
) -> Layout:
    """A :class:`Layout` from loudspeaker directions.

    Parameters
    ----------
    azimuths : array_like, shape (n,)
        Degrees, + left (pd-vbap angles).
    elevations : array_like, shape (n,), optional
        Degrees, + up; absent or all 0 means a horizontal (2-D) layout unless ``dim=3``.
    dim : {2, 3}, optional
        Inferred when absent: 3 if any elevation is not 0.
    triplets : array_like of int, shape (k, 3), optional
        3-D only: use these triplets (numbered **from 1**, as pd-vbap's ``ls-triplets``) instead of the
        hull's.  They are checked for valid indices and non-degenerate bases, not for overlaps.
    max_gap : float
        2-D: widest gap (degrees) between neighbours that is still panned across.

    Raises
    ------
    ValueError
        Too few loudspeakers, two in the same direction, non-finite angles, a bad ``dim`` or triplet.

    >>> make_layout([30, -30]).sets.tolist()
    [[1, 0]]
    """
    az, el, dim = _checked_angles(azimuths, elevations, dim)
    vectors = direction_vector(az, el)
    sets = _speaker_sets(az, el, vectors, dim, triplets, max_gap)
    inverses = []
    for s in sets:
        L = vectors[s][:, :dim].T
        if abs(np.linalg.det(L)) < 1e-9:
            raise ValueError(f"loudspeakers {' '.join(str(i + 1) for i in s)} make no valid set (flat)")
        inverses.append(np.linalg.inv(L))
    edges, border = _border(sets, az.size, dim)
    return Layout(
        azimuths=_frozen(az),
        elevations=_frozen(el),
        dim=dim,
        vectors=_frozen(vectors),
        sets=_frozen(np.asarray(sets, dtype=int).reshape(-1, dim)),
        inverses=_frozen(np.array(inverses, dtype=float).reshape(-1, dim, dim)),
        border_edges=_frozen(edges),
        border_speakers=_frozen(border.astype(int)),
    )


def _checked_angles(
    azimuths: ArrayLike, elevations: ArrayLike | None, dim: int | None
) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`make_layout`'s angles as arrays, checked, and its dimension (inferred when absent)."""
    az = np.asarray(azimuths, dtype=float).ravel()
    el = np.zeros_like(az) if elevations is None else np.asarray(elevations, dtype=float).ravel()
    if el.shape != az.shape:
        raise ValueError(f"{az.size} azimuths but {el.size} elevations")
    if not (np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
        raise ValueError("loudspeaker angles must be finite numbers")
    if dim is None or dim == 0:
        dim = 3 if np.any(el != 0.0) else 2
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3; got {dim}")
    if dim == 2 and np.any(el != 0.0):
        raise ValueError("a 2-D layout has azimuths only (elevations must be 0); use dim 3")
    n = az.size
    if n < dim:
        raise ValueError(f"a {dim}-D layout needs at least {dim} loudspeakers; got {n}")
    if n > MAX_SPEAKERS:
        raise ValueError(f"at most {MAX_SPEAKERS} loudspeakers; got {n}")
    return az, el, int(dim)


def _speaker_sets(
    az: np.ndarray,
    el: np.ndarray,
    vectors: np.ndarray,
    dim: int,
    triplets: ArrayLike | None,
    max_gap: float,
) -> np.ndarray:
    """The pairs (2-D) or triplets (3-D, the hull's or those given, numbered from 1) panned across,
    numbered from 0; no two loudspeakers may point the same way."""
    n = len(vectors)
    for i, j in itertools.combinations(range(n), 2):
        if float(vectors[i] @ vectors[j]) > 1.0 - 1e-12:
            raise ValueError(
                f"loudspeakers {i + 1} and {j + 1} point the same way (az {az[i]:g} el {el[i]:g})"
            )
    if dim == 2:
        if triplets is not None:
            raise ValueError("triplets are for 3-D layouts")
        sets = pairs_2d(az, max_gap=max_gap)
        if len(sets) == 0:
            raise ValueError(f"no loudspeaker pairs: every gap is wider than {max_gap:g} degrees")
        return sets
    if triplets is None:
        return triangulate(vectors)
    sets = np.asarray(triplets, dtype=int).reshape(-1, 3) - 1
    if len(sets) == 0 or sets.min() < 0 or sets.max() >= n:
        raise ValueError(f"triplets are loudspeaker numbers from 1 to {n}, three per triplet")
    if np.any((sets[:, 0] == sets[:, 1]) | (sets[:, 1] == sets[:, 2]) | (sets[:, 0] == sets[:, 2])):
        raise ValueError("a triplet names one loudspeaker twice")
    return sets


def _border(sets: np.ndarray, n: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """The layout's border: 3-D, the triplets' edges that only one triplet has, and the loudspeakers in
    no triplet; 2-D, no edges, and the loudspeakers in fewer than two pairs."""
    used = np.zeros(n, dtype=int)
    for s in sets:
        used[s] += 1
    if dim == 2:
        return np.zeros((0, 2), dtype=int), np.nonzero(used < 2)[0]
    count: dict[tuple[int, int], int] = {}
    for s in sets:
        for a, b in ((s[0], s[1]), (s[1], s[2]), (s[0], s[2])):
            key = (int(min(a, b)), int(max(a, b)))
            count[key] = count.get(key, 0) + 1
    edges = np.array(sorted(k for k, c in count.items() if c == 1), dtype=int).reshape(-1, 2)
    return edges, np.nonzero(used == 0)[0]


# ------------------------------------------------------------------------------------------- gains
def _point(layout: Layout, azimuth: float, elevation: float) -> np.ndarray:
    return direction_vector(azimuth, elevation if layout.dim == 3 else 0.0)


def _set_gains(layout: Layout, point: np.ndarray) -> tuple[int, np.ndarray]:
    """pd-vbap's choice: the set whose smallest gain is largest, and its unscaled gains."""
    g = layout.set_gains(point)
    best = int(np.argmax(g.min(axis=1)))
    return best, g[best]


def _scatter(layout: Layout, s: int, g: np.ndarray) -> np.ndarray:
    out = np.zeros(layout.n)
    g = np.where(g < 1e-12, 0.0, g)  # no negative gains, and no 1e-17 round-off at a loudspeaker
    out[layout.sets[s]] = g / np.linalg.norm(g)
    return out


def _nearest(layout: Layout, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, int | None]:
    """Gains and direction of the covered point nearest to ``p`` (on a border edge, or a loudspeaker:
    then its index)."""
    V = layout.vectors if layout.dim == 3 else layout.vectors * [1.0, 1.0, 0.0]
    spk = set(layout.border_speakers.tolist()) | set(layout.border_edges.ravel().tolist())
    candidates = sorted(spk) if spk else list(range(layout.n))
    best_i = candidates[int(np.argmax(V[candidates] @ p))]
    best_score, best_q, at = float(V[best_i] @ p), V[best_i], best_i
    gains = np.zeros(layout.n)
    gains[best_i] = 1.0
    if len(layout.border_edges):
        A, B = V[layout.border_edges[:, 0]], V[layout.border_edges[:, 1]]
        AxB = np.cross(A, B)
        sin_ab = np.linalg.norm(AxB, axis=1)
        m = AxB / sin_ab[:, None]
        q = p - (m @ p)[:, None] * m
        qn = np.linalg.norm(q, axis=1)
        ok = qn > 1e-12
        q[ok] /= qn[ok, None]
        ga = np.einsum("ij,ij->i", np.cross(q, B), m) / sin_ab
        gb = np.einsum("ij,ij->i", np.cross(A, q), m) / sin_ab
        between = ok & (ga >= 0.0) & (gb >= 0.0)
        if np.any(between):
            score = np.where(between, q @ p, -np.inf)
            j = int(np.argmax(score))
            if score[j] > best_score + 1e-12:
                gains = np.zeros(layout.n)
                g = np.array([ga[j], gb[j]])
                gains[layout.border_edges[j]] = g / np.linalg.norm(g)
                best_q, at = q[j], None
    return gains, best_q, at


def _center(layout: Layout, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, int | None]:
    """Unit-power gains for the unit vector ``p``, the direction actually panned, and the index of the
    loudspeaker it was moved to (None when ``p`` is inside the loudspeakers, or moved onto an edge)."""
    s, g = _set_gains(layout, p)
    if g.min() >= -INSIDE_TOL:
        return _scatter(layout, s, g), p, None
    return _nearest(layout, p)


def _additive(layout: Layout, dirs: np.ndarray) -> np.ndarray:
    """The summed unit-power gains of several spread directions, shape (n,).

    A direction whose best set has a gain below -0.01 is outside every set and skipped (pd-vbap's
    ``additive_vbap``); gains between -0.01 and 0 are set to 0 (pd-vbap keeps them, negative).
    """
    g = np.einsum("kij,mj->mki", layout.inverses, dirs[:, : layout.dim])  # (m, k, dim)
    best = np.argmax(g.min(axis=2), axis=1)
    chosen = g[np.arange(len(dirs)), best]  # (m, dim)
    keep = chosen.min(axis=1) >= PD_NEGATIVE
    chosen = np.where(chosen[keep] < 1e-12, 0.0, chosen[keep])
    total = np.zeros(layout.n)
    np.add.at(total, layout.sets[best[keep]], chosen / np.linalg.norm(chosen, axis=1, keepdims=True))
    return total


def _spread_dirs(vs: np.ndarray, bases: np.ndarray, spread: float, azimuth: float) -> np.ndarray:
    """pd-vbap's ``new_spread_dir`` for several bases, shape (m, 3): ``vs`` turned ``spread`` degrees
    toward each base by the sine rule (the bases need not be unit vectors; pd-vbap's are not)."""
    bases = np.array(bases, dtype=float)
    gamma = np.degrees(np.arccos(np.clip(bases @ vs, -1.0, 1.0)))
    redo = (np.abs(gamma) < 1.0) | (gamma > 179.0)  # pd-vbap checks < 1 only (> 179 divides by 0 there)
    if np.any(redo):
        bases[redo] = direction_vector(azimuth + 90.0, 0.0)
        gamma[redo] = np.degrees(np.arccos(np.clip(bases[redo] @ vs, -1.0, 1.0)))
    beta = np.radians(180.0 - gamma)
    s = math.radians(spread)
    b = math.sin(s) / np.sin(beta)
    a = np.sin(math.pi - s - beta) / np.sin(beta)
    d = a[:, None] * vs + b[:, None] * bases
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / math.sqrt(float(v @ v))


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.array([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])


def _spread(
    layout: Layout, p: np.ndarray, azimuth: float, spread: float, gains: np.ndarray, base: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """pd-vbap's ``spread_it``: add the gains of directions around ``p``; returns gains and the new base."""
    if layout.dim == 2:
        k = np.array([-1.0, -0.5, -0.25, 0.25, 0.5, 1.0])
        dirs = direction_vector(azimuth + k * spread, np.zeros(6))
    else:
        d0 = _spread_dirs(p, base[None, :], spread, azimuth)[0]
        base = _unit(d0 - math.cos(math.radians(spread)) * p)  # new_spread_base
        b = [base]
        for _ in range(3):  # four orthogonal directions around p
            b.append(_unit(_cross(b[-1], p)))
        b += [(b[i] + b[(i + 1) % 4]) / 2.0 for i in range(4)]  # four between them
        b += [(p + b[i]) / 2.0 for i in range(4)]  # four at half the spread
        b += [(p + b[8 + i]) / 2.0 for i in range(4)]  # four at a quarter
        dirs = np.vstack([d0, _spread_dirs(p, np.array(b[1:]), spread, azimuth)])
    total = gains + _additive(layout, dirs)
    if spread > 70.0:
        total += ((spread - 70.0) / 30.0) ** 2 * 10.0
    return total / np.linalg.norm(total), base


class Panner:
    """VBAP with pd-vbap's state: the spread base (3-D) carries over from one direction to the next.

    >>> p = Panner(make_layout([30, -30]))
    >>> p.gains(0.0).round(6).tolist(), p.direction
    ([0.707107, 0.707107], (0.0, 0.0))
    >>> p.gains(90.0).tolist(), p.direction        # outside the pair: the nearest loudspeaker
    ([1.0, 0.0], (30.0, 0.0))
    """

    def __init__(self, layout: Layout) -> None:
        self.layout = layout
        self.reset()

    def reset(self) -> None:
        """Forget the spread base (pd-vbap's initial one, +y) and the last direction."""
        self._base = np.array([0.0, 1.0, 0.0])
        self.direction: tuple[float, float] = (0.0, 0.0)

    def gains(self, azimuth: float, elevation: float = 0.0, spread: float = 0.0) -> np.ndarray:
        """Unit-power gains, one per loudspeaker, for a source direction (degrees) and spread (0..100).

        Also sets :attr:`direction`, the direction actually panned: the source's own inside the
        loudspeakers (elevation 0 in 2-D), the nearest covered one outside.
        """
        if not (math.isfinite(azimuth) and math.isfinite(elevation) and math.isfinite(spread)):
            raise ValueError("direction and spread must be finite numbers")
        p = _point(self.layout, azimuth, elevation)
        g, used, at = _center(self.layout, p)
        if used is p:  # keep the given angles (no round trip through atan2)
            az, el = float(_wrap180(np.asarray(azimuth))), float(elevation) if self.layout.dim == 3 else 0.0
        elif at is not None:  # moved to a loudspeaker: its own angles
            az, el = float(_wrap180(self.layout.azimuths[at])), float(self.layout.elevations[at])
        else:
            az, el = vector_direction(used)
        self.direction = (az, el)
        spread = min(max(float(spread), 0.0), 100.0)
        if spread >= 1e-5:
            g, self._base = _spread(self.layout, _unit(used), az, spread, g, self._base)
        return g


def vbap_gains(layout: Layout, azimuth: float, elevation: float = 0.0, spread: float = 0.0) -> np.ndarray:
    """Unit-power VBAP gains, one per loudspeaker, for one direction (degrees) and spread (0..100).

    Stateless: a 3-D spread starts from pd-vbap's initial spread base (use :class:`Panner` for a moving
    source).

    >>> quad = make_layout([45, 135, -135, -45])
    >>> vbap_gains(quad, 90.0).round(6).tolist()
    [0.707107, 0.707107, 0.0, 0.0]
    >>> float((vbap_gains(quad, 10.0, spread=30) ** 2).sum())
    1.0
    """
    return Panner(layout).gains(azimuth, elevation, spread)


# ------------------------------------------------------------------------------------------ layouts
def parse_layout(values: Any, dim: int = 0, triplets: ArrayLike | None = None) -> Layout:
    """A layout from a patch parameter: azimuths, ``[az, el]`` pairs, or a flat ``az el ...`` list (dim 3).

    >>> parse_layout([0, 120, -120]).dim
    2
    >>> parse_layout([[0, 0], [120, 0], [-120, 0], [0, 90]]).dim
    3
    >>> parse_layout([0, 0, 120, 0, -120, 0, 0, 90], dim=3).n
    4
    """
    items = list(values)
    if not items:
        raise ValueError("empty loudspeaker layout")
    if all(isinstance(v, (list, tuple, np.ndarray)) for v in items):
        if any(len(v) != 2 for v in items):
            raise ValueError("a 3-D layout lists [azimuth, elevation] pairs")
        az = [float(v[0]) for v in items]
        el = [float(v[1]) for v in items]
        return make_layout(az, el, dim=dim or None, triplets=triplets)
    if any(isinstance(v, (list, tuple, np.ndarray, str)) for v in items):
        raise ValueError(f"a layout is numbers (azimuths) or [azimuth, elevation] pairs; got {items!r}")
    nums = [float(v) for v in items]
    if dim == 3:
        if len(nums) % 2:
            raise ValueError("a flat 3-D layout is azimuth elevation pairs: an even count of numbers")
        return make_layout(nums[0::2], nums[1::2], dim=3, triplets=triplets)
    return make_layout(nums, dim=dim or 2, triplets=triplets)


_SELECTORS = ("define_loudspeakers", "define-loudspeakers", "ls-directions")


def _parse_pd_text(text: str, where: str) -> Layout:
    directions: list[float] | None = None
    triplets: list[float] | None = None
    text = "\n".join(line.split("#", 1)[0] for line in text.splitlines())
    for statement in re.split(r"[;\n]", text):
        words = statement.split()
        if not words:
            continue
        head, args = words[0], words[1:]
        try:
            nums = [float(w) for w in args]
        except ValueError:
            raise ValueError(f"{where}: '{head}' takes numbers; got {' '.join(args)!r}") from None
        if head in _SELECTORS:
            if directions is not None:
                raise ValueError(f"{where}: the loudspeaker directions are given twice")
            directions = nums
        elif head == "ls-triplets":
            if len(nums) % 3 or not nums:
                raise ValueError(f"{where}: ls-triplets takes loudspeaker numbers, three per triplet")
            triplets = (triplets or []) + nums
        else:
            raise ValueError(
                f"{where}: unknown message '{head}' (expected {', '.join(_SELECTORS)}, ls-triplets)"
            )
    if not directions:
        raise ValueError(f"{where}: no 'define_loudspeakers DIM az [el] ...' line")
    d, rest = int(directions[0]), directions[1:]
    if d not in (2, 3):
        raise ValueError(f"{where}: the first number is the dimension, 2 or 3; got {directions[0]:g}")
    trip = None if triplets is None else np.array(triplets, dtype=int).reshape(-1, 3)
    return parse_layout(rest, dim=d, triplets=trip)


def read_layout(path: str | Path) -> Layout:
    """Read a layout file: ``.json`` or Pd message text (see the module docstring).

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it (``OSError`` when it cannot be read).
    """
    path = Path(path)
    text = read_text(path, "layout")  # a regular file of 4 MB at most: a pipe is refused, never waited on
    if path.suffix.lower() != ".json":
        return _parse_pd_text(text, str(path))
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON: {exc}") from exc
    except RecursionError:
        raise ValueError(f"{path}: JSON nested too deeply: expected a loudspeaker layout") from None
    if not isinstance(data, dict) or "speakers" not in data:
        raise ValueError(f'{path}: expected an object with "speakers" (and optionally "dim", "triplets")')
    unknown = set(data) - {"speakers", "dim", "triplets", "name", "comment"}
    if unknown:
        raise ValueError(f"{path}: unknown keys {sorted(unknown)} (speakers, dim, triplets, name, comment)")
    try:
        return parse_layout(data["speakers"], dim=int(data.get("dim", 0)), triplets=data.get("triplets"))
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{path}: {exc}") from exc


def _num(x: float) -> float | int:
    x = float(x)
    return int(x) if x.is_integer() else x


def pd_messages(layout: Layout) -> list[tuple[str, list[float | int]]]:
    """The messages that give pd-vbap this layout (and, in 3-D, these triplets), as (selector, args).

    2-D: ``define_loudspeakers 2 az ...`` (pd-vbap's own pairs are the same).  3-D: ``ls-directions 3
    az el ...`` and ``ls-triplets a b c ...`` (loudspeakers numbered from 1) for a
    ``[define_loudspeakers]`` object, then a ``bang`` to it, whose output goes to ``[vbap]``.

    >>> pd_messages(make_layout([30, -30]))
    [('define_loudspeakers', [2, 30, -30])]
    """
    if layout.dim == 2:
        return [("define_loudspeakers", [2, *(_num(a) for a in layout.azimuths)])]
    directions: list[float | int] = [3]
    for a, e in zip(layout.azimuths, layout.elevations, strict=True):
        directions += [_num(a), _num(e)]
    triplets = [int(i) + 1 for i in layout.sets.ravel()]
    return [("ls-directions", directions), ("ls-triplets", triplets)]


def format_layout(layout: Layout) -> str:
    """The layout as Pd message text (one message per line), readable by :func:`read_layout`.

    >>> print(format_layout(make_layout([30, -30])))
    define_loudspeakers 2 30 -30;
    """
    lines = []
    for selector, args in pd_messages(layout):
        lines.append(
            " ".join([selector, *(f"{a:.10g}" if isinstance(a, float) else str(a) for a in args)]) + ";"
        )
    return "\n".join(lines)
