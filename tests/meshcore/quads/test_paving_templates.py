"""Paving's closure templates (midpoint subdivision into grids): exact cover, one centre."""

from __future__ import annotations

import numpy as np

from meshcore.mesh.quality import quad_quality, signed_area
from meshcore.partition.kernel import strictly_convex_rows
from meshcore.quads.paving_fronts import _angles
from meshcore.quads.paving_templates import template


def polyline(corners: list, counts: list) -> np.ndarray:
    """The closed polygon through the corners, side i cut in counts[i] equal segments."""
    C = np.asarray(corners, float)
    out = []
    for i, n in enumerate(counts):
        a, b = C[i], C[(i + 1) % len(C)]
        t = np.arange(n)[:, None] / n
        out.append(a + t * (b - a))
    return np.concatenate(out)


def meshed(P: np.ndarray):
    loop = np.arange(len(P))
    res = template(P, loop, np.degrees(_angles(P, loop)))
    assert res is not None
    pts, quads = res
    Q = np.concatenate([P, pts])
    assert strictly_convex_rows(Q, quads).all()
    assert quad_quality(Q, quads).min() > 0
    x, y = P[:, 0], P[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    cells = signed_area(Q, quads, "quad")
    assert (cells > 0).all()
    assert np.isclose(cells.sum(), area, rtol=1e-12)
    e = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges, count = np.unique(e, axis=0, return_counts=True)
    assert count.max() == 2  # conforming
    boundary = edges[count == 1]
    assert len(boundary) == len(P) and boundary.max() < len(P)  # the polygon's edges only
    degree = np.bincount(edges.ravel(), minlength=len(Q))
    return Q, quads, degree[len(P) :]


def test_triangle_is_three_grids_around_one_centre():
    P = polyline([[0, 0], [1, 0], [0.5, 0.8]], [10, 12, 14])
    _, quads, inner = meshed(P)
    # spokes 18 - n: 8, 6, 4; patches n_i = s_{i-1} + s_{i+1}: 8 x 6, 6 x 4, 4 x 8
    assert len(quads) == 48 + 24 + 32
    assert np.count_nonzero(inner != 4) == 1 and np.count_nonzero(inner == 3) == 1


def test_rectangle_with_equal_opposite_counts_is_one_grid():
    P = polyline([[0, 0], [2, 0], [2, 1], [0, 1]], [12, 6, 12, 6])
    _, quads, inner = meshed(P)
    assert len(quads) == 72
    assert (inner == 4).all()


def test_counts_no_template_fits_are_left_to_the_partition():
    P = polyline([[0, 0], [3, 0], [3, 1], [0, 1]], [16, 2, 4, 2])
    loop = np.arange(len(P))
    assert template(P, loop, np.degrees(_angles(P, loop))) is None


def test_the_closure_takes_the_template_before_the_partition():
    # a front of 36 nodes with 3 corners: closed by the template, the partition not called
    from meshcore import parse_domain
    from meshcore.partition import size_map
    from meshcore.quads import paving_fronts

    P = polyline([[0, 0], [1, 0], [0.5, 0.8]], [10, 12, 14])
    sizes = size_map(parse_domain({"type": "Polygon", "coordinates": [P.tolist()]}), 0.1, None)
    none = np.zeros((0, 4), np.int64)
    Q, cells, stats, gone = paving_fronts._close(P, [np.arange(len(P))], sizes, "balanced", none)
    assert stats["templates"] == 1 and len(cells) == 104 and len(gone) == 0
    assert np.array_equal(Q[: len(P)], P)
