"""Facts about ``triangulate`` that a reader can check by hand.

Every mesh is checked by :func:`assert_conforming`, from the mesh alone:

* every triangle is counter-clockwise by the exact ``orient2d`` (so no
  triangle has zero or negative area);
* every input segment, boundary or constraint, is a chain of mesh edges:
  the mesh points lying on it, sorted along it, run from one endpoint to
  the other and each consecutive pair is a mesh edge (and the result's own
  ``segments`` list is that chain);
* the mesh's border edges (edges of one triangle) are exactly the pieces of
  the boundary rings: holes and the exterior are gone, nothing else is;
* the triangle areas add up to the domain's area.

Domains (sketches not to scale)::

    square with a hole   L-shape        comb, 5 degree spikes   grid
    +---------+          +---+          /\\  /\\  /\\  /\\  /\\     +--+--+--+
    |   ___   |          |   |         /  \\/  \\/  \\/  \\/  \\    |  |  |  |
    |  (   )  |          |   +---+     |________________|     +--+--+--+
    |   ---   |          |       |                            |  |  |  |
    +---------+          +-------+                            +--+--+--+
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import meshcore.triangulation.refinement as tri_mod
from meshcore.domain.planar import parse_domain
from meshcore.errors import AlgorithmError, Cancelled, InputError
from meshcore.geometry.predicates import orient2d
from meshcore.mesh.quality import triangle_angles
from meshcore.triangulation.refinement import triangulate

# ---------------------------------------------------------------------------
# Domains
# ---------------------------------------------------------------------------


def circle(cx, cy, r, angles):
    return np.column_stack([cx + r * np.cos(angles), cy + r * np.sin(angles)]).tolist()


def square_with_hole(n=48, uneven=True, seed=0):
    """Unit square minus a disk of radius 0.25, its circle sampled unevenly."""
    rng = np.random.default_rng(seed)
    th = np.sort(rng.uniform(0, 2 * np.pi, n)) if uneven else np.linspace(0, 2 * np.pi, n, False)
    return {
        "type": "Polygon",
        "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], circle(0.5, 0.5, 0.25, th)],
    }


def l_shape():
    return {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]]}


def star(n=50, seed=1):
    """A random star polygon: sorted angles, radii in [0.3, 1]."""
    rng = np.random.default_rng(seed)
    th = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.3, 1.0, n)
    return {
        "type": "Polygon",
        "coordinates": [np.column_stack([r * np.cos(th), r * np.sin(th)]).tolist()],
    }


def comb(k=5, angle=5.0):
    """A bar with k spikes whose apex angle is ``angle`` degrees."""
    w = 2 * math.tan(math.radians(angle / 2))
    pts = [[0.0, 0.0], [float(k), 0.0]]
    for i in range(k - 1, -1, -1):
        x = i + 0.5
        pts += [[i + 1.0, 0.3], [x + w / 2, 0.3], [x, 1.3], [x - w / 2, 0.3]]
    return {"type": "Polygon", "coordinates": [pts]}


def grid(n=6):
    """Unit square sampled on an n x n grid (every 4 neighbours co-circular),
    and its interior grid lines as constraint polylines."""
    xs = np.linspace(0, 1, n + 1).tolist()
    ring = (
        [[x, 0.0] for x in xs[:-1]]
        + [[1.0, y] for y in xs[:-1]]
        + [[x, 1.0] for x in xs[::-1][:-1]]
        + [[0.0, y] for y in xs[::-1][:-1]]
    )
    lines = [[[x, y] for y in xs] for x in xs[1:-1]] + [[[x, y] for x in xs] for y in xs[1:-1]]
    return {"type": "Polygon", "coordinates": [ring]}, lines


def moved(geometry, lines, f):
    g = copy.deepcopy(geometry)

    def walk(x):
        if isinstance(x[0], (int, float)):
            return f(np.asarray(x, float)).tolist()
        return [walk(y) for y in x]

    g["coordinates"] = walk(g["coordinates"])
    return g, (None if lines is None else [f(np.asarray(x, float)).tolist() for x in lines])


def shift(p):
    return p + 1e6


def shrink(p):
    return p * 1e-6


UNIT = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}
#: Two squares with holes, an island in the first hole, and a triangle apart.
MULTI = {
    "type": "MultiPolygon",
    "coordinates": [
        [[[0, 0], [1, 0], [1, 1], [0, 1]], [[0.3, 0.3], [0.3, 0.7], [0.7, 0.7], [0.7, 0.3]]],
        [[[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6]]],
        [[[2, 0], [3, 0], [2.5, 1]]],
    ],
}
#: A square with midpoints on its sides, constraints branching at its centre.
SPOKES = {
    "type": "Polygon",
    "coordinates": [[[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0.5, 1], [0, 1]]],
}

NAMED = {
    "square-with-hole": (square_with_hole(), None),
    "l-shape": (l_shape(), None),
    "star": (star(), None),
    "comb": (comb(), None),
    "grid-constraints": grid(),
    "grid-boundary": (grid()[0], None),
    "multipolygon-island": (MULTI, None),
    "dangling-constraint": (UNIT, [[[0.2, 0.2], [0.5, 0.5], [0.8, 0.3]]]),
    "constraint-loop": (UNIT, [[[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8], [0.2, 0.2]]]),
    "branching-constraints": (
        SPOKES,
        [[[0.5, 0.0], [0.5, 0.5], [0.5, 1.0]], [[0.5, 0.5], [1.0, 0.5]], [[0.5, 0.5], [0.1, 0.9]]],
    ),
    "sharp-constraint": (UNIT, [[[0.0, 0.0], [0.9, 0.01]]]),  # 0.64 degrees at the corner
}
MODES = {
    "default": {},
    "empty": {"empty": True},
    "empty-kept": {"empty": True, "keep_boundary": True},
    "min_angle": {"min_angle": 30},
    "kept": {"min_angle": 30, "keep_boundary": True},
    "size": {"min_angle": 25, "size": 0.1},
}

# ---------------------------------------------------------------------------
# Checks
# ---------------------------------------------------------------------------

#: Degrees: angles measured by acos of rounded coordinates (a 30-30-120
#: triangle made by an off-centre reads 29.9999999).
ANGLE_ROUNDING = 1e-6


def area_sum(points, triangles) -> float:
    c = points - points.min(axis=0)  # exact for nearby coordinates
    e1 = c[triangles[:, 1]] - c[triangles[:, 0]]
    e2 = c[triangles[:, 2]] - c[triangles[:, 0]]
    return math.fsum(0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]))


def edge_set(triangles) -> set[tuple[int, int]]:
    e = np.sort(
        np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1
    )
    return set(map(tuple, e.tolist()))


def border_edges(triangles) -> set[tuple[int, int]]:
    e = np.sort(
        np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1
    )
    u, c = np.unique(e, axis=0, return_counts=True)
    return set(map(tuple, u[c == 1].tolist()))


def points_on_segment(points, a, b, tol):
    """Indices of the points within tol of the closed segment ab, sorted along it."""
    d = b - a
    t = (points - a) @ d / (d @ d)
    foot = a + np.clip(t, 0, 1)[:, None] * d
    near = np.flatnonzero(np.hypot(*(points - foot).T) <= tol)
    return near[np.argsort(t[near])]


def assert_conforming(domain, res, area_rtol=1e-12):
    P = res.mesh.points
    T = res.mesh.cells[0].data
    assert res.mesh.cells[0].type == "triangle" and len(T) > 0
    assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) == 1).all()
    assert np.array_equal(np.unique(T), np.arange(len(P))), "every point is a vertex"
    n_in = len(domain.points)
    assert np.array_equal(P[:n_in], domain.points), "input points first, unchanged"
    edges = edge_set(T)
    seg_in = np.concatenate([domain.segments, domain.constraints])
    # rounding of new points on a segment: a few ulps of the coordinates
    tol = 8 * np.finfo(float).eps * np.abs(P).max() + 1e-12 * domain.diameter
    pieces = []
    for s, (i, j) in enumerate(seg_in):
        chain = points_on_segment(P, P[i], P[j], tol)
        assert chain[0] == i and chain[-1] == j, f"segment {s} ends"
        pairs = list(zip(chain[:-1].tolist(), chain[1:].tolist(), strict=True))
        for a, b in pairs:
            assert (min(a, b), max(a, b)) in edges, f"segment {s}: {a}-{b} is not an edge"
        rows = res.segments[res.segment_ids == s]
        assert rows.tolist() == [list(p) for p in pairs], f"segment {s}: reported chain"
        if s < len(domain.segments):
            pieces += [(min(a, b), max(a, b)) for a, b in pairs]
    assert border_edges(T) == set(pieces), "the border is the boundary rings, exactly"
    rel = abs(area_sum(P, T) - domain.area) / domain.area
    assert rel < area_rtol, rel


def small_input_angles(domain, bound) -> list[tuple[int, int, int]]:
    """(v, u, w) for segments vu and vw meeting at input vertex v at an angle
    under the bound: the interior angle between two ring segments, the
    plain angle when a constraint is one of them."""
    P = domain.points
    nb = len(domain.segments)
    seg = np.concatenate([domain.segments, domain.constraints])
    out = []
    for v in range(len(P)):
        rows = np.flatnonzero((seg == v).any(axis=1))
        for x in range(len(rows)):
            for y in range(x + 1, len(rows)):
                r1, r2 = rows[x], rows[y]
                u = seg[r1, 1] if seg[r1, 0] == v else seg[r1, 0]
                w = seg[r2, 1] if seg[r2, 0] == v else seg[r2, 0]
                a, b = P[u] - P[v], P[w] - P[v]
                if r1 < nb and r2 < nb:  # interior angle, from the outgoing to the incoming one
                    out_seg, in_seg = (r1, r2) if seg[r1, 0] == v else (r2, r1)
                    a = P[seg[in_seg, 0]] - P[v]
                    b = P[seg[out_seg, 1]] - P[v]
                    ang = math.degrees(math.atan2(b[0] * a[1] - b[1] * a[0], a @ b)) % 360
                else:
                    ang = math.degrees(math.atan2(abs(a[0] * b[1] - a[1] * b[0]), a @ b))
                if ang < bound:
                    out.append((v, int(u), int(w)))
    return out


def assert_min_angle_away_from_small_input_angles(domain, res, bound):
    """Each triangle with an angle under the bound (beyond rounding) has its
    three vertices on two segments meeting at an input vertex at an angle
    under the bound."""
    P = res.mesh.points
    T = res.mesh.cells[0].data
    small = small_input_angles(domain, bound)
    tol = 8 * np.finfo(float).eps * np.abs(P).max() + 1e-12 * domain.diameter
    P0 = domain.points

    def on(p, a, b):
        d = b - a
        t = np.clip((p - a) @ d / (d @ d), 0, 1)
        return np.hypot(*(a + t * d - p)) <= tol

    bad = np.flatnonzero(triangle_angles(P, T).min(axis=1) < bound - ANGLE_ROUNDING)
    for t in bad:
        assert any(
            all(on(P[x], P0[v], P0[u]) or on(P[x], P0[v], P0[w]) for x in T[t]) for v, u, w in small
        ), f"triangle {T[t].tolist()} under {bound} degrees away from small input angles"


def median_edge(res) -> float:
    P = res.mesh.points
    e = np.array(sorted(edge_set(res.mesh.cells[0].data)))
    return float(np.median(np.hypot(*(P[e[:, 1]] - P[e[:, 0]]).T)))


# ---------------------------------------------------------------------------
# Tests
# ---------------------------------------------------------------------------


class TestConformity:
    @pytest.mark.parametrize("mode", MODES)
    @pytest.mark.parametrize("name", NAMED)
    def test_named_domains(self, name, mode):
        geometry, lines = NAMED[name]
        domain = parse_domain(geometry, lines)
        assert_conforming(domain, triangulate(domain, **MODES[mode]))

    @pytest.mark.parametrize("f, scale", [(shift, 1.0), (shrink, 1e-6)], ids=["1e6", "1e-6"])
    @pytest.mark.parametrize("mode", ["min_angle", "kept", "size"])
    @pytest.mark.parametrize("name", NAMED)
    def test_translated_and_scaled(self, name, mode, f, scale):
        geometry, lines = moved(*NAMED[name], f)
        domain = parse_domain(geometry, lines)
        kw = dict(MODES[mode])
        if "size" in kw:
            kw["size"] *= scale
        res = triangulate(domain, **kw)
        # New points 1e6 from the origin sit within an ulp (1e-10) of their
        # segment, so the area is exact up to that rounding there.
        rtol = 1e-12 if f is shrink or mode == "kept" else 1e-9
        assert_conforming(domain, res, area_rtol=rtol)
        if mode == "min_angle":
            assert_min_angle_away_from_small_input_angles(domain, res, 30)

    @settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def test_random_polygons_with_holes(self, data):
        seed = data.draw(st.integers(0, 2**32 - 1))
        rng = np.random.default_rng(seed)
        n = data.draw(st.integers(10, 40))
        # star-shaped around the origin: radii in [0.55, 1], angular gaps under
        # 65 degrees, so every chord is 0.46 or more from the origin and holes
        # of radius under 0.12 around points at distance 0.3 are inside, apart
        th = np.sort((np.arange(n) + rng.uniform(-0.4, 0.4, n)) * 2 * np.pi / n)
        outer = (np.asarray(circle(0, 0, 1, th)) * rng.uniform(0.55, 1.0, (n, 1))).tolist()
        rings = [outer]
        for k in range(data.draw(st.integers(0, 3))):
            m = data.draw(st.integers(3, 10))
            # star-shaped around its centre, gaps under 180 degrees: simple
            ha = (np.arange(m) + rng.uniform(-0.2, 0.2, m)) * 2 * np.pi / m
            r = rng.uniform(0.03, 0.12, (m, 1))
            c = 0.3 * np.array([math.cos(2 * math.pi * k / 3), math.sin(2 * math.pi * k / 3)])
            rings.append((c + r * np.column_stack([np.cos(ha), np.sin(ha)])).tolist())
        domain = parse_domain({"type": "Polygon", "coordinates": rings})
        kw = data.draw(
            st.sampled_from(
                [
                    {"empty": True},
                    {"empty": True, "keep_boundary": True},
                    {"min_angle": 30},
                    {"min_angle": 28, "keep_boundary": True},
                    {"min_angle": 20, "size": 0.08},
                    {"min_angle": 30, "max_area": 0.01},
                ]
            )
        )
        res = triangulate(domain, **kw)
        assert_conforming(domain, res)
        if "min_angle" in kw and not kw.get("keep_boundary"):
            assert_min_angle_away_from_small_input_angles(domain, res, kw["min_angle"])


class TestQuality:
    @pytest.mark.parametrize("name", NAMED)
    def test_min_angle_30_away_from_small_input_angles(self, name):
        domain = parse_domain(*NAMED[name])
        res = triangulate(domain, min_angle=30)
        assert_min_angle_away_from_small_input_angles(domain, res, 30)

    def test_min_angle_30_on_a_domain_without_small_angles(self):
        domain = parse_domain(square_with_hole())
        res = triangulate(domain, min_angle=30)
        assert triangle_angles(res.mesh.points, res.mesh.cells[0].data).min() >= 30 - ANGLE_ROUNDING

    @pytest.mark.parametrize("bound", [32, 34])
    def test_angles_above_30_terminate(self, bound):
        # Beyond 30 degrees the guarantee is the Miller-Pav-Walkington one
        # (input angles under 60 may keep neighbours under the bound).
        domain = parse_domain(square_with_hole())
        res = triangulate(domain, min_angle=bound)
        angles = triangle_angles(res.mesh.points, res.mesh.cells[0].data)
        assert angles.min() >= bound - ANGLE_ROUNDING

    def test_comb_keeps_its_5_degree_spikes(self):
        domain = parse_domain(comb())
        res = triangulate(domain, min_angle=30)
        angles = triangle_angles(res.mesh.points, res.mesh.cells[0].data)
        assert angles.min() == pytest.approx(5.0, abs=0.05)  # the spike tips, untouched

    @pytest.mark.parametrize(
        "name, size",
        [
            ("square-with-hole", 0.1),
            ("square-with-hole", 0.03),
            ("l-shape", 0.1),
            ("comb", 0.05),
            ("star", 0.04),
            ("grid-constraints", 0.05),
        ],
    )
    def test_size_is_the_median_edge_length(self, name, size):
        # (the circle evenly sampled: the uneven one has features finer than 0.1)
        geometry, lines = NAMED[name]
        if name == "square-with-hole":
            geometry = square_with_hole(n=24, uneven=False)
        domain = parse_domain(geometry, lines)
        res = triangulate(domain, size=size, min_angle=30)
        assert median_edge(res) == pytest.approx(size, rel=0.2)

    def test_max_area_bounds_every_triangle(self):
        domain = parse_domain(square_with_hole())
        res = triangulate(domain, max_area=1e-3, min_angle=30)
        P, T = res.mesh.points, res.mesh.cells[0].data
        e1, e2 = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
        assert (0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])).max() <= 1e-3
        assert len(T) >= domain.area / 1e-3

    def test_size_field_is_followed(self):
        # h(x, y) = 0.02 + 0.08 x on the unit square, from its four corners
        domain = parse_domain(
            {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}
        )
        field = {"points": [[0, 0], [0, 1], [1, 0], [1, 1]], "values": [0.02, 0.02, 0.1, 0.1]}
        res = triangulate(domain, size_field=field, min_angle=30)
        assert_conforming(domain, res)
        P = res.mesh.points
        e = np.array(sorted(edge_set(res.mesh.cells[0].data)))
        length = np.hypot(*(P[e[:, 1]] - P[e[:, 0]]).T)
        x = P[e].mean(axis=1)[:, 0]
        for x0 in (0.1, 0.5, 0.9):
            band = np.abs(x - x0) < 0.05
            assert np.median(length[band]) == pytest.approx(0.02 + 0.08 * x0, rel=0.2)

    def test_size_field_with_kept_boundary_fills_the_interior(self):
        # the square's four long sides stay whole; inside, the field rules
        domain = parse_domain(UNIT)
        field = {"points": [[0, 0], [0, 1], [1, 0], [1, 1]], "values": [0.02, 0.02, 0.06, 0.06]}
        res = triangulate(domain, size_field=field, min_angle=30, keep_boundary=True)
        assert_conforming(domain, res)
        assert res.boundary_points_added == 0 and res.interior_points_added > 500
        P = res.mesh.points
        e = np.array(sorted(edge_set(res.mesh.cells[0].data)))
        length = np.hypot(*(P[e[:, 1]] - P[e[:, 0]]).T)
        mid = P[e].mean(axis=1)
        for x0 in (0.3, 0.7):
            band = (np.abs(mid[:, 0] - x0) < 0.05) & (np.abs(mid[:, 1] - 0.5) < 0.3)
            assert np.median(length[band]) == pytest.approx(0.02 + 0.04 * x0, rel=0.2)

    def test_two_constraints_1e5_apart(self):
        # 0.03 long (not 0.4): the same 1e-5 gap, growing to 1.075e-5; 51k
        # triangles instead of 421k.
        domain = parse_domain(
            UNIT, [[[0.3, 0.5], [0.33, 0.5]], [[0.3, 0.50001], [0.33, 0.50001075]]]
        )
        res = triangulate(domain, min_angle=30)
        assert_conforming(domain, res)
        angles = triangle_angles(res.mesh.points, res.mesh.cells[0].data)
        assert angles.min() >= 30 - ANGLE_ROUNDING

    def test_feature_cuts_leave_a_star_to_refinement(self):
        # cutting every boundary piece to 1.5 times its distance to the nearest
        # non-adjacent segment made 771 triangles here (402 without the cuts,
        # Triangle 309): only strips and near-touching features are cut now
        domain = parse_domain(star())
        res = triangulate(domain, min_angle=30)
        assert_conforming(domain, res)
        assert len(res.mesh.cells[0].data) <= 450

    def test_vertex_1e6_from_a_segment_graded_before_refinement(self):
        # the pieces near the vertex are halved towards it first: a few hundred
        # triangles (refinement alone made over a million)
        domain = parse_domain(
            {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0.5, 1e-6]]]}
        )
        res = triangulate(domain, min_angle=30)
        assert_conforming(domain, res)
        assert len(res.mesh.cells[0].data) <= 1000

    def test_thin_strip_cut_before_refinement(self):
        # the long sides are cut to 1.5 times the width before the triangulation
        # (features.feature_cuts): refinement has nothing to split (it took 10 rounds)
        w = 1e-4
        strip = [[[0, 0], [1, 0], [1, w], [0, w]]]
        domain = parse_domain({"type": "Polygon", "coordinates": strip})
        res = triangulate(domain, size=0.05, min_angle=30)
        assert_conforming(domain, res)
        angles = triangle_angles(res.mesh.points, res.mesh.cells[0].data)
        assert angles.min() >= 30 - ANGLE_ROUNDING
        assert res.rounds == 0 and res.interior_points_added == 0
        P = res.mesh.points
        e = res.boundary_segments
        assert np.hypot(*(P[e[:, 1]] - P[e[:, 0]]).T).max() <= 1.5 * w * (1 + 1e-9)

    def test_size_field_nearest_value_outside_its_points(self):
        # one field point: the same size everywhere, as `size`
        domain = parse_domain(l_shape())
        field = {"points": [[0.5, 0.5]], "values": [0.1]}
        res = triangulate(domain, size_field=field, min_angle=30)
        assert median_edge(res) == pytest.approx(0.1, rel=0.2)


class TestModes:
    @pytest.mark.parametrize("name", NAMED)
    def test_keep_boundary_adds_no_point_on_any_segment(self, name):
        domain = parse_domain(*NAMED[name])
        res = triangulate(domain, min_angle=30, size=0.1, keep_boundary=True)
        seg_in = np.concatenate([domain.segments, domain.constraints])
        assert res.boundary_points_added == 0
        assert np.array_equal(res.segments, seg_in)
        assert np.array_equal(res.segment_ids, np.arange(len(seg_in)))
        P = res.mesh.points
        new = P[len(domain.points) :]
        a, b = domain.points[seg_in[:, 0]], domain.points[seg_in[:, 1]]
        for i in range(len(seg_in)):
            on_line = orient2d(a[i], b[i], new) == 0
            lo, hi = np.minimum(a[i], b[i]), np.maximum(a[i], b[i])
            inside = ((new >= lo) & (new <= hi)).all(axis=1)
            assert not (on_line & inside).any()

    def test_keep_boundary_gives_up_rather_than_encroach(self):
        # a long side next to a fine lattice: triangles on it stay thin
        domain = parse_domain(square_with_hole(n=8, uneven=False))
        res = triangulate(domain, min_angle=30, size=0.05, keep_boundary=True)
        assert res.given_up > 0
        assert_conforming(domain, res)

    def test_empty_adds_only_boundary_points(self):
        domain = parse_domain(star())
        res = triangulate(domain, empty=True)
        P = res.mesh.points
        seg_in = np.concatenate([domain.segments, domain.constraints])
        assert res.interior_points_added == 0 and res.boundary_points_added > 0
        on_some = np.zeros(len(P), bool)
        for i, j in seg_in:
            on_some[points_on_segment(P, P[i], P[j], 1e-12)] = True
        assert on_some.all()

    def test_empty_kept_is_the_constrained_delaunay_of_the_input(self):
        domain = parse_domain(comb())
        res = triangulate(domain, empty=True, keep_boundary=True)
        assert np.array_equal(res.mesh.points, domain.points)
        # n points, a simple polygon: n - 2 triangles
        assert len(res.mesh.cells[0].data) == len(domain.points) - 2

    def test_curve_points_go_on_the_circle(self):
        th = np.linspace(0, 2 * np.pi, 12, endpoint=False)
        domain = parse_domain(
            {
                "type": "Polygon",
                "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], circle(0.5, 0.5, 0.25, th)],
            }
        )
        curves = [{"ring": 1, "type": "circle", "center": [0.5, 0.5], "radius": 0.25}]
        res = triangulate(domain, curves=curves, size=0.03, min_angle=30)
        P = res.mesh.points
        hole = res.segments[res.segment_ids >= 4].ravel()
        r = np.hypot(P[hole, 0] - 0.5, P[hole, 1] - 0.5)
        assert len(np.unique(hole)) > 12
        assert np.abs(r - 0.25).max() < 1e-12

    def test_output_is_deterministic(self):
        domain = parse_domain(*NAMED["grid-constraints"])
        a = triangulate(domain, min_angle=30, size=0.07)
        b = triangulate(domain, min_angle=30, size=0.07)
        assert np.array_equal(a.mesh.points, b.mesh.points)
        assert np.array_equal(a.mesh.cells[0].data, b.mesh.cells[0].data)

    def test_counts_and_rounds(self):
        domain = parse_domain(square_with_hole())
        res = triangulate(domain, min_angle=30, size=0.05)
        n = len(res.mesh.points)
        assert n == len(domain.points) + res.boundary_points_added + res.interior_points_added
        assert res.boundary_points_added > 0 and res.interior_points_added > 0
        assert res.rounds >= 1
        assert set(res.timings) >= {"delaunay", "refine"}

    def test_accepts_a_geojson_mapping(self):
        res = triangulate(l_shape(), min_angle=30)
        assert_conforming(parse_domain(l_shape()), res)


class TestErrors:
    @pytest.mark.parametrize(
        "kw, loc",
        [
            ({"min_angle": 0}, ["min_angle"]),
            ({"min_angle": 35}, ["min_angle"]),
            ({"min_angle": float("nan")}, ["min_angle"]),
            ({"max_area": -1}, ["max_area"]),
            ({"size": 0}, ["size"]),
            ({"size": "big"}, ["size"]),
            ({"size": 1e-300}, ["size"]),  # more points than the estimates count
            ({"max_area": 1e-300}, ["max_area"]),
            ({"empty": True, "size": 0.1}, ["size"]),
            ({"empty": True, "min_angle": 20}, ["min_angle"]),
            ({"size_field": {"points": [[0, 0]], "values": [1, 2]}}, ["size_field", "values"]),
            ({"size_field": {"points": [[0, 0]], "values": [0]}}, ["size_field", "values", 0]),
            (
                {"size_field": {"points": [[0, 0], [0, 0]], "values": [1, 1]}},
                ["size_field", "points", 1],
            ),
            # distances between them overflow: was an IndexError (no nearest point)
            (
                {"size_field": {"points": [[1e308, 1e308], [-1e308, 0]], "values": [1, 1]}},
                ["size_field", "points", 0],
            ),
            # an integer beyond float64 (as JSON may carry): was an OverflowError
            ({"size_field": {"points": [[0, 0]], "values": [10**400]}}, ["size_field"]),
            (
                {"curves": [{"ring": 3, "type": "circle", "center": [0, 0], "radius": 1}]},
                ["curves", 0, "ring"],
            ),
            # not containers at all: were a TypeError from unpacking or iterating them
            ({"size_field": 5}, ["size_field"]),
            ({"curves": 5}, ["curves"]),
        ],
    )
    def test_bad_parameters_name_the_argument(self, kw, loc):
        with pytest.raises(InputError) as err:
            triangulate(parse_domain(l_shape()), **kw)
        assert err.value.errors[0]["loc"] == loc

    def test_progress_may_cancel(self):
        def stop(fraction, message):
            if fraction > 0.5:
                raise Cancelled("stop")

        with pytest.raises(Cancelled):
            triangulate(parse_domain(l_shape()), size=0.05, progress=stop)

    def test_runaway_refinement_is_an_algorithm_error(self, monkeypatch):
        monkeypatch.setattr(tri_mod, "MAX_POINTS", 200)
        with pytest.raises(AlgorithmError, match="200 points"):
            triangulate(parse_domain(l_shape()), size=0.01)

    def test_estimated_triangles(self):
        domain = parse_domain(l_shape())  # area 3, perimeter 8
        thin = 0.25 * 8**2 / 3  # the points the angle bound forces in thin parts
        by_size = tri_mod.estimated_triangles(domain, size=0.1)
        assert by_size.triangles == pytest.approx(
            2 * (3 / (math.sqrt(3) / 2 * 0.01) + thin), rel=0.01
        )
        assert by_size.binding == "size"
        assert tri_mod.estimated_triangles(domain) == (2 * int(thin), None)
        # several sizes: the count of them together, the binding one named (ties: the first
        # of size, max_area, size_field)
        both = tri_mod.estimated_triangles(domain, size=0.1, max_area=1e-4)
        assert both.triangles > by_size.triangles and both.binding == "max_area"
        assert tri_mod.estimated_triangles(domain, size=0.01, max_area=1e-4).binding == "size"
        field = {"points": [[0.5, 0.5]], "values": [0.1]}
        assert tri_mod.estimated_triangles(domain, size=0.1, size_field=field) == by_size
        fine = tri_mod.estimated_triangles(domain, size=0.1, size_field={**field, "values": [0.05]})
        assert fine.binding == "size_field" and fine.triangles > by_size.triangles
