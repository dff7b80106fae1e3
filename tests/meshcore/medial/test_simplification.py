r"""Geometry simplification with the medial axis (§9.7.4).

The plate of the main test (10 x 4), with a hole of radius 0.1, a hole of
radius 1 and a 0.2 x 0.2 notch in its top edge::

    (0,4) +---------------+ +----------------------+ (10,4)
          |              4.4 4.6                   |
          |    o                  .---.            |
          |  (2,2) r=0.1         ( 6.5,2 ) r=1     |
          |                       '---'            |
    (0,0) +----------------------------------------+ (10,0)

Simplified: the small hole and the notch go (ratios about 0.2 and 0.4 of the
local radius), the large hole stays (about 2.3).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from meshcore.domain.planar import parse_domain
from meshcore.errors import Cancelled, InputError
from meshcore.medial.simplification import (
    DEFAULT_THRESHOLD,
    TOLERANCES,
    _corner,
    _rings,
    _sides,
    simplify,
)


def circle(c, r, n, a0=0.0, a1=2 * math.pi, endpoint=False) -> list[list[float]]:
    t = np.linspace(a0, a1, n, endpoint=endpoint)
    return np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)]).tolist()


def polygon_area(ring) -> float:
    p = np.asarray(ring, dtype=float)
    x, y = p[:, 0], p[:, 1]
    return abs(0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))


NOTCHED = [[0, 0], [10, 0], [10, 4], [4.6, 4], [4.6, 3.8], [4.4, 3.8], [4.4, 4], [0, 4]]
SMALL_HOLE = circle((2, 2), 0.1, 32)
LARGE_HOLE = circle((6.5, 2), 1, 64)
PLATE = {"type": "Polygon", "coordinates": [NOTCHED, SMALL_HOLE, LARGE_HOLE]}


def simplified(geometry, **kw):
    domain = parse_domain(geometry)
    res = simplify(domain, **kw)
    out = parse_domain(res.domain)  # a valid domain
    return domain, res, out


class TestPlate:
    def test_small_features_go_large_hole_stays(self):
        domain, res, out = simplified(PLATE)
        kinds = sorted((r["kind"], r["ring"]) for r in res.removed)
        assert kinds == [("hole", 1), ("notch", 0)]
        notch = next(r for r in res.removed if r["kind"] == "notch")
        assert notch["vertices"] == [4, 5]  # (4.6, 3.8) and (4.4, 3.8)
        assert all(r["ratio"] < DEFAULT_THRESHOLD for r in res.removed)
        assert out.ring_count == 2  # the outer ring and the large hole
        assert len(out.points) == 6 + 64  # the notch's two bottom corners are gone
        assert res.stats["axis_loops"] == 2  # one axis loop per hole of the input

    def test_area_changes_by_the_removed_areas(self):
        domain, res, out = simplified(PLATE)
        hole = polygon_area(SMALL_HOLE)
        assert out.area == pytest.approx(domain.area + hole + 0.2 * 0.2, rel=1e-12)
        assert sum(r["area"] for r in res.removed) == pytest.approx(hole + 0.04, rel=1e-12)
        hole_entry = next(r for r in res.removed if r["kind"] == "hole")
        assert hole_entry["vertices"] == list(range(32))
        assert hole_entry["size"] == pytest.approx(polygon_perimeter(SMALL_HOLE) / math.pi)

    def test_threshold_zero_removes_nothing(self):
        domain, res, out = simplified(PLATE, threshold=0)
        assert res.removed == []
        assert res.domain == domain.as_geojson()
        assert out.area == domain.area

    @pytest.mark.parametrize(("scale", "shift"), [(1e-6, 0.0), (1.0, 1e6)])
    def test_scaling_and_translation_change_nothing(self, scale, shift):
        moved = {
            "type": "Polygon",
            "coordinates": [(np.asarray(r) * scale + shift).tolist() for r in PLATE["coordinates"]],
        }
        base = simplify(parse_domain(PLATE)).removed
        res = simplify(parse_domain(moved)).removed
        assert [(r["kind"], r["ring"], r["vertices"]) for r in res] == [
            (r["kind"], r["ring"], r["vertices"]) for r in base
        ]
        assert [r["ratio"] for r in res] == pytest.approx([r["ratio"] for r in base], rel=1e-6)

    def test_large_threshold_removes_the_large_hole_too(self):
        domain, res, out = simplified(PLATE, threshold=3)
        assert sorted(r["ring"] for r in res.removed if r["kind"] == "hole") == [1, 2]
        assert out.ring_count == 1
        assert out.area == pytest.approx(40.0)


def polygon_perimeter(ring) -> float:
    p = np.asarray(ring, dtype=float)
    return float(np.hypot(*(np.roll(p, -1, axis=0) - p).T).sum())


class TestDetails:
    def test_protrusion_is_cut_by_its_chord(self):
        ring = [[0, 0], [10, 0], [10, 4], [5.1, 4], [5.1, 4.2], [4.9, 4.2], [4.9, 4], [0, 4]]
        domain, res, out = simplified({"type": "Polygon", "coordinates": [ring]})
        assert [r["kind"] for r in res.removed] == ["protrusion"]
        assert res.removed[0]["area"] == pytest.approx(-0.04)
        assert out.area == pytest.approx(40.0)

    def test_notch_in_a_sampled_edge_is_cut_at_its_own_corners(self):
        right = [[x, 4] for x in np.round(np.arange(10, 5.09, -0.1), 6)]
        left = [[x, 4] for x in np.round(np.arange(4.9, -0.01, -0.1), 6)]
        ring = [[0, 0], [10, 0], *right, [5.1, 3.8], [4.9, 3.8], *left]
        domain, res, out = simplified({"type": "Polygon", "coordinates": [ring]})
        assert len(res.removed) == 1 and res.removed[0]["kind"] == "notch"
        assert res.removed[0]["size"] == pytest.approx(math.hypot(0.2, 0.2))
        assert out.area == pytest.approx(40.0)
        assert len(out.points) == len(ring) - 2

    def test_step_is_flattened(self):
        ring = [[0, 0], [5, 0], [5, 0.1], [10, 0.1], [10, 4], [0, 4]]
        domain, res, out = simplified({"type": "Polygon", "coordinates": [ring]})
        assert [r["kind"] for r in res.removed] == ["step"]
        assert len(out.points) == 5
        assert [5, 0.05] in out.points.tolist()  # the step collapsed to its midpoint
        assert out.area == pytest.approx(domain.area)

    def test_convex_fillet_is_replaced_by_its_corner(self):
        arc = circle((9.7, 3.7), 0.3, 9, 0, math.pi / 2, True)
        domain, res, out = simplified(
            {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], *arc, [0, 4]]]}
        )
        assert [r["kind"] for r in res.removed] == ["fillet"]
        assert out.area == pytest.approx(40.0)
        assert np.hypot(*(out.points - [10, 4]).T).min() < 1e-12
        assert res.removed[0]["area"] == pytest.approx(0.3**2 - polygon_area([[9.7, 3.7], *arc]))

    def test_chamfer_is_replaced_by_its_corner(self):
        ring = [[0, 0], [10, 0], [10, 3.8], [9.8, 4], [0, 4]]
        domain, res, out = simplified({"type": "Polygon", "coordinates": [ring]})
        assert [r["kind"] for r in res.removed] == ["fillet"]
        assert np.allclose(sorted(out.points.tolist()), [[0, 0], [0, 4], [10, 0], [10, 4]])

    def test_concave_fillet_restores_the_inner_corner(self):
        arc = circle((2.2, 2.2), 0.2, 9, -math.pi / 2, -math.pi, True)
        ring = [[0, 0], [10, 0], [10, 2], *arc, [2, 10], [0, 10]]
        domain, res, out = simplified({"type": "Polygon", "coordinates": [ring]})
        assert [r["kind"] for r in res.removed] == ["fillet"]
        assert res.removed[0]["area"] < 0
        assert out.area == pytest.approx(36.0)

    @pytest.mark.parametrize("n", [64, 256])
    def test_a_sampled_circle_has_no_details(self, n):
        domain, res, out = simplified(
            {"type": "Polygon", "coordinates": [circle((0, 0), 1, n)]}, threshold=0.9
        )
        assert res.removed == []

    def test_plain_polygons_keep_their_corners(self):
        for ring in (
            [[0, 0], [10, 0], [10, 2], [2, 2], [2, 10], [0, 10]],
            [[0, 0], [10, 0], [5, 1]],
        ):
            _, res, _ = simplified({"type": "Polygon", "coordinates": [ring]}, threshold=2)
            assert [r for r in res.removed if r["kind"] != "hole"] == []

    def test_multipolygon_stays_a_multipolygon(self):
        geometry = {
            "type": "MultiPolygon",
            "coordinates": [PLATE["coordinates"], [[[20, 0], [30, 0], [30, 4], [20, 4]]]],
        }
        domain, res, out = simplified(geometry)
        assert res.domain["type"] == "MultiPolygon"
        assert out.ring_count == 3
        assert sorted(r["kind"] for r in res.removed) == ["hole", "notch"]


class TestHelpers:
    def test_corner_of_two_lines(self):
        X = _corner(
            np.array([0.0, 0]),
            np.array([1.0, 0]),
            np.array([2.0, 1]),
            np.array([2.0, 3]),
            TOLERANCES,
        )
        assert X.tolist() == [2.0, 0.0]
        # parallel lines, and a corner behind the run: none
        assert (
            _corner(
                np.array([0.0, 0]),
                np.array([1.0, 0]),
                np.array([1.0, 1]),
                np.array([0.0, 1]),
                TOLERANCES,
            )
            is None
        )
        assert (
            _corner(
                np.array([0.0, 0]),
                np.array([1.0, 0]),
                np.array([0.5, 1]),
                np.array([0.5, 3]),
                TOLERANCES,
            )
            is None
        )

    def test_sides_run_along_straight_boundary(self):
        ring = [[x, 0.0] for x in range(5)] + [[4.0, 1.0], [0.0, 1.0]]
        domain = parse_domain({"type": "Polygon", "coordinates": [ring]})
        rg = _rings(domain, np.ones(domain.boundary_point_count))
        back, back_n, fwd, fwd_n = _sides(rg, math.radians(10))
        assert fwd[0] == 4 and fwd_n[0] == 4  # the sampled bottom edge is one side
        assert back[4] == 4 and back_n[4] == 4
        assert fwd[2] == 2 and back[2] == 2
        assert fwd[4] == 1 and back[0] == 1  # corners end sides


class TestInterface:
    def test_progress_reports_and_cancels(self):
        domain = parse_domain(PLATE)
        seen = []
        simplify(domain, progress=lambda f, m: seen.append(f))
        assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)

        def stop(fraction, message):
            raise Cancelled("stop")

        with pytest.raises(Cancelled):
            simplify(domain, progress=stop)

    @pytest.mark.parametrize(
        ("kwargs", "loc"),
        [
            ({"threshold": -1}, ["threshold"]),
            ({"threshold": math.nan}, ["threshold"]),
            ({"threshold": True}, ["threshold"]),
            ({"threshold": "big"}, ["threshold"]),
            ({"h": 0}, ["h"]),
            ({"h": math.inf}, ["h"]),
        ],
    )
    def test_bad_parameters(self, kwargs, loc):
        with pytest.raises(InputError) as info:
            simplify(parse_domain(PLATE), **kwargs)
        assert info.value.errors[0]["loc"] == loc
        assert info.value.code == "bad_value"

    def test_domain_must_be_a_domain(self):
        with pytest.raises(InputError) as info:
            simplify(PLATE)
        assert info.value.code == "bad_type"
        assert info.value.errors[0]["loc"] == ["domain"]
