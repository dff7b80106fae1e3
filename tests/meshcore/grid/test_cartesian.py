"""Facts about ``grid`` (§8.2) that a reader can check by hand.

Every fitted mesh is checked by :func:`assert_fitted`, from the mesh alone:

* every cell is counter-clockwise with positive area: triangles by the
  exact ``orient2d``, quads strictly convex (all four corners turn left);
* every input vertex is a mesh point (the same coordinates);
* every input segment, boundary or constraint, is a chain of mesh edges:
  the mesh points on it, sorted along it, run from one end to the other
  and each consecutive pair is a mesh edge;
* the mesh conforms (no edge held by three cells), and its border edges
  are exactly the chains of the boundary rings;
* the cell areas add up to the domain's area.

Domains::

    square with a hole   L-shape       grid-aligned square
    +---------+          +---+         +--+--+
    |   ___   |          |   |         |  |  |   (the boundary runs on
    |  (   )  |          |   +---+     +--+--+    grid lines: every node
    |   ---   |          |       |     |  |  |    on it snaps in place)
    +---------+          +-------+     +--+--+
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d
from meshcore.grid import grid
from meshcore.mesh import topology


def circle(cx, cy, r, n, start=0.0):
    th = start + 2 * np.pi * np.arange(n) / n
    return np.column_stack([cx + r * np.cos(th), cy + r * np.sin(th)]).tolist()


def square_with_hole(n=48):
    return {
        "type": "Polygon",
        "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], circle(0.5, 0.5, 0.25, n)],
    }


def l_shape():
    return {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]]}


def plate(k=3):
    holes = [
        circle(0.25 + 0.5 * i / (k - 1) * 1.0, 0.25 + 0.5 * j / (k - 1), 0.07, 12, 0.3)
        for i in range(k)
        for j in range(k)
    ]
    return {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], *holes]}


NAMED = {
    "square_with_hole": (square_with_hole(), 0.037),
    "l_shape": (l_shape(), 0.13),
    "plate": (plate(), 0.041),
    "aligned_square": (
        {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]},
        0.125,
    ),
}


def _cells(mesh):
    return [(b.type, b.data) for b in mesh.cells]


def assert_fitted(domain, mesh, area_rtol=1e-12):
    dom = parse_domain(domain) if isinstance(domain, dict) else domain
    P = mesh.points
    Q = P - P.min(axis=0)  # exact near 1e6: the shoelace sum without cancellation
    area = 0.0
    for kind, data in _cells(mesh):
        k = data.shape[1]
        for c in range(k):
            turn = orient2d(P[data[:, c]], P[data[:, (c + 1) % k]], P[data[:, (c + 2) % k]])
            assert (turn > 0).all(), f"{kind} not strictly convex / counter-clockwise"
            area += 0.5 * float(
                np.sum(
                    Q[data[:, c], 0] * Q[data[:, (c + 1) % k], 1]
                    - Q[data[:, (c + 1) % k], 0] * Q[data[:, c], 1]
                )
            )
    assert area == pytest.approx(dom.area, rel=area_rtol)
    # input vertices are mesh points
    key = {tuple(p) for p in P.tolist()}
    assert all(tuple(p) in key for p in dom.points.tolist())
    # edges
    edges = []
    for _, data in _cells(mesh):
        k = data.shape[1]
        edges.append(np.column_stack([data.ravel(), np.roll(data, -1, axis=1).ravel()]))
    e = np.sort(np.concatenate(edges), axis=1)
    ue, cnt = np.unique(e, axis=0, return_counts=True)
    assert cnt.max() <= 2
    edge_set = {tuple(x) for x in ue.tolist()}
    border = {tuple(x) for x in ue[cnt == 1].tolist()}
    # on a segment: within rounding of the coordinates' magnitude
    tol = 1e-12 * dom.diameter + 64 * np.finfo(float).eps * float(np.abs(P).max())
    chain_edges = set()
    index = {tuple(p): i for i, p in enumerate(P.tolist())}
    segs = np.concatenate([dom.segments, dom.constraints])
    for s, (a, b) in enumerate(segs):
        A, B = dom.points[a], dom.points[b]
        d = B - A
        t = (P - A) @ d / (d @ d)
        off = np.abs((P[:, 0] - A[0]) * d[1] - (P[:, 1] - A[1]) * d[0]) / np.hypot(*d)
        on = np.flatnonzero((off < tol) & (t > -1e-12) & (t < 1 + 1e-12))
        on = on[np.argsort(t[on])]
        assert on[0] == index[tuple(A)] and on[-1] == index[tuple(B)]
        for u, v in zip(on[:-1], on[1:], strict=True):
            assert (min(u, v), max(u, v)) in edge_set, f"segment {s} is not a chain of edges"
            if s < len(dom.segments):
                chain_edges.add((min(u, v), max(u, v)))
    assert border == chain_edges
    assert topology.conformity(mesh)["nonmanifold"] == 0


def _interior_squares(mesh, h):
    """The interior cells are squares of side h (or their halves)."""
    P = mesh.points
    sets = mesh.cell_sets["interior"]
    for block, ids in zip(mesh.cells, sets, strict=True):
        data = block.data[ids]
        if block.type == "quad":
            sides = np.linalg.norm(P[data] - P[np.roll(data, -1, axis=1)], axis=2)
            diag = np.linalg.norm(P[data[:, 0]] - P[data[:, 2]], axis=1)
            np.testing.assert_allclose(sides, h, rtol=1e-9)
            np.testing.assert_allclose(diag, h * math.sqrt(2), rtol=1e-9)
        else:
            sides = np.sort(np.linalg.norm(P[data] - P[np.roll(data, -1, axis=1)], axis=2), axis=1)
            np.testing.assert_allclose(sides[:, :2], h, rtol=1e-9)
            np.testing.assert_allclose(sides[:, 2], h * math.sqrt(2), rtol=1e-9)


class TestFit:
    @pytest.mark.parametrize("boundary", ["fit", "split"])
    @pytest.mark.parametrize("cells", ["quad", "triangle"])
    @pytest.mark.parametrize("name", NAMED)
    def test_named_domains(self, name, cells, boundary):
        domain, h = NAMED[name]
        res = grid(domain, size=h, boundary=boundary, cells=cells)
        assert_fitted(domain, res.mesh)
        _interior_squares(res.mesh, h)
        assert res.stats["cells"]["interior"] > 0
        if boundary == "split" or cells == "triangle":
            assert all(b.type == "triangle" for b in res.mesh.cells if len(b)) or cells == "quad"
            if cells == "triangle":
                assert [b.type for b in res.mesh.cells] == ["triangle"]

    def test_split_boundary_cells_are_triangles(self):
        domain, h = NAMED["square_with_hole"]
        res = grid(domain, size=h, boundary="split")
        quad_block = next(b for b in res.mesh.cells if b.type == "quad")
        # every quad is an interior square: the cut cells are all triangles
        assert len(quad_block) == len(res.mesh.cell_sets["interior"][0])

    def test_aligned_square_is_all_squares(self):
        domain, h = NAMED["aligned_square"]
        res = grid(domain, size=h)
        assert res.stats["quads"] == 64 and res.stats["triangles"] == 0
        assert res.stats["templates"]["whole"] + res.stats["core_cells"] >= 60
        P, q = res.mesh.points, res.mesh.cells[0].data
        np.testing.assert_allclose(np.linalg.norm(P[q] - P[np.roll(q, -1, axis=1)], axis=2), h)

    def test_rotated_grid_and_origin(self):
        domain, h = NAMED["l_shape"]
        res = grid(domain, size=h, angle=17.0, origin=[0.01, -0.02])
        assert_fitted(domain, res.mesh)
        _interior_squares(res.mesh, h)

    def test_constraints_are_chains(self):
        dom = parse_domain(
            l_shape(), [[[0.2, 0.3], [1.7, 0.6]], [[0.5, 1.8], [0.5, 0.5], [0.8, 0.9]]]
        )
        res = grid(dom, size=0.11)
        assert_fitted(dom, res.mesh)

    @pytest.mark.parametrize("boundary", ["fit", "split"])
    @pytest.mark.parametrize("f", ["shift", "shrink"])
    def test_translation_and_scale(self, f, boundary):
        domain, h = NAMED["square_with_hole"]
        base = grid(domain, size=h, boundary=boundary)
        if f == "shift":
            move, hh, o = (lambda p: [p[0] + 1e6, p[1] + 1e6]), h, [1e6, 1e6]
        else:
            move, hh, o = (lambda p: [p[0] * 1e-6, p[1] * 1e-6]), h * 1e-6, [0.0, 0.0]
        moved = {
            "type": "Polygon",
            "coordinates": [[move(p) for p in r] for r in domain["coordinates"]],
        }
        res = grid(moved, size=hh, origin=o, boundary=boundary)
        assert_fitted(moved, res.mesh, area_rtol=1e-9 if f == "shift" else 1e-12)
        assert res.stats["quads"] == base.stats["quads"]
        assert res.stats["triangles"] == base.stats["triangles"]
        assert res.stats["templates"] == base.stats["templates"]

    @settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def test_random_polygons_with_holes(self, data):
        seed = data.draw(st.integers(0, 2**32 - 1))
        rng = np.random.default_rng(seed)
        n = data.draw(st.integers(6, 40))
        th = np.sort((np.arange(n) + rng.uniform(-0.4, 0.4, n)) * 2 * np.pi / n)
        outer = np.asarray(circle(0, 0, 1, n)) * 0 + np.column_stack([np.cos(th), np.sin(th)])
        outer = (outer * rng.uniform(0.55, 1.0, (n, 1))).tolist()
        rings = [outer]
        for k in range(data.draw(st.integers(0, 3))):
            m = data.draw(st.integers(3, 10))
            ha = (np.arange(m) + rng.uniform(-0.2, 0.2, m)) * 2 * np.pi / m
            r = rng.uniform(0.03, 0.12, (m, 1))
            c = 0.3 * np.array([math.cos(2 * math.pi * k / 3), math.sin(2 * math.pi * k / 3)])
            rings.append((c + r * np.column_stack([np.cos(ha), np.sin(ha)])).tolist())
        domain = {"type": "Polygon", "coordinates": rings}
        h = data.draw(st.floats(0.02, 0.2))
        angle = data.draw(st.floats(0, 90))
        boundary = data.draw(st.sampled_from(["fit", "split"]))
        res = grid(domain, size=h, angle=angle, boundary=boundary)
        assert_fitted(domain, res.mesh)


def _segments_of(lines):
    parts = getattr(lines, "geoms", [lines])
    return np.concatenate(
        [np.stack([np.asarray(g.coords)[:-1], np.asarray(g.coords)[1:]], axis=1) for g in parts]
    )


def _brute_hausdorff(A, B, step):
    """Largest distance from a dense sample of each set to every segment of the other."""

    def dense(S):
        out = []
        for a, b in S:
            n = int(math.ceil(np.linalg.norm(b - a) / step)) + 1
            out.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
        return np.concatenate(out)

    def directed(P, S):
        a, d = S[:, 0], S[:, 1] - S[:, 0]
        best = np.zeros(len(P))
        for k in range(0, len(P), 2048):
            q = P[k : k + 2048, None, :]
            t = np.clip(((q - a) * d).sum(-1) / (d * d).sum(-1), 0, 1)
            best[k : k + 2048] = np.linalg.norm(a + t[..., None] * d - q, axis=-1).min(axis=1)
        return best.max()

    return max(directed(dense(A), B), directed(dense(B), A))


class TestKeep:
    @pytest.mark.parametrize("name", NAMED)
    def test_staircase_covers_and_errors(self, name):
        domain, h = NAMED[name]
        res = grid(domain, size=h, boundary="keep")
        P = res.mesh.points
        quads = res.mesh.cells[0].data
        stair = shapely.union_all([shapely.Polygon(P[q]) for q in quads])
        coords = domain["coordinates"]
        dom = shapely.Polygon(coords[0], coords[1:])
        assert dom.difference(stair).area <= 1e-12 * dom.area  # covered
        # every kept cell meets the domain's interior
        assert all(shapely.Polygon(P[q]).intersection(dom).area > 0 for q in quads)
        assert res.stats["area_error"] == pytest.approx(stair.area - dom.area, rel=1e-9, abs=1e-12)
        brute = _brute_hausdorff(_segments_of(stair.boundary), _segments_of(dom.boundary), h / 256)
        assert res.stats["hausdorff"] == pytest.approx(brute, abs=h / 100)
        _interior_squares(res.mesh, h)


class TestBadInput:
    @pytest.mark.parametrize(
        "kw, loc, code",
        [
            ({"size": 1e-5}, ("size",), "too_many_cells"),
            ({"size": -1.0}, ("size",), "bad_parameter"),
            ({"size": float("nan")}, ("size",), "non_finite"),
            ({"angle": float("inf")}, ("angle",), "non_finite"),
            ({"boundary": "trim"}, ("boundary",), "bad_parameter"),
            ({"cells": "hex"}, ("cells",), "bad_parameter"),
            ({"origin": [0, "a"]}, ("origin",), "bad_parameter"),
            ({"max_cells": 0}, ("max_cells",), "bad_parameter"),
        ],
    )
    def test_bad_parameters(self, kw, loc, code):
        with pytest.raises(InputError) as err:
            grid(square_with_hole(), **kw)
        assert err.value.code == code
        assert tuple(err.value.errors[0]["loc"]) == loc

    @pytest.mark.parametrize(
        "rings, code",
        [
            ([[[0, 0], [1, 1], [1, 0], [0, 1]]], "self_intersection"),
            ([[[0, 0], [1, 0], [1, 0], [0, 1]]], "duplicate_point"),
            ([[[0, 0], [1, 0]]], "too_few_points"),
            ([[[0, 0], [1, 0], [2, 0]]], "zero_area"),
            ([[[0, 0], [1, 0], [0, float("nan")]]], "non_finite"),
            ([[[0, 0], [1, 0], [1, 1], [0, 1]], [[2, 2], [3, 2], [3, 3]]], "hole_outside"),
        ],
    )
    def test_bad_domain(self, rings, code):
        with pytest.raises(InputError) as err:
            grid({"type": "Polygon", "coordinates": rings}, size=0.1)
        assert err.value.code == code
        assert err.value.errors[0]["loc"][0] == "domain"

    @pytest.mark.parametrize("size", [0, 0.0, -1.0])
    def test_estimate_refuses_a_size_not_above_zero(self, size):
        """It divided by the size: 0 was a ZeroDivisionError, -1 a count of 4 cells."""
        from meshcore.grid import estimated_cells

        with pytest.raises(InputError) as err:
            estimated_cells(square_with_hole(), size=size)
        assert err.value.code == "bad_parameter"
        assert tuple(err.value.errors[0]["loc"]) == ("size",)

    def test_default_size_is_bounded(self):
        res = grid(square_with_hole(), max_cells=2000)
        assert res.stats["grid"][0] * res.stats["grid"][1] <= 2000
