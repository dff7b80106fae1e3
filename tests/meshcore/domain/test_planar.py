"""The 2D domain input: what parse_domain accepts, normalizes and rejects.

Hand-made domains state facts a reader can check on paper (the bow-tie's
segments cross at (1, 1), a 4 x 4 square with a 2 x 2 hole has area 12);
hypothesis draws star-shaped polygons with holes (valid by construction),
polygons with a vertex moved across an edge (invalid by construction) and
small random integer polygons judged by a brute-force exact test.

    (0,4) +-----------+ (4,4)     SQUARE, HOLE below: the outer ring
          |  +-----+  |               (0,0) (4,0) (4,4) (0,4) and the hole
          |  |     |  |               (1,1) (3,1) (3,3) (1,3); the domain
          |  +-----+  |               between them has area 16 - 4 = 12.
    (0,0) +-----------+ (4,0)
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import Domain, parse_domain, parse_size_field
from meshcore.errors import InputError

SQUARE = [[0, 0], [4, 0], [4, 4], [0, 4]]
HOLE = [[1, 1], [3, 1], [3, 3], [1, 3]]


def polygon(*rings):
    return {"type": "Polygon", "coordinates": [list(r) for r in rings]}


def multipolygon(*polys):
    return {"type": "MultiPolygon", "coordinates": [[list(r) for r in p] for p in polys]}


def rejected(geometry, segments=None) -> InputError:
    with pytest.raises(InputError) as info:
        parse_domain(geometry, segments)
    return info.value


def signed_area(points, segments) -> float:
    """Shoelace over oriented segments: positive iff the domain is on their left."""
    a = points[segments[:, 0]]
    b = points[segments[:, 1]]
    return 0.5 * float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))


# ---------------------------------------------------------------------------
# Accepted domains: layout, orientation, area
# ---------------------------------------------------------------------------


class TestAccepted:
    def test_square_with_hole_area_and_layout(self):
        d = parse_domain(polygon(SQUARE, HOLE))
        assert d.area == 12.0
        assert d.diameter == math.hypot(4, 4)
        assert d.points.shape == (8, 2) and d.points.dtype == np.float64
        assert d.ring_offsets.tolist() == [0, 4, 8]
        assert d.ring_is_hole.tolist() == [False, True]
        assert d.ring_polygon.tolist() == [0, 0]
        assert d.segments.dtype == np.int64 and d.segments.shape == (8, 2)
        assert d.constraints.shape == (0, 2)
        assert d.segment_ring.tolist() == [0] * 4 + [1] * 4

    def test_orientation_is_normalized(self):
        # Input: clockwise outer ring, counter-clockwise hole; both get reversed.
        d = parse_domain(polygon(SQUARE[::-1], HOLE))
        assert d.ring_reversed.tolist() == [True, True]
        outer = d.segments[:4]
        hole = d.segments[4:]
        assert signed_area(d.points, outer) == 16.0  # counter-clockwise
        assert signed_area(d.points, hole) == -4.0  # clockwise
        assert d.area == 12.0
        # Points keep the input order; segment v still joins input vertices v and v+1.
        assert d.points[:4].tolist() == SQUARE[::-1]
        assert sorted(d.segments[0].tolist()) == [0, 1]

    def test_counter_clockwise_outer_kept(self):
        d = parse_domain(polygon(SQUARE, HOLE[::-1]))
        assert d.ring_reversed.tolist() == [False, False]
        assert d.segments[:4].tolist() == [[0, 1], [1, 2], [2, 3], [3, 0]]

    def test_closed_and_open_rings_give_the_same_domain(self):
        closed = parse_domain(polygon(SQUARE + [SQUARE[0]], HOLE + [HOLE[0]]))
        open_ = parse_domain(polygon(SQUARE, HOLE))
        assert closed == open_
        assert closed.points.shape == (8, 2)

    def test_numpy_input_equals_list_input(self):
        ring = np.array(SQUARE, dtype=float)
        d = parse_domain({"type": "Polygon", "coordinates": [ring]})
        assert d == parse_domain(polygon(SQUARE))
        assert d.diameter == parse_domain(polygon(SQUARE)).diameter
        # A writable array is copied (in the checking pass), a read-only one is used as is.
        assert not np.shares_memory(d.points, ring)
        ring[0, 0] = -1.0
        assert d.points[0, 0] == SQUARE[0][0]
        ring.setflags(write=False)
        frozen = parse_domain({"type": "Polygon", "coordinates": [ring]})
        assert np.shares_memory(frozen.points, ring)

    def test_multipolygon_ring_numbering(self):
        # polygon 0: square with hole; polygon 1: a triangle beside it; polygon 2:
        # an island inside polygon 0's hole.
        island = [[1.5, 1.5], [2.5, 1.5], [2, 2.5]]
        tri = [[5, 0], [7, 0], [6, 2]]
        d = parse_domain(multipolygon([SQUARE, HOLE], [tri], [island]))
        assert d.multi
        assert d.ring_offsets.tolist() == [0, 4, 8, 11, 14]
        assert d.ring_polygon.tolist() == [0, 0, 1, 2]
        assert d.ring_is_hole.tolist() == [False, True, False, False]
        assert d.area == 16 - 4 + 2 + 0.5
        assert d.ring_name(1) == "polygon 0, ring 1"
        assert d.vertex_loc(9) == ("coordinates", 1, 0, 1)
        assert d.vertex_name(12) == "vertex 1 of polygon 2, ring 0"

    def test_collinear_boundary_samples_are_allowed(self):
        # A 2 x 1 rectangle sampled with 100 points per side: long collinear runs.
        t = np.arange(100) / 100
        ring = np.concatenate(
            [
                np.stack([2 * t, 0 * t], 1),
                np.stack([2 + 0 * t, t], 1),
                np.stack([2 - 2 * t, 1 + 0 * t], 1),
                np.stack([0 * t, 1 - t], 1),
            ]
        )
        d = parse_domain(polygon(ring.tolist()))
        assert d.area == 2.0
        assert len(d.segments) == 400

    def test_circle_area_is_the_inscribed_polygon(self):
        n = 20000
        th = 2 * np.pi * np.arange(n) / n
        d = parse_domain(polygon(np.stack([np.cos(th), np.sin(th)], 1)))
        assert d.area == pytest.approx(0.5 * n * math.sin(2 * math.pi / n), rel=1e-14)

    def test_area_is_exact_far_from_the_origin(self):
        shifted = [[x + 1e6, y - 3e6] for x, y in SQUARE]
        hole = [[x + 1e6, y - 3e6] for x, y in HOLE]
        assert parse_domain(polygon(shifted, hole)).area == 12.0

    def test_as_geojson_is_normalized(self):
        d = parse_domain(polygon(SQUARE[::-1], HOLE))
        g = d.as_geojson()
        closed = [[float(x), float(y)] for x, y in SQUARE + SQUARE[:1]]
        assert g == {
            "type": "Polygon",
            "coordinates": [closed, [[float(x), float(y)] for x, y in HOLE[::-1] + HOLE[-1:]]],
        }
        again = parse_domain(g)
        assert again.ring_reversed.tolist() == [False, False]
        assert again.area == d.area

    def test_extra_geojson_members_are_ignored(self):
        g = {**polygon(SQUARE), "bbox": [0, 0, 4, 4]}
        assert parse_domain(g).area == 16.0

    def test_domain_is_immutable(self):
        d = parse_domain(polygon(SQUARE))
        with pytest.raises(ValueError):
            d.points[0, 0] = 7.0
        with pytest.raises(AttributeError):
            d.area = 1.0  # type: ignore[misc]


# ---------------------------------------------------------------------------
# Constraints
# ---------------------------------------------------------------------------


class TestConstraints:
    def test_interior_polyline(self):
        d = parse_domain(polygon(SQUARE, HOLE), [[[0.5, 0.5], [0.5, 3.5], [3.5, 3.5]]])
        assert d.points.shape == (11, 2)
        assert d.constraints.tolist() == [[8, 9], [9, 10]]
        assert d.constraint_source.tolist() == [[0, 0], [0, 1]]
        assert d.vertex_loc(10) == ("segments", 0, 2)
        assert d.area == 12.0

    def test_interface_between_ring_vertices_shares_their_indices(self):
        # From the outer ring's vertex (0, 0) to the hole's vertex (1, 1).
        d = parse_domain(polygon(SQUARE, HOLE), [[[0, 0], [1, 1]]])
        assert d.points.shape == (8, 2)
        assert d.constraints.tolist() == [[0, 4]]

    def test_polylines_meeting_at_a_vertex_and_a_closed_loop(self):
        lines = [
            [[0.5, 0.5], [2, 0.5]],
            [[2, 0.5], [3.5, 0.5], [3.5, 0.9], [2, 0.5]],  # branches and closes
        ]
        d = parse_domain(polygon(SQUARE, HOLE), lines)
        assert d.points.shape == (8 + 4, 2)
        assert d.constraints.tolist() == [[8, 9], [9, 10], [10, 11], [11, 9]]

    def test_crossing_constraints(self):
        e = rejected(polygon(SQUARE), [[[1, 1], [3, 3]], [[1, 3], [3, 1]]])
        assert e.code == "constraint_intersection"
        assert "constraint 0 and constraint 1" in e.message
        assert "(2.0, 2.0)" in e.message
        assert e.errors[0]["loc"] == ["segments", 0, 0]

    def test_constraint_vertex_on_a_boundary_segment(self):
        e = rejected(polygon(SQUARE), [[[2, 0], [2, 2]]])
        assert e.code == "constraint_intersection"
        assert "touch at (2.0, 0.0)" in e.message
        assert e.errors[0]["loc"] == ["segments", 0, 0]

    def test_constraint_crossing_the_boundary(self):
        e = rejected(polygon(SQUARE), [[[2, 2], [6, 3]]])
        assert e.code == "constraint_intersection"
        assert "cross at (4.0, 2.5)" in e.message

    def test_duplicate_constraint_segment(self):
        e = rejected(polygon(SQUARE), [[[1, 1], [2, 2]], [[2, 2], [1, 1]]])
        assert e.code == "constraint_intersection"
        assert "overlap" in e.message

    def test_constraint_on_a_boundary_segment(self):
        e = rejected(polygon(SQUARE), [[[0, 0], [4, 0]]])
        assert e.code == "constraint_intersection"

    def test_constraint_outside(self):
        e = rejected(polygon(SQUARE), [[[5, 5], [6, 6]]])
        assert e.code == "constraint_outside"
        assert e.errors[0]["loc"] == ["segments", 0, 0]

    def test_constraint_in_a_hole(self):
        e = rejected(polygon(SQUARE, HOLE), [[[1.5, 1.5], [2.5, 2.5]]])
        assert e.code == "constraint_outside"

    def test_chord_outside_a_notch(self):
        # The chord joins two ring vertices across the notch (outside the domain).
        notch = [[0, 0], [4, 0], [4, 4], [2, 1], [0, 4]]
        e = rejected(polygon(notch), [[[0, 4], [4, 4]]])
        assert e.code == "constraint_outside"
        assert parse_domain(polygon(notch), [[[0, 0], [2, 1]]]).constraints.tolist() == [[0, 3]]

    def test_short_and_repeated_polylines(self):
        assert rejected(polygon(SQUARE), [[[1, 1]]]).code == "too_few_points"
        e = rejected(polygon(SQUARE), [[[1, 1], [2, 2], [2, 2]]])
        assert e.code == "duplicate_point"
        assert e.errors[0]["loc"] == ["segments", 0, 2]
        e = rejected(polygon(SQUARE), [[[1, 1], [2, float("inf")]]])
        assert e.code == "non_finite"
        assert e.errors[0]["loc"] == ["segments", 0, 1, 1]


# ---------------------------------------------------------------------------
# Rejections, hand-made
# ---------------------------------------------------------------------------


class TestRejected:
    def test_bow_tie_names_both_segments_and_the_crossing(self):
        e = rejected(polygon([[0, 0], [2, 2], [2, 0], [0, 2]]))
        assert e.code == "self_intersection"
        assert "ring 0 intersects itself" in e.message
        assert "[ring 0: vertex 0 -> 1]" in e.message
        assert "[ring 0: vertex 2 -> 3]" in e.message
        assert "cross at (1.0, 1.0)" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 0, 0]
        assert e.errors[0]["type"] == "self_intersection"

    def test_hole_outside(self):
        e = rejected(polygon(SQUARE, [[5, 5], [6, 5], [6, 6]]))
        assert e.code == "hole_outside"
        assert "ring 1" in e.message and "ring 0" in e.message and "vertex 0" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 1, 0]

    def test_hole_inside_a_hole(self):
        e = rejected(polygon(SQUARE, HOLE, [[1.5, 1.5], [2, 1.5], [2, 2]]))
        assert e.code == "hole_outside"
        assert "inside another hole" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 2, 0]

    def test_outer_ring_inside_its_hole(self):
        e = rejected(polygon(HOLE, SQUARE))
        assert e.code == "hole_outside"

    def test_nan(self):
        e = rejected(polygon([[0, 0], [1, float("nan")], [1, 1]]))
        assert e.code == "non_finite"
        assert "vertex 1" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 0, 1, 1]

    def test_out_of_range(self):
        e = rejected(polygon([[0, 0], [1e200, 0], [1, 1]]))
        assert e.code == "out_of_range"
        assert e.errors[0]["loc"] == ["coordinates", 0, 1, 0]

    def test_two_points(self):
        e = rejected(polygon([[0, 0], [1, 1]]))
        assert e.code == "too_few_points"
        assert "ring 0 has 2 distinct" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 0]

    def test_two_distinct_points_alternating(self):
        e = rejected(polygon([[0, 0], [1, 1], [0, 0], [1, 1]]))
        assert e.code == "too_few_points"

    def test_closed_two_point_ring(self):
        assert rejected(polygon([[0, 0], [1, 1], [0, 0]])).code == "too_few_points"

    def test_duplicate_consecutive_vertices(self):
        e = rejected(polygon(SQUARE, [[1, 1], [3, 1], [3, 1], [3, 3]]))
        assert e.code == "duplicate_point"
        assert "ring 1: vertex 2 repeats vertex 1 at (3.0, 1.0)" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 1, 2]

    def test_doubled_closing_point(self):
        e = rejected(polygon(SQUARE + [[0, 0], [0, 0]]))
        assert e.code == "duplicate_point"
        assert e.errors[0]["loc"] == ["coordinates", 0, 5]

    def test_zero_area(self):
        e = rejected(polygon([[0, 0], [1, 1], [3, 3]]))
        assert e.code == "zero_area"

    def test_spike_doubling_back(self):
        e = rejected(polygon([[0, 0], [4, 0], [4, 4], [4, 6], [4, 5], [0, 4]]))
        assert e.code == "self_intersection"

    def test_vertex_on_a_segment(self):
        e = rejected(polygon([[0, 0], [4, 0], [4, 4], [2, 0], [0, 4]]))
        assert e.code == "self_intersection"
        assert "touch at (2.0, 0.0)" in e.message

    def test_ring_touching_itself_at_a_vertex(self):
        # Vertex 2 and vertex 5 are the same point (2, 2): two lobes pinched together.
        e = rejected(polygon([[0, 0], [4, 0], [2, 2], [4, 4], [0, 4], [2, 2]]))
        assert e.code == "self_intersection"
        assert "touch at (2.0, 2.0)" in e.message

    def test_hole_touching_the_outer_ring(self):
        e = rejected(polygon(SQUARE, [[0, 0], [1, 1], [1, 2]]))
        assert e.code == "ring_intersection"
        assert "ring 0 and ring 1 intersect" in e.message
        assert "(0.0, 0.0)" in e.message

    def test_hole_touching_another_hole_on_a_segment(self):
        e = rejected(polygon(SQUARE, [[1, 1], [2, 1], [2, 2]], [[2, 1.5], [3, 1], [3, 2]]))
        assert e.code == "ring_intersection"
        assert "(2.0, 1.5)" in e.message

    def test_crossing_rings(self):
        e = rejected(polygon(SQUARE, [[3, 1], [5, 1], [5, 2], [3, 2]]))
        assert e.code == "ring_intersection"
        assert "cross at (4.0, 1.0)" in e.message or "cross at (4.0, 2.0)" in e.message

    def test_overlapping_multipolygon_parts(self):
        # Boundaries crossing.
        e = rejected(multipolygon([SQUARE], [[[2, 2], [6, 2], [6, 6], [2, 6]]]))
        assert e.code == "ring_intersection"
        assert "polygon 0, ring 0 and polygon 1, ring 0" in e.message
        assert e.errors[0]["loc"] == ["coordinates", 0, 0, 1]
        # One part inside the other.
        e = rejected(multipolygon([SQUARE], [HOLE]))
        assert e.code == "polygon_overlap"
        assert e.errors[0]["loc"] == ["coordinates", 1, 0, 0]
        # The same, listed the other way round.
        assert rejected(multipolygon([HOLE], [SQUARE])).code == "polygon_overlap"
        # Parts sharing only a corner still touch.
        e = rejected(multipolygon([SQUARE], [[[4, 4], [5, 4], [5, 5]]]))
        assert e.code == "ring_intersection"

    def test_island_in_a_hole_is_not_an_overlap(self):
        d = parse_domain(multipolygon([SQUARE, HOLE], [[[1.5, 1.5], [2.5, 1.5], [2, 2.5]]]))
        assert d.area == 12.5

    @pytest.mark.parametrize(
        ("geometry", "loc"),
        [
            ([1, 2], []),
            ({"type": "LineString", "coordinates": []}, ["type"]),
            ({"type": "Polygon"}, ["coordinates"]),
            ({"type": "Polygon", "coordinates": []}, ["coordinates"]),
            ({"type": "Polygon", "coordinates": [[[0, 0, 0], [1, 0, 0], [1, 1, 0]]]}, None),
            ({"type": "Polygon", "coordinates": [[[0, 0], [1, "a"], [1, 1]]]}, None),
            ({"type": "Polygon", "coordinates": [[[0, 0], [1], [1, 1]]]}, None),
            # numpy would read these as [1.0, 1.0] and [1, 0]: refused as the schema does
            (polygon([[0, 0.5], [1, True], [1, 1]]), ["coordinates", 0, 1, 1]),
            (polygon([[0, 0], [False, 2], [1, 1]]), ["coordinates", 0, 1, 0]),
            ({"type": "MultiPolygon", "coordinates": [[]]}, ["coordinates", 0]),
            ({"type": "MultiPolygon", "coordinates": [SQUARE]}, None),
        ],
    )
    def test_malformed_geometry(self, geometry, loc):
        e = rejected(geometry)
        assert e.code == "bad_geometry"
        if loc is not None:
            assert e.errors[0]["loc"] == loc

    def test_boolean_constraint_coordinate(self):
        e = rejected(polygon(SQUARE), [[[0.2, 0.2], [0.5, np.True_]]])
        assert e.code == "bad_geometry" and e.errors[0]["loc"] == ["segments", 0, 1, 1]

    def test_huge_integer_is_not_finite(self):
        e = rejected(polygon([[0, 0], [10**400, 0], [1, 1]]))
        assert e.code == "non_finite"
        assert e.errors[0]["loc"] == ["coordinates", 0, 1, 0]

    def test_errors_list_every_pair_up_to_ten(self):
        # A zigzag crossing a long edge many times.
        zig = [[i, 1 if i % 2 else -1] for i in range(30)] + [[29, 5], [0, 5]]
        ring = zig + [[-1, 0], [30, 0], [30, 6], [-2, 6], [-2, 0.5]]
        e = rejected(polygon(ring))
        assert e.code == "self_intersection"
        assert len(e.errors) == 10
        assert "more intersecting pairs" in e.message

    def test_long_edge_crossing_a_dense_arc(self):
        # A half circle sampled with 5000 points, closed through (0.5, 3): the long
        # edge from (-1, 0) to (0.5, 3) enters the disk and leaves through the arc.
        th = np.linspace(0, np.pi, 5000)
        arc = np.stack([np.cos(th), np.sin(th)], 1).tolist()
        e = rejected(polygon(arc + [[0.5, 3.0]]))
        assert e.code == "self_intersection"
        assert "vertex 4999 -> 5000" in e.message or "vertex 5000 -> 0" in e.message
        # Closed below the diameter instead: valid.
        d = parse_domain(polygon(arc + [[0.0, -1.0]]))
        assert d.area > 0


# ---------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------


def shoelace2(ring) -> int:
    """Twice the signed area of an integer ring, exactly (Python ints)."""
    n = len(ring)
    return sum(
        ring[i][0] * ring[(i + 1) % n][1] - ring[(i + 1) % n][0] * ring[i][1] for i in range(n)
    )


@st.composite
def star_ring(draw, n_dirs: int, rmin: int, rmax: int, center=(0, 0)):
    """Integer vertices at increasing angles around ``center``, every gap <= 90 degrees.

    Directions are multiples of 2 pi / n_dirs, the four axis directions always
    among them; radii are at least ``rmin``, large enough that rounding to
    integers keeps the angular order. Such a polygon is simple, star-shaped
    about its centre, and contains the disk of radius ``rmin * cos(45°) - 1``.
    """
    quarter = n_dirs // 4
    extra = draw(st.sets(st.integers(0, n_dirs - 1), max_size=n_dirs // 2))
    dirs = sorted(extra | {0, quarter, 2 * quarter, 3 * quarter})
    radii = draw(st.lists(st.integers(rmin, rmax), min_size=len(dirs), max_size=len(dirs)))
    return [
        [
            center[0] + round(r * math.cos(2 * math.pi * k / n_dirs)),
            center[1] + round(r * math.sin(2 * math.pi * k / n_dirs)),
        ]
        for k, r in zip(dirs, radii, strict=True)
    ]


HOLE_CENTERS = [(0, 0), (35, 0), (-35, 0), (0, 35), (0, -35)]


@st.composite
def star_domain(draw):
    """A star polygon (radii 100..1000) with up to 5 disjoint star holes inside."""
    outer = draw(star_ring(64, 100, 1000))
    centers = draw(st.sets(st.sampled_from(HOLE_CENTERS), max_size=5))
    holes = [draw(star_ring(16, 8, 12, c)) for c in sorted(centers)]
    rings = [outer, *holes]
    flips = draw(st.lists(st.booleans(), min_size=len(rings), max_size=len(rings)))
    closes = draw(st.lists(st.booleans(), min_size=len(rings), max_size=len(rings)))
    given_rings = []
    for ring, flip, close in zip(rings, flips, closes, strict=True):
        r = ring[::-1] if flip else list(ring)
        given_rings.append(r + [r[0]] if close else r)
    area2 = abs(shoelace2(outer)) - sum(abs(shoelace2(h)) for h in holes)
    return polygon(*given_rings), area2


@st.composite
def crossing_ring(draw):
    """A star polygon with vertex a + 1 moved so that edge a crosses edge b at its midpoint.

    The new vertex is v_b + v_{b+1} - v_a: the edge from v_a to it passes
    through the midpoint of edge b and ends on the other side.
    """
    ring = draw(star_ring(64, 100, 1000))
    n = len(ring)
    a = draw(st.integers(0, n - 1))
    b = draw(st.integers(0, n - 1))
    assume((b - a) % n not in (n - 1, 0, 1))
    va, vb, vb1 = ring[a], ring[b], ring[(b + 1) % n]
    assume((vb1[0] - vb[0]) * (va[1] - vb[1]) - (vb1[1] - vb[1]) * (va[0] - vb[0]) != 0)
    moved = [vb[0] + vb1[0] - va[0], vb[1] + vb1[1] - va[1]]
    assume(moved not in ring)
    ring = list(ring)
    ring[(a + 1) % n] = moved
    return ring


def outcome(geometry):
    """("ok", area) or (code, first loc): what a client would see."""
    try:
        return ("ok", parse_domain(geometry).area)
    except InputError as e:
        return (e.code, e.errors[0]["loc"])


def transformed(geometry, f):
    def ring(r):
        return [list(f(x, y)) for x, y in r]

    return {"type": "Polygon", "coordinates": [ring(r) for r in geometry["coordinates"]]}


PROPS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class TestProperties:
    @PROPS
    @given(star_domain())
    def test_star_polygons_with_holes_are_valid_with_the_shoelace_area(self, drawn):
        geometry, area2 = drawn
        d = parse_domain(geometry)
        assert d.area == area2 / 2
        assert d.ring_reversed.shape == (len(geometry["coordinates"]),)
        # Oriented segments: outer counter-clockwise, holes clockwise.
        for k in range(d.ring_count):
            lo, hi = d.ring_offsets[k], d.ring_offsets[k + 1]
            a = signed_area(d.points, d.segments[lo:hi])
            assert (a < 0) == bool(d.ring_is_hole[k])

    @PROPS
    @given(crossing_ring())
    def test_a_vertex_moved_across_an_edge_is_a_self_intersection(self, ring):
        e = rejected(polygon(ring))
        assert e.code == "self_intersection"
        assert "ring 0 intersects itself" in e.message

    @PROPS
    @given(st.one_of(star_domain().map(lambda d: d[0]), crossing_ring().map(polygon)))
    def test_translation_and_power_of_two_scaling_change_nothing(self, geometry):
        base = outcome(geometry)
        moved = outcome(transformed(geometry, lambda x, y: (x + 1e6, y - 1e6)))
        assert moved == base
        small = outcome(transformed(geometry, lambda x, y: (x * 2.0**-20, y * 2.0**-20)))
        if base[0] == "ok":
            assert small == ("ok", base[1] * 2.0**-40)
        else:
            assert small == base

    @PROPS
    @given(st.one_of(star_domain().map(lambda d: d[0]), crossing_ring().map(polygon)))
    def test_scaling_by_1e_minus_6_keeps_the_verdict(self, geometry):
        # 1e-6 is not a power of two: coordinates round, but these inputs have no
        # near-degenerate contacts, so the verdict (and the code) stays.
        base = outcome(geometry)
        small = outcome(transformed(geometry, lambda x, y: (x * 1e-6, y * 1e-6)))
        assert small[0] == base[0]
        if base[0] == "ok":
            assert small[1] == pytest.approx(base[1] * 1e-12, rel=1e-12)

    @settings(max_examples=300, deadline=None)
    @given(
        st.lists(st.tuples(st.integers(0, 6), st.integers(0, 6)).map(list), min_size=3, max_size=9)
    )
    def test_small_integer_rings_agree_with_brute_force(self, ring):
        # A coarse grid makes touching, collinear overlaps and repeats common.
        expect_valid = brute_force_simple(ring)
        try:
            d = parse_domain(polygon(ring))
        except InputError as e:
            assert not expect_valid, e.message
            return
        assert expect_valid
        assert d.area == abs(shoelace2(ring)) / 2 > 0


def _orient(a, b, c) -> int:
    v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return (v > 0) - (v < 0)


def _on(p, a, b) -> bool:
    return (
        _orient(a, b, p) == 0
        and min(a[0], b[0]) <= p[0] <= max(a[0], b[0])
        and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])
    )


def brute_force_simple(ring) -> bool:
    """Is the integer ring (maybe closed) a simple polygon? O(n^2), exact."""
    if len(ring) >= 2 and ring[0] == ring[-1]:
        ring = ring[:-1]
    n = len(ring)
    if n < 3 or any(ring[i] == ring[(i + 1) % n] for i in range(n)):
        return False
    segs = [(ring[i], ring[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        for j in range(i + 1, n):
            (a, b), (c, d) = segs[i], segs[j]
            if j == i + 1 or (i == 0 and j == n - 1):
                # Adjacent: they share one vertex; they may not overlap.
                shared, p, q = (b, a, d) if j == i + 1 else (a, b, c)
                if _on(q, p, shared) or _on(p, shared, q):
                    return False
                continue
            if _orient(a, b, c) * _orient(a, b, d) < 0 and _orient(c, d, a) * _orient(c, d, b) < 0:
                return False
            if _on(c, a, b) or _on(d, a, b) or _on(a, c, d) or _on(b, c, d):
                return False
    return True


# ---------------------------------------------------------------------------
# The wire model (service.methods.domain_schema), which maps these errors to the params
# ---------------------------------------------------------------------------


class TestDomainIn:
    def test_example_parses(self):
        from service.methods.domain_schema import SQUARE_WITH_HOLE, DomainIn

        model = DomainIn.model_validate(SQUARE_WITH_HOLE)
        d = model.to_domain()
        assert isinstance(d, Domain)
        assert d.area == 12.0
        assert model.point_count() == 10

    def test_nan_is_located_at_the_coordinate(self):
        from pydantic import BaseModel, ValidationError

        from service.methods.domain_schema import DomainIn

        class Params(BaseModel):
            domain: DomainIn

        body = '{"domain": {"type": "Polygon", "coordinates": [[[0, 0], [1, NaN], [1, 1]]]}}'
        with pytest.raises(ValidationError) as info:
            Params.model_validate_json(body)
        (err,) = info.value.errors()
        assert err["loc"] == ("domain", "coordinates", 0, 1, 1)
        assert err["type"] == "finite_number"

    def test_booleans_and_strings_are_not_coordinates(self):
        from pydantic import ValidationError

        from service.methods.domain_schema import DomainIn

        for bad in (True, "1"):
            with pytest.raises(ValidationError) as info:
                DomainIn.model_validate(polygon([[0, 0], [1, bad], [1, 1]]))
            assert info.value.errors()[0]["loc"] == ("coordinates", 0, 1, 1)

    def test_multipolygon_depth_is_checked(self):
        from pydantic import ValidationError

        from service.methods.domain_schema import DomainIn

        with pytest.raises(ValidationError) as info:
            DomainIn.model_validate({"type": "MultiPolygon", "coordinates": [SQUARE]})
        assert info.value.errors()[0]["loc"][:1] == ("coordinates",)

    def test_meshcore_errors_are_located_in_the_params(self):
        from service.methods.domain_schema import DomainIn

        bow_tie = DomainIn.model_validate(polygon([[0, 0], [2, 2], [2, 0], [0, 2]]))
        with pytest.raises(InputError) as info:
            bow_tie.to_domain()
        assert info.value.errors[0]["loc"] == ["domain", "coordinates", 0, 0]
        square = DomainIn.model_validate(polygon(SQUARE))
        with pytest.raises(InputError) as info:
            square.to_domain([[[5, 5], [6, 6]]])
        assert info.value.code == "constraint_outside"
        assert info.value.errors[0]["loc"] == ["segments", 0, 0]


def test_corner_angles_are_the_angles_inside_the_domain():
    """An L's reflex corner reads 270, a hole's corners 270 (the domain is outside them),
    whichever way the rings were given."""
    ell = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [0, 0]]
    hole = [[0.2, 0.2], [0.2, 0.5], [0.5, 0.5], [0.5, 0.2], [0.2, 0.2]]
    for outer, inner in ((ell, hole), (ell[::-1], hole[::-1])):
        d = parse_domain({"type": "Polygon", "coordinates": [outer, inner]})
        ring = d.points[: d.boundary_point_count].tolist()
        angles = dict(zip(map(tuple, ring), d.corner_angles().tolist(), strict=True))
        assert angles[(1.0, 1.0)] == pytest.approx(270)
        assert angles[(2.0, 0.0)] == pytest.approx(90)
        assert all(angles[tuple(map(float, p))] == pytest.approx(270) for p in hole[:4])


@pytest.mark.parametrize(
    "field, loc",
    [
        ({"points": [[0, 0], [1, 1]], "values": [True, 0.5]}, ["size_field", "values", 0]),
        ({"points": [[0, 0], [1, 1]], "values": [0.5, "1"]}, ["size_field", "values", 1]),
        ({"points": [[0, "1"], [1, 1]], "values": [1, 0.5]}, ["size_field", "points", 0, 1]),
        ({"points": [[0, 0], [1, False]], "values": [1, 0.5]}, ["size_field", "points", 1, 1]),
        ((np.zeros((2, 2)), np.array([True, True])), ["size_field", "values", 0]),
        (([[0, 0], [1, 1]], [1.0, np.True_]), ["size_field", "values", 1]),
    ],
)
def test_size_field_refuses_bools_and_strings(field, loc):
    """numpy reads a bool as 0 or 1 and a numeric string as its number; the library
    refuses them where a number is due, as the service's schema does."""
    with pytest.raises(InputError) as err:
        parse_size_field(field)
    assert err.value.errors[0]["loc"] == loc and err.value.code == "bad_parameter"


@pytest.mark.parametrize("missing", ["points", "values"])
def test_size_field_without_points_or_values_says_which(missing):
    field = {"points": [[0, 0], [1, 1]], "values": [1, 0.5]}
    del field[missing]
    with pytest.raises(InputError) as err:
        parse_size_field(field)
    assert err.value.errors[0]["loc"] == ["size_field", missing]
    assert err.value.code == "bad_parameter" and missing in err.value.message


def test_size_field_takes_ints_floats_and_numeric_arrays():
    pts, vals = parse_size_field({"points": [[0, 0], [1, 1.5]], "values": [1, np.float32(0.5)]})
    assert pts.dtype == vals.dtype == np.float64 and vals.tolist() == [1.0, 0.5]
    pts, vals = parse_size_field((np.array([[0, 0], [1, 1]]), np.array([2, 3])))
    assert vals.tolist() == [2.0, 3.0]
