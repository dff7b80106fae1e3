"""Recursive partition (§8.7.2), 2D: facts a reader can check by hand.

Hypothesis draws star-shaped polygons with a hole; every mesh must hold
only triangles (or only quads), no cell of non-positive area (exact
orient2d), the domain's area, every input segment as a chain of edges, and
edges whose median length is within 20 % of the size.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore import InputError, parse_domain
from meshcore.geometry.predicates import orient2d
from meshcore.mesh import quality
from meshcore.mesh.quality import quad_quality
from meshcore.partition import (
    kernel,
    partition_polygon,
    recursive_partition,
    resample_boundary,
    size_map,
)

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}
L_SHAPE = {
    "type": "Polygon",
    "coordinates": [[[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]]],
}


def circle(cx, cy, r, n, clockwise=False):
    t = 2 * np.pi * np.arange(n) / n
    if clockwise:
        t = -t
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)]).tolist()


SQUARE_HOLE = {
    "type": "Polygon",
    "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], circle(0.5, 0.5, 0.25, 32)],
}


@st.composite
def star_with_hole(draw):
    n = draw(st.integers(5, 12))
    radii = draw(st.lists(st.floats(0.7, 1.0), min_size=n, max_size=n))
    jitter = draw(st.lists(st.floats(-0.3, 0.3), min_size=n, max_size=n))
    t = 2 * np.pi * (np.arange(n) + np.array(jitter)) / n
    outer = np.column_stack([np.array(radii) * np.cos(t), np.array(radii) * np.sin(t)])
    rings = [outer.tolist()]
    if draw(st.booleans()):
        m = draw(st.integers(3, 8))
        r = draw(st.floats(0.1, 0.3))
        cx, cy = draw(st.floats(-0.15, 0.15)), draw(st.floats(-0.15, 0.15))
        rings.append(circle(cx, cy, r, m))
    size = draw(st.sampled_from([0.12, 0.08]))
    return {"type": "Polygon", "coordinates": rings}, size


def edges_of(cells: np.ndarray) -> np.ndarray:
    e = np.sort(np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    return e


def check_mesh(geometry, res, size, element, median=True):
    dom = parse_domain(geometry)
    (block,) = res.mesh.cells
    assert block.type == element
    P, C = res.mesh.points, block.data
    k = C.shape[1]
    # every corner turns left (exact): no inverted or flat cell, quads convex
    for c in range(k):
        assert (orient2d(P[C[:, c]], P[C[:, (c + 1) % k]], P[C[:, (c + 2) % k]]) > 0).all()
    area = quality.signed_area(P, C, element)
    assert math.isclose(float(area.sum()), dom.area, rel_tol=1e-9)
    # conforming: every edge in one or two cells; the edges in one cell are the boundary
    e, cnt = np.unique(edges_of(C), axis=0, return_counts=True)
    assert cnt.max() <= 2
    bnd = e[cnt == 1]
    # every input segment a chain of boundary edges: boundary points on it, lengths adding up
    a, b = dom.points[dom.segments[:, 0]], dom.points[dom.segments[:, 1]]
    seg_len = np.hypot(*(b - a).T)
    bl = np.hypot(*(P[bnd[:, 1]] - P[bnd[:, 0]]).T)
    assert math.isclose(bl.sum(), seg_len.sum(), rel_tol=1e-9)
    mid = (P[bnd[:, 0]] + P[bnd[:, 1]]) / 2
    for s in range(len(a)):
        d = b[s] - a[s]
        on = (
            np.abs(d[0] * (mid[:, 1] - a[s, 1]) - d[1] * (mid[:, 0] - a[s, 0])) <= 1e-9 * seg_len[s]
        )
        t = np.einsum("ij,j->i", mid - a[s], b[s] - a[s]) / seg_len[s] ** 2
        on &= (t > 0) & (t < 1)
        assert math.isclose(bl[on].sum(), seg_len[s], rel_tol=1e-9)
    # input vertices are mesh points
    assert np.array_equal(P[: len(dom.points)], dom.points)
    if median:
        med = float(np.median(np.hypot(*(P[e[:, 1]] - P[e[:, 0]]).T)))
        assert abs(med - size) <= 0.2 * size, med


class TestBadInput:
    def test_element_is_named(self):
        with pytest.raises(InputError) as ei:
            recursive_partition(SQUARE, size=0.1, element="hexahedron")
        assert ei.value.errors[0]["loc"] == ["element"]

    def test_strategy_is_named(self):
        with pytest.raises(InputError) as ei:
            recursive_partition(SQUARE, size=0.1, strategy="random")
        assert ei.value.errors[0]["loc"] == ["strategy"]

    @pytest.mark.parametrize("size", [0, -1, float("nan"), "a"])
    def test_size_is_named(self, size):
        with pytest.raises(InputError) as ei:
            recursive_partition(SQUARE, size=size)
        assert ei.value.errors[0]["loc"] == ["size"]

    def test_no_size(self):
        with pytest.raises(InputError) as ei:
            recursive_partition(SQUARE)
        assert ei.value.errors[0]["loc"] == ["size"]

    def test_constraints_refused(self):
        dom = parse_domain(SQUARE, segments=[[[0.2, 0.2], [0.8, 0.8]]])
        with pytest.raises(InputError) as ei:
            recursive_partition(dom, size=0.1)
        assert ei.value.code == "unsupported"

    def test_bad_domain_located(self):
        bow = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1]]]}
        with pytest.raises(InputError) as ei:
            recursive_partition(bow, size=0.1)
        assert ei.value.errors[0]["loc"][0] == "coordinates"


class TestCanonical:
    @pytest.mark.parametrize("element", ["triangle", "quad"])
    @pytest.mark.parametrize("geometry", [SQUARE, L_SHAPE, SQUARE_HOLE])
    def test_valid_mesh(self, geometry, element):
        res = recursive_partition(geometry, size=0.05, element=element)
        check_mesh(geometry, res, 0.05, element)
        assert res.quality[element]["invalid"] == 0
        if element == "quad":
            # smoothing and the clean-up: the least quality (8.4) was 0.18-0.30 without
            P, C = res.mesh.points, res.mesh.cells[0].data
            assert quad_quality(P, C).min() > 0.4

    def test_unit_square_with_size_one_is_two_triangles(self):
        #  3---2
        #  | / |    one separator: the diagonal
        #  0---1
        res = recursive_partition(SQUARE, size=1.0)
        assert len(res.mesh.cells[0].data) == 2
        assert res.stats["separators"]["1"] == 1

    def test_unit_square_with_size_one_is_one_quad(self):
        res = recursive_partition(SQUARE, size=1.0, element="quad")
        assert res.mesh.cells[0].data.tolist() == [[0, 1, 2, 3]]

    def test_hole_joined_by_a_bridge(self):
        res = recursive_partition(SQUARE_HOLE, size=0.1)
        assert res.stats["bridges"] == 1

    def test_angle_strategy(self):
        res = recursive_partition(L_SHAPE, size=0.05, strategy="angle")
        check_mesh(L_SHAPE, res, 0.05, "triangle")

    def test_size_field_grades(self):
        field = {"points": [[0, 0], [1, 1]], "values": [0.02, 0.2]}
        res = recursive_partition(SQUARE, size_field=field)
        P, C = res.mesh.points, res.mesh.cells[0].data
        cen = P[C].mean(axis=1)
        area = quality.signed_area(P, C, "triangle")
        near = cen.sum(axis=1) < 0.5
        far = cen.sum(axis=1) > 1.5
        assert area[near].mean() < area[far].mean() / 4

    def test_odd_ring_made_even_for_quads(self):
        tri = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1]]]}
        dom = parse_domain(tri)
        bnd = resample_boundary(dom, size_map(dom, 0.3), even=True)
        assert len(bnd.loops[0]) % 2 == 0
        res = recursive_partition(tri, size=0.3, element="quad")
        check_mesh(tri, res, 0.3, "quad", median=False)

    @pytest.mark.parametrize("shift, scale", [(1e6, 1.0), (0.0, 1e-6)])
    def test_translation_and_scale(self, shift, scale):
        ref = recursive_partition(L_SHAPE, size=0.1)
        coords = [
            [[x * scale + shift, y * scale + shift] for x, y in r] for r in L_SHAPE["coordinates"]
        ]
        moved = recursive_partition({"type": "Polygon", "coordinates": coords}, size=0.1 * scale)
        assert len(moved.mesh.cells[0].data) == len(ref.mesh.cells[0].data)
        np.testing.assert_allclose((moved.mesh.points - shift) / scale, ref.mesh.points, atol=1e-6)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=star_with_hole(), element=st.sampled_from(["triangle", "quad"]))
def test_random_polygons_with_holes(case, element):
    geometry, size = case
    res = recursive_partition(geometry, size=size, element=element)
    check_mesh(geometry, res, size, element)


def test_guaranteed_quad_route_when_stuck(monkeypatch):
    import meshcore.partition.recursive as module

    real = module.partition_polygon

    def stuck(points, loops, ring_polygon, sizes, *, quad, strategy="balanced"):
        if quad:
            return points, None, None
        return real(points, loops, ring_polygon, sizes, quad=quad, strategy=strategy)

    monkeypatch.setattr(module, "partition_polygon", stuck)
    res = recursive_partition(SQUARE_HOLE, size=0.05, element="quad")
    assert res.stats["fallback"] is True
    check_mesh(SQUARE_HOLE, res, 0.05, "quad")


def test_split_search_compiles_once():
    # the sampled search, then the full one, pass ``full`` as a runtime bool: one
    # signature of _best_split and _score for both (a literal True/False is two);
    # loaded from numba's cache, the callees have none of their own
    recursive_partition(SQUARE_HOLE, size=0.1, element="quad")
    recursive_partition(SQUARE_HOLE, size=0.1)
    assert len(kernel.recurse.signatures) == 1
    assert len(kernel._best_split.signatures) <= 1
    assert len(kernel._score.signatures) <= 1


def test_stuck_sub_polygon_handed_back():
    # a 12-gon the quad recursion gets stuck on after one split: the quad it cut
    # off is kept and the 10-gon left is handed back, the two covering the polygon
    P = np.array(
        [[0.8, 0.0], [0.7, 0.4], [0.3, 0.9], [0.2, 0.6], [-0.1, 0.6], [-0.8, 0.1],
         [-0.4, -0.8], [0.2, -1.0], [0.2, -0.5], [0.5, -0.6], [0.6, -0.7], [0.5, -0.5]]
    )  # fmt: skip
    loop = [np.arange(len(P))]
    sizes = size_map(parse_domain({"type": "Polygon", "coordinates": [P.tolist()]}), 10.0, None)
    assert partition_polygon(P, loop, np.zeros(1, np.int64), sizes, quad=True)[1] is None
    Q, cells, stats = partition_polygon(
        P, loop, np.zeros(1, np.int64), sizes, quad=True, leave_stuck=True
    )
    assert len(cells) and len(stats["stuck"]) == 1
    assert kernel.strictly_convex_rows(Q, cells).all()
    left = stats["stuck"][0]
    assert len(left) % 2 == 0
    fan = np.column_stack([np.full(len(left) - 2, left[0]), left[1:-1], left[2:]])
    whole = np.column_stack(
        [np.zeros(len(P) - 2, np.int64), np.arange(1, len(P) - 1), np.arange(2, len(P))]
    )
    total = quality.signed_area(Q, cells, "quad").sum() + quality.signed_area(Q, fan).sum()
    assert math.isclose(total, quality.signed_area(P, whole).sum())
