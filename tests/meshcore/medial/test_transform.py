r"""The medial axis transform (§9.6): boundaries rebuilt from axes and radii.

The analytic axes used here::

    rectangle 2 x 1                     annulus, radii 0.5 and 1
    (0,1) +-------------+ (2,1)         a loop of nodes on the circle of
          | \         / |               radius 0.75, every radius 0.25
          |  o-------o  |
          | /         \ |
    (0,0) +-------------+ (2,0)

The rectangle's axis: the segment (0.5, 0.5)-(1.5, 0.5) with radius 0.5,
and four branches to the corners whose radius falls linearly to 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from meshcore.domain.planar import parse_domain
from meshcore.errors import Cancelled, InputError
from meshcore.medial.transform import medial_transform

RECT_NODES = np.array([[0.5, 0.5], [1.5, 0.5], [0, 0], [2, 0], [2, 1], [0, 1]], dtype=float)
RECT_RADIUS = np.array([0.5, 0.5, 0, 0, 0, 0])
RECT_EDGES = np.array([[0, 1], [0, 2], [1, 3], [1, 4], [0, 5]])
RECT = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1]]]}


def circle(radius: float, n: int) -> list[list[float]]:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return (radius * np.column_stack([np.cos(t), np.sin(t)])).tolist()


def annulus_axis(k: int):
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    nodes = 0.75 * np.column_stack([np.cos(t), np.sin(t)])
    edges = np.column_stack([np.arange(k), (np.arange(k) + 1) % k])
    return nodes, np.full(k, 0.25), edges


ANNULUS = {"type": "Polygon", "coordinates": [circle(1, 1024), circle(0.5, 1024)]}


def signed_area(ring) -> float:
    p = np.asarray(ring)
    return 0.5 * float(np.sum(p[:-1, 0] * p[1:, 1] - p[1:, 0] * p[:-1, 1]))


class TestAnalyticAxes:
    def test_rectangle_is_rebuilt(self):
        domain = parse_domain(RECT)
        res = medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, boundary=domain)
        assert res.domain["type"] == "Polygon"
        assert len(res.domain["coordinates"]) == 1  # no hole
        assert res.hausdorff < res.h
        assert res.area == pytest.approx(2.0, abs=6 * res.h)  # perimeter x h
        assert res.stats["boundary_area"] == 2.0

    def test_corner_branches_give_sharp_corners(self):
        # Tangent triangles from the (0.5, 0.5) disk to the corner: the corner is a vertex.
        res = medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES)
        ring = np.asarray(res.domain["coordinates"][0])
        for corner in ([0, 0], [2, 0], [2, 1], [0, 1]):
            assert np.hypot(*(ring - corner).T).min() < 1e-12

    def test_annulus_has_one_hole(self):
        domain = parse_domain(ANNULUS)
        res = medial_transform(*annulus_axis(400), boundary=domain)
        assert res.domain["type"] == "Polygon"
        outer, *holes = res.domain["coordinates"]
        assert len(holes) == 1
        assert res.hausdorff < res.h
        exact = math.pi * (1 - 0.25)
        assert res.area == pytest.approx(exact, abs=3 * math.pi * res.h)  # perimeter x h
        assert res.stats["holes"] == 1 and res.stats["rings"] == 2

    def test_smaller_h_is_closer(self):
        domain = parse_domain(ANNULUS)
        coarse = medial_transform(*annulus_axis(400), boundary=domain, h=0.02)
        fine = medial_transform(*annulus_axis(400), boundary=domain, h=0.002)
        assert coarse.hausdorff < 0.02 and fine.hausdorff < 0.002
        assert fine.hausdorff < coarse.hausdorff

    def test_single_disk(self):
        res = medial_transform([[3.0, -1.0]], [2.0], np.zeros((0, 2), dtype=int), h=1e-3)
        assert res.area == pytest.approx(4 * math.pi, abs=2 * math.pi * 2 * 1e-3)
        assert res.area < 4 * math.pi  # inscribed polygons: inside the exact union
        assert res.hausdorff is None

    def test_disjoint_parts_make_a_multipolygon(self):
        res = medial_transform([[0, 0], [1, 0], [5, 0]], [0.2, 0.2, 0.3], [[0, 1]])
        assert res.domain["type"] == "MultiPolygon"
        assert len(res.domain["coordinates"]) == 2
        assert res.stats["polygons"] == 2

    def test_output_is_a_valid_normalized_domain(self):
        res = medial_transform(*annulus_axis(200))
        outer, hole = res.domain["coordinates"]
        assert outer[0] == outer[-1] and hole[0] == hole[-1]
        assert signed_area(outer) > 0 > signed_area(hole)  # outer CCW, hole CW
        assert all(isinstance(x, float) for x in outer[0])
        assert parse_domain(res.domain).area == pytest.approx(res.area)

    def test_translation_does_not_change_the_result(self):
        shift = np.array([1e6, -1e6])
        base = medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, h=1e-3)
        moved = medial_transform(RECT_NODES + shift, RECT_RADIUS, RECT_EDGES, h=1e-3)
        assert moved.area == pytest.approx(base.area, rel=1e-8)


class TestRoundTrip:
    """medial_transform of medial_axis(domain) reproduces the boundary within h."""

    @pytest.mark.parametrize(
        "geometry", [RECT, {"type": "Polygon", "coordinates": [circle(1, 256), circle(0.5, 256)]}]
    )
    def test_axis_of_a_domain_rebuilds_it(self, geometry):
        from meshcore.medial.axis import medial_axis

        domain = parse_domain(geometry)
        ax = medial_axis(domain, h=0.01)
        res = medial_transform(ax.nodes, ax.radius, ax.edges, boundary=domain, h=ax.h)
        assert res.hausdorff < ax.h
        assert len(res.domain["coordinates"]) == domain.ring_count
        perimeter = 6.0 if domain.ring_count == 1 else 3 * math.pi
        assert abs(res.area - domain.area) < perimeter * ax.h


class TestProgress:
    def test_reports_and_cancels(self):
        seen = []
        medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, progress=lambda f, m: seen.append(f))
        assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)

        def stop(fraction, message):
            raise Cancelled("stop")

        with pytest.raises(Cancelled):
            medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, progress=stop)


class TestErrors:
    @pytest.mark.parametrize(
        ("nodes", "radius", "edges", "loc", "code"),
        [
            ([], [], [], ["nodes"], "empty"),
            ([[0, 0, 0]], [1], [], ["nodes"], "bad_shape"),
            ("abc", [1], [], ["nodes"], "bad_shape"),
            ([[0, 0], [1, math.nan]], [1, 1], [], ["nodes", 1, 1], "non_finite"),
            ([[0, 0], [1, 0]], [1], [], ["radius"], "shape_mismatch"),
            ([[0, 0], [1, 0]], [[1, 1]], [], ["radius"], "bad_shape"),
            ([[0, 0], [1, 0]], [1, math.inf], [], ["radius", 1], "non_finite"),
            (
                [[0, 0], [1, 0], [2, 0], [3, 0]],
                [1, 1, 1, -0.5],
                [],
                ["radius", 3],
                "negative_radius",
            ),
            ([[0, 0], [1, 0]], [1, 1], [[0, 1], [1, 2]], ["edges", 1, 1], "index_out_of_range"),
            ([[0, 0], [1, 0]], [1, 1], [[0, -1]], ["edges", 0, 1], "index_out_of_range"),
            ([[0, 0], [1, 0]], [1, 1], [[0, 1], [1, 1]], ["edges", 1], "self_loop"),
            ([[0, 0], [1, 0]], [1, 1], [[0, 0.5]], ["edges", 0, 1], "bad_index"),
            ([[0, 0], [1, 0]], [1, 1], [[0, 1, 1]], ["edges"], "bad_shape"),
            ([[0, 0], [1, 0]], [0, 0], [[0, 1]], ["radius"], "empty_union"),
            ([[0, 0], [1e300, 0]], [1, 1], [], ["nodes", 1], "out_of_range"),
        ],
    )
    def test_bad_axis(self, nodes, radius, edges, loc, code):
        with pytest.raises(InputError) as info:
            medial_transform(nodes, radius, edges)
        assert info.value.code == code
        assert info.value.errors[0]["loc"] == loc

    @pytest.mark.parametrize("h", [0, -1, math.nan, math.inf, "x"])
    def test_bad_h(self, h):
        with pytest.raises(InputError) as info:
            medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, h=h)
        assert info.value.errors[0]["loc"] == ["h"]

    def test_boundary_must_be_a_domain(self):
        with pytest.raises(InputError) as info:
            medial_transform(RECT_NODES, RECT_RADIUS, RECT_EDGES, boundary=RECT)
        assert info.value.code == "bad_type"
