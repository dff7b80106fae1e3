"""Delaunay-admissible boundaries (§9.1.2-§9.1.5): facts a reader can check.

Every output segment must be an edge of the Delaunay triangulation of the
output points (checked with our kernel, rebuilt from scratch, and with
scipy's Qhull where the points are in general position); every input segment
must be the chain of its output pieces, in order and on the segment (on the
circle for a ring that declares one); the empty triangulation of the domain
must cover exactly the domain's area.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay as Qhull

import meshcore.delaunay.admissible as admissible_mod
from meshcore.delaunay.admissible import (
    admissible_segments,
    circles_of,
    classify_segments,
    make_admissible,
    restricted_triangles,
)
from meshcore.delaunay.admissible_pieces import _grid_reach
from meshcore.delaunay.kernel2d import delaunay
from meshcore.domain.planar import parse_domain
from meshcore.errors import AlgorithmError, Cancelled, InputError
from meshcore.geometry.constructions import point_segment_distance
from meshcore.geometry.predicates import dot2d, incircle, orient2d
from meshcore.mesh import CellBlock, Mesh
from meshcore.triangulation.refinement import triangulate

# ---------------------------------------------------------------------------
# Test domains
# ---------------------------------------------------------------------------


def star_ring(n: int = 50, seed: int = 1, r0: float = 0.3) -> np.ndarray:
    """A random star polygon: sorted random angles, random radii in [r0, 1]."""
    rng = np.random.default_rng(seed)
    angle = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
    radius = rng.uniform(r0, 1.0, n)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def comb_ring(teeth: int = 9, degrees: float = 5.0, heights=(4.0, 3.0, 1.0)) -> np.ndarray:
    """A comb of adjacent 5° spikes of heights 4, 3, 1, ... on a base of depth 1.

    ::

         /\\
        /  \\/\\
       /    \\  \\/\\   ...
      +-----------------+
      +-----------------+
    """
    pts, x = [], 0.0
    for i in range(teeth):
        h = heights[i % len(heights)]
        w = 2.0 * h * math.tan(math.radians(degrees / 2.0))
        pts += [[x, 0.0], [x + w / 2.0, h]]
        x += w
    pts += [[x, 0.0], [x, -1.0], [0.0, -1.0]]
    # Dyadic coordinates (multiples of 2**-20): translations by 1e6 and
    # scalings by powers of two are exact.
    return np.round(np.array(pts) * 2.0**20) / 2.0**20


def ring_segments(n: int) -> np.ndarray:
    i = np.arange(n)
    return np.column_stack([i, (i + 1) % n])


#: An L whose inner horizontal side sees the bottom samples through the notch:
#: the inner vertical side is sampled every 1/4, the bottom every 1.
#:
#:   +
#:   |:
#:   |:   (inner side sampled densely)
#:   |+--------+
#:   +-+-+-+---+
L_SHAPE = {
    "type": "Polygon",
    "coordinates": [
        [[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [4, 1], [1, 1]]
        + [[1, 1 + k / 4] for k in range(1, 13)]
        + [[0, 4]]
    ],
}


def _grid_ring(corners, step=1):
    out = []
    for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1], strict=True):
        n = max(abs(bx - ax), abs(by - ay)) // step
        out += [[ax + (bx - ax) * k // n, ay + (by - ay) * k // n] for k in range(n)]
    return out


#: A 6 x 6 square with a 2 x 2 square hole, every ring vertex and the
#: constraints on the integer grid: co-circular quadruples everywhere.
GRID = {
    "type": "Polygon",
    "coordinates": [
        _grid_ring([(0, 0), (6, 0), (6, 6), (0, 6)]),
        _grid_ring([(2, 2), (2, 4), (4, 4), (4, 2)]),
    ],
}
GRID_CONSTRAINTS = [[[1, y] for y in range(1, 6)], [[5, 1], [5, 5]]]


def island_domain():
    """A square sampled every 1/8 with a circular hole sampled unevenly (12
    points on a quarter, 7 on the rest) and an island inside the hole.

    The island's points are inside the hole's circle, so some chords of the
    hole are not Delaunay: they must be split, on the circle if declared.
    """
    radius = 0.45
    theta = np.concatenate(
        [
            np.linspace(0, np.pi / 2, 12, endpoint=False),
            np.linspace(np.pi / 2, 2 * np.pi, 7, endpoint=False),
        ]
    )
    hole = np.column_stack([0.5 + radius * np.cos(theta), 0.5 + radius * np.sin(theta)])
    t = np.arange(8) / 8
    zero, one = 0 * t, 1 + 0 * t
    square = np.concatenate(
        [
            np.column_stack([t, zero]),
            np.column_stack([one, t]),
            np.column_stack([1 - t, one]),
            np.column_stack([zero, 1 - t]),
        ]
    )
    island = [[0.3, 0.3], [0.5, 0.25], [0.5, 0.4], [0.3, 0.5]]
    geometry = {
        "type": "MultiPolygon",
        "coordinates": [[square.tolist(), hole.tolist()], [island]],
    }
    curve = {"ring": 1, "type": "circle", "center": [0.5, 0.5], "radius": radius}
    return geometry, curve


def polygon(ring: np.ndarray) -> dict:
    return {"type": "Polygon", "coordinates": [ring.tolist()]}


# ---------------------------------------------------------------------------
# Checks
# ---------------------------------------------------------------------------


def edge_keys(triangles: np.ndarray, n: int) -> np.ndarray:
    t = np.asarray(triangles, dtype=np.int64)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    return np.unique(np.minimum(a, b) * n + np.maximum(a, b))


def segment_keys(segments: np.ndarray, n: int) -> np.ndarray:
    s = np.asarray(segments, dtype=np.int64)
    return np.minimum(s[:, 0], s[:, 1]) * n + np.maximum(s[:, 0], s[:, 1])


def assert_delaunay_edges(points, segments, qhull: bool = False) -> None:
    """Every segment is an edge of the Delaunay triangulation of the points,
    by our kernel rebuilt from scratch; with ``qhull``, also by scipy's
    Qhull, except where the segment's quadrilateral is co-circular to within
    rounding (projections make right angles, hence Thales circles through
    four points, footnote 4 of §9.1.3): there Qhull's floating-point choice
    may take the other diagonal, and our exact in-circle test must find the
    segment locally Delaunay."""
    n = len(points)
    tri = delaunay(points)
    keys = segment_keys(segments, n)
    assert np.isin(keys, edge_keys(tri.triangles, n)).all()
    if not qhull:
        return
    dropped = np.flatnonzero(~np.isin(keys, edge_keys(Qhull(points).simplices, n)))
    for i in dropped:
        a, b = (int(v) for v in segments[i])
        t = tri.triangles
        both = np.flatnonzero(((t == a) | (t == b)).sum(axis=1) == 2)
        assert len(both) == 2
        c, d = (int(np.setdiff1d(t[k], [a, b])[0]) for k in both)
        if orient2d(points[a], points[b], points[c]) < 0:
            c, d = d, c
        assert incircle(points[a], points[b], points[c], points[d]) <= 0
        rows = np.array([[*(points[v] - points[d]), 0.0] for v in (a, b, c)])
        rows[:, 2] = rows[:, 0] ** 2 + rows[:, 1] ** 2
        near_tie = abs(np.linalg.det(rows)) / np.abs(rows[:, 2]).max() ** 2
        assert near_tie < 1e-12


def assert_chains(points, segments, res, circle=None, curved=None) -> None:
    """Input segment i is the chain of the output rows with source i: those
    rows are consecutive, go from its first point to its second, and their
    inner points lie on it in order (on the circle, in angular order, for
    the input segments in ``curved``)."""
    points, segments = np.asarray(points, float), np.asarray(segments)
    src, out, P = res.source, res.segments, res.points
    np.testing.assert_array_equal(P[: len(points)], points)
    assert (np.diff(src) >= 0).all()
    np.testing.assert_array_equal(np.unique(src), np.arange(len(segments)))
    first = np.flatnonzero(np.r_[True, src[1:] != src[:-1]])
    last = np.r_[first[1:] - 1, len(src) - 1]
    np.testing.assert_array_equal(out[first, 0], segments[:, 0])
    np.testing.assert_array_equal(out[last, 1], segments[:, 1])
    inner = np.flatnonzero(src[1:] == src[:-1])
    np.testing.assert_array_equal(out[inner, 1], out[inner + 1, 0])
    # Inner points: on the segment (or the circle), strictly in order.
    s = src[inner]
    a, b, m = P[segments[s, 0]], P[segments[s, 1]], P[out[inner, 1]]
    scale = np.abs(P).max() + np.ptp(P, axis=0).max()
    on_curve = np.zeros(len(s), dtype=bool) if curved is None else np.isin(s, curved)
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    t = np.einsum("ij,ij->i", m - a, d) / length**2
    off = np.abs(d[:, 0] * (m - a)[:, 1] - d[:, 1] * (m - a)[:, 0]) / length
    assert (off[~on_curve] <= 8 * np.finfo(float).eps * scale).all()
    if on_curve.any():
        (cx, cy), r = circle["center"], circle["radius"]
        rad = np.hypot(m[on_curve, 0] - cx, m[on_curve, 1] - cy)
        assert np.abs(rad - r).max() <= 1e-12 * r
    # Order along each input segment: the parameter of the chord increases.
    assert ((t > 0) & (t < 1)).all()
    same = s[1:] == s[:-1]
    assert (t[1:][same] > t[:-1][same]).all()


def triangle_areas(mesh) -> np.ndarray:
    p = mesh.points[mesh.cells[0].data]
    return 0.5 * (
        (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
        - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    )


def input_arrays(domain):
    return domain.points, np.concatenate([domain.segments, domain.constraints])


def check_domain(domain, res, qhull=False, curve=None) -> None:
    points, segments = input_arrays(domain)
    assert_delaunay_edges(res.points, res.segments, qhull=qhull)
    curved = None
    if curve is not None:
        k = curve["ring"]
        curved = np.arange(domain.ring_offsets[k], domain.ring_offsets[k + 1])
    assert_chains(points, segments, res, circle=curve, curved=curved)
    assert res.added == len(res.points) - len(points)
    areas = triangle_areas(res.triangulation)
    assert areas.min() > 0
    if curve is None:
        # Split points are rounded to the coordinates' ulp: far from the
        # origin (translated domains) that moves the area by up to about
        # ulp * diameter per added point.
        diameter = np.ptp(res.points, axis=0).max()
        rounding = 4 * res.added * np.spacing(np.abs(res.points).max()) * diameter
        assert abs(areas.sum() - domain.area) <= max(1e-12 * domain.area, rounding)
    for cases in (res.cases_before, res.cases_after):
        assert set(cases) == {"case0", "case1", "case2"}
    assert sum(res.cases_before.values()) == len(segments)
    assert sum(res.cases_after.values()) == len(res.segments)


def split_inputs(res, m: int) -> np.ndarray:
    return np.bincount(res.source, minlength=m) > 1


NAMED = {
    "comb": lambda: (polygon(comb_ring()), None),
    "star": lambda: (polygon(star_ring()), None),
    "L": lambda: (L_SHAPE, None),
    "grid": lambda: (GRID, GRID_CONSTRAINTS),
    "island": lambda: (island_domain()[0], None),
}


# ---------------------------------------------------------------------------
# Classification (§9.1.2)
# ---------------------------------------------------------------------------


def test_classification_of_a_hand_drawn_example():
    #   D(0,3)            C(4,3)
    #     +----------------+
    #     |      F(2,2.5)  |
    #     |   E(2,1)       |
    #     +----------------+
    #   A(0,0)            B(4,0)
    # AB lies on the hull (Case 0); AE's diametral ball (centre (1, 0.5),
    # radius 1.118) holds no point (Case 1); the diagonal DB's ball (centre
    # (2, 1.5), radius 2.5) holds E and F (Case 2).
    points = np.array([[0, 0], [4, 0], [4, 3], [0, 3], [2, 1], [2, 2.5]], dtype=float)
    segments = np.array([[0, 1], [0, 4], [3, 1]])
    np.testing.assert_array_equal(classify_segments(points, segments), [0, 1, 2])


def test_a_point_on_the_diametral_circle_is_not_inside():
    # (0, 2) sees the segment (-2, 0)-(2, 0) at exactly 90°: the open ball is
    # empty, so the segment is Case 1 (decided exactly, not by rounding).
    points = np.array([[-2, 0], [2, 0], [0, 2], [0, -3]], dtype=float)
    assert classify_segments(points, [[0, 1]])[0] == 1
    assert classify_segments(points + 1e6, [[0, 1]])[0] == 1


def test_collinear_hull_runs_are_case_0():
    # Samples along the bottom of a rectangle: every piece lies on the hull.
    points = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [0, 1], [1.5, 0.4]])
    segments = np.array([[0, 1], [1, 2], [2, 3], [0, 6]])
    np.testing.assert_array_equal(classify_segments(points, segments)[:3], [0, 0, 0])


# ---------------------------------------------------------------------------
# Named domains
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(NAMED))
def test_named_domains_become_delaunay_admissible(name):
    geometry, constraints = NAMED[name]()
    domain = parse_domain(geometry, constraints)
    res = make_admissible(domain)
    check_domain(domain, res, qhull=name in ("comb", "star", "island"))
    points, segments = input_arrays(domain)
    tri = delaunay(points)
    missing = ~np.isin(segment_keys(segments, len(points)), edge_keys(tri.triangles, len(points)))
    split = split_inputs(res, len(segments))
    cases = classify_segments(points, segments)
    # Non-Delaunay input segments are split; Case 0 segments never are; a
    # Case 1 segment whose closed diametral ball receives no added point
    # stays whole.
    assert split[missing].all()
    assert not split[cases == 0].any()
    added = res.points[len(points) :]
    for i in np.flatnonzero(cases == 1):
        a, b = points[segments[i]]
        if not (dot2d(a, b, added) <= 0).any():
            assert not split[i]
    assert res.added > 0


@pytest.mark.parametrize("name", ["comb", "L", "grid"])
def test_only_the_segments_that_are_not_delaunay_are_split(name):
    # On these domains no split lands in another segment's diametral ball, so
    # exactly the input's non-Delaunay (Case 2) segments are split and every
    # Case 0 / Case 1 segment is untouched.
    geometry, constraints = NAMED[name]()
    domain = parse_domain(geometry, constraints)
    res = make_admissible(domain)
    points, segments = input_arrays(domain)
    tri = delaunay(points)
    missing = ~np.isin(segment_keys(segments, len(points)), edge_keys(tri.triangles, len(points)))
    split = split_inputs(res, len(segments))
    np.testing.assert_array_equal(split, missing)
    cases = classify_segments(points, segments)
    assert (cases[split] == 2).all()


def test_the_star_and_comb_counts():
    # benchmarks/admissible.py: CGAL's conforming Delaunay adds 66 points on
    # the 50-vertex star and 48 on its 5°-corner polygon (Triangle's
    # pD 112 and 148); we add 28 and 16 here. Only Case 2 segments can be
    # non-Delaunay, and after the splits few Case 2 segments remain (each a
    # Delaunay edge through its triangle fP, §9.1.3).
    star = admissible_segments(star_ring(), ring_segments(50))
    comb = comb_ring()
    comb_res = admissible_segments(comb, ring_segments(len(comb)))
    assert star.added <= 30 and comb_res.added <= 20
    assert star.cases_before == {"case0": 2, "case1": 25, "case2": 23}
    assert comb_res.cases_before == {"case0": 5, "case1": 5, "case2": 11}
    assert comb_res.cases_after["case2"] < comb_res.cases_before["case2"]


def test_the_l_shape_is_split_at_the_projection():
    # The bottom sample (2, 0) encroaches the inner side (4, 1)-(1, 1); its
    # projection (2, 1), moved away from the nearer end (1, 1) by 2**-20 of
    # its distance (the tie-breaking nudge), is the one point added.
    domain = parse_domain(L_SHAPE)
    res = make_admissible(domain)
    (added,) = res.points[len(domain.points) :]
    assert added[1] == 1.0
    assert math.isclose(added[0], 2.0 + 2.0**-20, rel_tol=1e-15)
    assert res.cases_before == {"case0": 7, "case1": 12, "case2": 1}
    assert res.cases_after == {"case0": 7, "case1": 14, "case2": 0}


# ---------------------------------------------------------------------------
# Curves (§9.1.5)
# ---------------------------------------------------------------------------


def test_points_added_on_a_declared_circle_lie_on_it():
    geometry, curve = island_domain()
    domain = parse_domain(geometry)
    flat = make_admissible(domain)
    res = make_admissible(domain, curves=[curve])
    check_domain(domain, res, qhull=True, curve=curve)
    hole = np.arange(domain.ring_offsets[1], domain.ring_offsets[2])
    assert split_inputs(res, len(domain.segments))[hole].any()
    # Without the curve the same chords are split on the chord.
    check_domain(domain, flat, qhull=True)
    assert flat.added == res.added


def test_curves_are_validated_with_their_location():
    geometry, curve = island_domain()
    domain = parse_domain(geometry)
    bad = [
        ({**curve, "ring": 7}, ("curves", 0, "ring"), "bad_curve"),
        ({**curve, "radius": -1.0}, ("curves", 0, "radius"), "bad_curve"),
        ({**curve, "type": "ellipse"}, ("curves", 0, "type"), "bad_curve"),
        ({**curve, "center": [0.5, float("nan")]}, ("curves", 0, "center"), "bad_curve"),
        ({**curve, "radius": 0.4}, ("curves", 0, "radius"), "curve_mismatch"),
        ({**curve, "ring": 0}, ("curves", 0, "radius"), "curve_mismatch"),
    ]
    for item, loc, code in bad:
        with pytest.raises(InputError) as info:
            circles_of(domain, [item])
        assert info.value.code == code
        assert tuple(info.value.errors[0]["loc"]) == loc
    with pytest.raises(InputError) as info:
        circles_of(domain, [curve, curve])
    assert tuple(info.value.errors[0]["loc"]) == ("curves", 1, "ring")
    # Within 1e-6 of the diameter is accepted.
    circles, seg_circle = circles_of(domain, [{**curve, "radius": 0.45 + 1e-7}])
    assert len(circles) == 1 and (seg_circle >= 0).sum() == 19


# ---------------------------------------------------------------------------
# Translations and scalings
# ---------------------------------------------------------------------------


def _moved(geometry: dict, constraints, shift: float, scale: float):
    def move(x):
        if isinstance(x, list) and x and isinstance(x[0], int | float):
            return [v * scale + shift for v in x]
        return [move(v) for v in x]

    moved = {**geometry, "coordinates": move(geometry["coordinates"])}
    return moved, None if constraints is None else move(constraints)


@pytest.mark.parametrize("name", ["L", "grid", "comb"])
@pytest.mark.parametrize(("shift", "scale"), [(1e6, 1.0), (2.0**20, 1.0), (0.0, 2.0**-20)])
def test_exactly_translated_and_scaled_domains_give_the_same_result(name, shift, scale):
    # Dyadic inputs moved exactly: every decision is the same exact sign, so
    # the discretization is the same; split points agree up to the rounding
    # of the construction at the new position (exactly for the L and the
    # grid, whose splits are exact).
    geometry, constraints = NAMED[name]()
    base = make_admissible(parse_domain(geometry, constraints))
    moved_geometry, moved_constraints = _moved(geometry, constraints, shift, scale)
    domain = parse_domain(moved_geometry, moved_constraints)
    res = make_admissible(domain)
    check_domain(domain, res)
    np.testing.assert_array_equal(res.segments, base.segments)
    np.testing.assert_array_equal(res.source, base.source)
    assert res.cases_before == base.cases_before and res.cases_after == base.cases_after
    back = (res.points - shift) / scale
    if name == "comb":
        ulp = np.spacing(np.abs(res.points).max()) / scale
        np.testing.assert_allclose(back, base.points, rtol=0, atol=4 * ulp)
    else:
        np.testing.assert_array_equal(back, base.points)


@pytest.mark.parametrize("name", ["L", "grid", "comb", "star"])
def test_domains_scaled_by_1e_6_stay_admissible(name):
    # 1e-6 is not a power of two: the scaled input is rounded, ties of the
    # grid and the comb's symmetric spikes may break either way, so only
    # the facts are checked, and the size of the answer.
    geometry, constraints = NAMED[name]()
    base = make_admissible(parse_domain(geometry, constraints))
    moved_geometry, moved_constraints = _moved(geometry, constraints, 0.0, 1e-6)
    domain = parse_domain(moved_geometry, moved_constraints)
    res = make_admissible(domain)
    check_domain(domain, res)
    assert abs(res.added - base.added) <= max(2, base.added // 5)


# ---------------------------------------------------------------------------
# Termination guards (Exercises 9.2-9.4)
# ---------------------------------------------------------------------------


def test_protected_vertices_get_pieces_of_one_length():
    # On this star, a spike's segment is split near its tip twice: the tip is
    # protected, and every piece of its acute cluster cut there has the
    # common length r (Exercise 9.4).
    ring = star_ring(50, seed=2, r0=0.1)
    res = admissible_segments(ring, ring_segments(50))
    assert len(res.protected) > 0
    assert_delaunay_edges(res.points, res.segments, qhull=True)
    seg, P = res.segments, res.points
    for v, r in zip(res.protected, res.protection_radius, strict=True):
        at_v = np.flatnonzero((seg == v).any(axis=1))
        other = np.where(seg[at_v, 0] == v, seg[at_v, 1], seg[at_v, 0])
        length = np.hypot(*(P[other] - P[v]).T)
        assert np.isclose(length, r, rtol=1e-12).any()
        assert (length >= r * (1 - 1e-12)).all()


def test_a_fan_of_segments_at_small_angles_terminates():
    # A non-manifold vertex: eight segments from the origin within 20°, of
    # random lengths (Exercise 9.4), inside a box.
    rng = np.random.default_rng(5)
    angle = np.sort(rng.uniform(0, np.radians(20), 8))
    length = rng.uniform(0.2, 1.0, 8)
    ends = np.column_stack([length * np.cos(angle), length * np.sin(angle)])
    box = [[-1.0, -1.0], [2.0, -1.0], [2.0, 2.0], [-1.0, 2.0]]
    points = np.vstack([[0.0, 0.0], ends, box])
    segments = np.column_stack([np.zeros(8, dtype=int), np.arange(1, 9)])
    res = admissible_segments(points, segments)
    assert_delaunay_edges(res.points, res.segments, qhull=True)
    assert_chains(points, segments, res)


def test_a_projection_next_to_an_endpoint_falls_back_to_half_the_distance():
    # P = (0.001, 0.02) sees E F at 91.7°, the widest angle (Q below sees it
    # at 88.9° but lies in the circle E F P, so E F is not Delaunay). P's
    # projection would leave a piece of 0.001 next to E, where |EP| = 0.02:
    # the split goes to |EP| / 2 instead, and that one point suffices.
    #
    #     P
    #   E-+-----------F
    #
    #          Q
    points = np.array([[0.0, 0.0], [1.0, 0.0], [0.001, 0.02], [0.5, -0.51]])
    res = admissible_segments(points, [[0, 1]])
    assert res.added == 1
    half = math.hypot(0.001, 0.02) / 2 * (1 + 2.0**-20)  # with the nudge
    np.testing.assert_allclose(res.points[4], [half, 0.0], rtol=1e-15)
    assert_delaunay_edges(res.points, res.segments, qhull=True)


@pytest.mark.parametrize("other", [[[0, 1], [1, 0]], [[0, 0.9], [1, 0.2]]])
def test_crossing_segments_fail_with_an_algorithm_error(other):
    # Not a planar straight-line graph: the splits converge on the crossing
    # until one lands on the other segment, or float64 runs out there.
    points = np.array([[0, 0], [1, 1], *other, [2, 2], [-1, 2]], dtype=float)
    with pytest.raises(AlgorithmError, match="cross"):
        admissible_segments(points, [[0, 1], [2, 3]])


def test_the_limit_on_added_points_is_named_when_reached(monkeypatch):
    # a valid star past the limit was told "do segments cross?"
    monkeypatch.setattr(admissible_mod, "MAX_ADDED_FACTOR", 0)
    monkeypatch.setattr(admissible_mod, "MAX_ADDED_BASE", 10)
    with pytest.raises(AlgorithmError, match="within 10 added points") as info:
        admissible_segments(star_ring(), ring_segments(50))
    assert "cross" not in str(info.value)


def test_a_point_inside_a_segment_is_refused():
    points = np.array([[0, 0], [2, 0], [1, 0], [1, 1], [1, -1]], dtype=float)
    with pytest.raises(InputError) as info:
        admissible_segments(points, [[0, 1]])
    assert info.value.code == "point_on_segment"
    assert info.value.errors[0]["loc"] == ["segments", 0]


# ---------------------------------------------------------------------------
# Raw arrays, restriction, progress
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "segments", "code"),
    [
        ([[0, 0], [1, 0], [0, float("nan")]], [[0, 1]], "non_finite"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 3]], "index_out_of_range"),
        ([[0, 0], [1, 0], [0, 1]], [[1, 1]], "degenerate_segment"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 0]], "duplicate_segment"),
        ([[0, 0], [1, 0], [2, 0], [0, 1]], [[0, 1], [0, 2]], "overlapping_segments"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 0]], [[0, 1]], "duplicate_points"),
        # numpy would read these as numbers (True, "1") or truncate them (1.5)
        ([[0, 0], [1, True], [0, 1]], [[0, 1]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 1]], [[0, True]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 1]], [["0", "1"]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1.5]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 1]], [[0, float("inf")]], "bad_shape"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 10**30]], "bad_shape"),  # was an OverflowError
    ],
)
def test_bad_raw_input_raises_input_error(points, segments, code):
    with pytest.raises(InputError) as info:
        admissible_segments(points, segments)
    assert info.value.code == code


def test_restriction_keeps_the_domain_side_and_refuses_a_wrong_orientation():
    domain = parse_domain(L_SHAPE)
    res = admissible_segments(domain.points, domain.segments)
    inside = restricted_triangles(res.delaunay, res.segments)
    # The L's area is 4 + 3 = 7: the notch's triangles are left out.
    mesh = Mesh(res.points, (CellBlock("triangle", res.delaunay.triangles[inside]),))
    assert math.isclose(triangle_areas(mesh).sum(), 7.0, rel_tol=1e-12)
    with pytest.raises(InputError) as info:
        restricted_triangles(res.delaunay, res.segments[:, ::-1])
    assert info.value.code == "inconsistent_orientation"


def test_progress_is_reported_and_may_cancel():
    seen = []
    make_admissible(parse_domain(L_SHAPE), progress=lambda f, m: seen.append((f, m)))
    assert seen and all(0 <= f <= 1 for f, _ in seen)

    def stop(fraction, message):
        raise Cancelled("stop")

    with pytest.raises(Cancelled):
        make_admissible(parse_domain(polygon(star_ring())), progress=stop)


def test_pauses_of_the_splitting_loop_change_nothing(monkeypatch):
    # The compiled loop pauses for progress every TICK_POINTS added points
    # (and to grow its arrays, to protect vertices): resumed, it makes the
    # same points and pieces, and reports each pause.
    ring = star_ring(50, seed=2, r0=0.1)
    base = admissible_segments(ring, ring_segments(50))
    monkeypatch.setattr(admissible_mod, "TICK_POINTS", 3)
    seen = []
    res = admissible_segments(ring, ring_segments(50), progress=lambda f, m: seen.append(m))
    np.testing.assert_array_equal(res.points, base.points)
    np.testing.assert_array_equal(res.segments, base.segments)
    assert len(seen) == res.rounds >= base.added // 3


# ---------------------------------------------------------------------------
# Random star polygons with holes (hypothesis)
# ---------------------------------------------------------------------------


def _star(draw, count, centre, r_min, r_max):
    """A star-shaped ring: angular gaps from weights in [1, 2] (so no gap
    reaches pi), radii in [r_min, r_max]."""
    k = draw(count)
    weights = np.asarray(draw(st.lists(st.floats(1.0, 2.0), min_size=k, max_size=k)))
    angle = 2 * np.pi * np.cumsum(weights) / weights.sum()
    radius = np.asarray(draw(st.lists(st.floats(r_min, r_max), min_size=k, max_size=k)))
    return np.column_stack([centre + radius * np.cos(angle), radius * np.sin(angle)]).tolist()


@st.composite
def stars_with_holes(draw):
    """A star-shaped outer ring around the origin (8 to 40 vertices, radii in
    [0.5, 1]: its sides stay farther than 0.38 from the origin) and up to
    two star-shaped holes centred at (-0.15, 0) and (0.15, 0), radii up to
    0.12 (so they stay apart and inside)."""
    rings = [_star(draw, st.integers(8, 40), 0.0, 0.5, 1.0)]
    for centre in draw(st.sampled_from([[], [-0.15], [-0.15, 0.15]])):
        rings.append(_star(draw, st.integers(4, 12), centre, 0.03, 0.12))
    return {"type": "Polygon", "coordinates": rings}


@settings(max_examples=60, deadline=None)
@given(stars_with_holes())
def test_random_star_polygons_with_holes_become_admissible(geometry):
    domain = parse_domain(geometry)
    res = make_admissible(domain)
    check_domain(domain, res)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_reach_finds_the_nearest_segment_within_each_vertex_radius(seed):
    # The protection radii's search (_grid_reach): each vertex's reach is
    # lowered to its distance to the nearest segment not incident to it
    # wherever that is within its radius, with radii from tiny to one larger
    # than the whole set, and segments far longer than the cells.
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-1.5, 1.5, (660, 2))
    xy[300:600] = xy[:300] + rng.normal(0.0, 0.05, (300, 2)) * rng.choice([1.0, 30.0], (300, 1))
    a, b = np.arange(300), np.arange(300, 600)
    a[:20] = 600 + np.arange(20)  # segments incident to a vertex are left out
    verts = np.arange(600, 660)
    radius = 10.0 ** rng.uniform(-4.0, -0.5, 60)
    radius[0] = 5.0
    reach = radius * rng.uniform(0.5, 1.0, 60)
    got = _grid_reach(xy, a, b, np.arange(300), verts, reach, radius, 0.2)
    d = np.array([
        point_segment_distance(np.repeat(xy[v][None], 300, axis=0), xy[a], xy[b])[0]
        for v in verts
    ])  # fmt: skip
    d[a[None, :] == verts[:, None]] = np.inf
    want = np.minimum(reach, d.min(axis=1))
    assert (want < reach).sum() > 10 and np.array_equal(got, want)


# ---------------------------------------------------------------------------
# A vertex within float64 rounding of a segment (issue 19's bug)
# ---------------------------------------------------------------------------

#: Lattice polygons (coordinates / 20) valid in floating point (parse_domain
#: accepts them) where a vertex is on another segment in exact rationals and
#: off it by rounding: the spike at the segment's end is thinner than float64
#: resolves. The first is the example of the medial axis's ``TestAnyPolygon``
#: that raised AlgorithmError "the split point is an existing point"; the
#: second raised "too short for float64" (its split point landed one ulp from
#: the vertex, and the next projection rounded onto that point).
NEAR_TOUCHING = [
    ([[9, 6], [14, 7], [2, 2], [5, 10], [2, 13]], 4, 3),
    ([[15, 6], [0, 8], [7, 19], [11, 16], [17, 13], [9, 17], [20, 6], [11, 9], [2, 11]], 4, 3),
]


@pytest.mark.parametrize(("ring", "segment", "point"), NEAR_TOUCHING)
def test_a_point_within_rounding_of_a_segment_is_refused_with_its_location(ring, segment, point):
    P = np.array(ring, dtype=float) / 20
    assert orient2d(P[[segment]], P[[(segment + 1) % len(P)]], P[[point]])[0] != 0
    with pytest.raises(InputError) as info:
        admissible_segments(P, ring_segments(len(P)))
    assert info.value.code == "point_near_segment"
    assert [e["loc"] for e in info.value.errors] == [["segments", segment], ["points", point]]
    domain = parse_domain(polygon(P))
    # make_admissible and the triangulator (on its subsegments) locate it in the domain.
    for run in (make_admissible, triangulate):
        with pytest.raises(InputError) as info:
            run(domain)
        assert info.value.code == "point_near_segment"
        (_, seg_ring, seg_vertex), (_, ring_no, vertex) = (e["loc"] for e in info.value.errors)
        assert ring_no == seg_ring == 0 and ring[vertex] == ring[point]  # the vertex, as given
        assert ring[seg_vertex] in (ring[segment], ring[(segment + 1) % len(ring)])
        assert f"vertex {vertex} of ring 0" in info.value.message  # named as given
        assert f"point {point}" not in info.value.message


#: Lattice rings (coordinates / 20) whose boundary samples (h = 0.01) pass
#: within rounding of a vertex (on another side in exact rationals): the
#: splits on both sides met at one added point next to the vertex, which
#: raised AlgorithmError "the split point is an existing point" (found by
#: the medial axis's ``TestAnyPolygon``; now ``point_near_segment``).
NEAR_TOUCHING_SAMPLED = [
    [[1, 2], [2, 3], [3, 0], [19, 20]],
    [[10, 17], [0, 20], [19, 1], [20, 3], [17, 3]],
]


@pytest.mark.parametrize("ring", [NEAR_TOUCHING[0][0], *NEAR_TOUCHING_SAMPLED])
def test_the_medial_axis_refuses_the_near_touching_polygon_with_a_location(ring):
    from meshcore.medial import medial_axis

    geometry = {"type": "Polygon", "coordinates": [(np.array(ring) / 20).tolist()]}
    with pytest.raises(InputError) as info:
        medial_axis(parse_domain(geometry), h=0.01)
    assert info.value.errors[0]["loc"][0] == "coordinates"


#: Star polygons with holes on a lattice of step 0.05 (found by a fuzz of
#: this session): an input vertex within rounding of another segment's
#: added point (AlgorithmError "too short for float64" before), and, moved
#: by 1e6, an added point that rounds onto an input vertex back in the
#: input's frame (a "duplicate points" error on an added point before).
NEAR_TOUCHING_DOMAINS = [
    [
        [
            [0.65, 0.0],
            [0.7, 0.15],
            [0.55, 0.4],
            [0.6, 0.55],
            [0.65, 0.65],
            [0.3, 0.5],
            [0.15, 0.9],
            [0.15, 0.8],
            [0.1, 0.8],
            [-0.1, 0.85],
            [-0.3, 0.55],
            [-0.7, 0.25],
            [-0.65, 0.15],
            [-0.9, -0.1],
            [-0.85, -0.5],
            [-0.55, -0.35],
            [-0.65, -0.4],
            [-0.4, -0.35],
            [-0.45, -0.45],
            [-0.6, -0.55],
            [-0.1, -0.6],
            [0.05, -0.95],
            [0.0, -0.6],
            [0.2, -0.5],
            [0.55, -0.45],
            [0.85, -0.15],
            [0.6, -0.05],
            [0.6, -0.0],
        ],
        [[0.1, -0.4], [-0.3, 0.05], [-0.1, 0.25], [0.0, 0.2], [0.05, 0.1], [0.4, 0.0]],
    ],
    [
        [
            [1000000.75, 1000000.65],
            [1000000.7, 1000000.65],
            [1000000.3, 1000000.9],
            [1000000.25, 1000000.95],
            [999999.7, 1000000.75],
            [999999.35, 1000000.55],
            [999999.5, 1000000.25],
            [999999.45, 1000000.25],
            [999999.3, 1000000.25],
            [999999.45, 1000000.15],
            [999999.4, 999999.8],
            [999999.65, 999999.55],
            [999999.7, 999999.45],
            [1000000.25, 999999.5],
            [1000000.85, 999999.9],
        ],
        [
            [1000000.4, 999999.85],
            [1000000.05, 999999.85],
            [999999.95, 999999.75],
            [1000000.0, 999999.8],
            [999999.85, 1000000.0],
            [1000000.15, 1000000.3],
        ],
    ],
]


@pytest.mark.parametrize("rings", NEAR_TOUCHING_DOMAINS)
def test_domains_with_a_vertex_within_rounding_of_a_segment_are_refused_there(rings):
    domain = parse_domain({"type": "Polygon", "coordinates": rings})
    with pytest.raises(InputError) as info:
        make_admissible(domain)
    assert info.value.code == "point_near_segment"
    assert all(e["loc"][0] == "coordinates" for e in info.value.errors)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 20), st.integers(0, 20)), min_size=3, max_size=9, unique=True
    ),
    st.sampled_from([(0.0, 1.0), (1e6, 1.0), (0.0, 1e-6)]),
)
def test_lattice_polygons_are_admissible_or_refused_with_a_location(ring, move):
    # Small lattice polygons are full of vertices on other segments in exact
    # rationals: valid ones (in floating point) must become admissible or be
    # refused with a location in the domain, never an AlgorithmError.
    shift, scale = move
    coords = (np.array(ring, dtype=float) / 20 * scale + shift).tolist()
    try:
        domain = parse_domain({"type": "Polygon", "coordinates": [coords]})
    except InputError:
        return
    try:
        res = make_admissible(domain)
    except InputError as exc:
        assert exc.errors[0]["loc"][0] == "coordinates"
        return
    assert_delaunay_edges(res.points, res.segments)
