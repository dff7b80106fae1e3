"""Params and run function of ``delaunay``: the Delaunay triangulation or tetrahedralization.

The params model refuses, with the field's location, what JSON Schema can
say (rows of 2 or 3 finite numbers); its :meth:`DelaunayParams.check` runs
the other checks before the job is queued: points of mixed dimensions
(naming the first odd one), too few points, duplicates (naming both
points), all points collinear (2D) or coplanar (3D), the last two with
exact predicates.

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

import time

import numpy as np
from pydantic import Field

from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import CellBlock, Mesh
from service.schemas import Coordinates, MethodParams, Progress


class DelaunayParams(MethodParams):
    """The Delaunay triangulation (2D) or tetrahedralization (3D) of a point set."""

    points: list[Coordinates] = Field(
        min_length=3,
        description="Distinct points, all [x, y] (triangles) or all [x, y, z] (tetrahedra); "
        "not all collinear (2D) or coplanar (3D).",
    )

    def point_count(self) -> int:
        return len(self.points)

    def array(self) -> np.ndarray:
        return np.asarray(self.points, dtype=np.float64)

    def check(self) -> None:
        super().check()
        d = len(self.points[0])
        bad = next((i for i, p in enumerate(self.points) if len(p) != d), None)
        if bad is not None:
            raise _error(
                f"every point must have the dimension of point 0 ({d}); point {bad} has "
                f"{len(self.points[bad])} coordinates",
                "mixed_dimensions",
                [bad],
            )
        check_points(self.array())


def _error(message: str, code: str, loc: list | None = None) -> InputError:
    return InputError(message, loc=["points", *(loc or [])], code=code)


def check_points(p: np.ndarray) -> None:
    """Exact checks of a point set for :func:`delaunay` / :func:`delaunay3d`.

    Raises
    ------
    InputError
        ``too_few_points``, ``duplicate_points`` (naming both points),
        ``collinear_points`` (2D) or ``coplanar_points`` (3D).
    """
    n, d = p.shape
    if n < d + 1:
        raise _error(
            f"a {'triangulation' if d == 2 else 'tetrahedralization'} needs at least "
            f"{d + 1} points, got {n}",
            "too_few_points",
        )
    order = np.lexsort(p.T[::-1])
    same = np.flatnonzero((p[order[1:]] == p[order[:-1]]).all(axis=1))
    if same.size:
        pairs = sorted(tuple(sorted((int(order[k]), int(order[k + 1])))) for k in same[:20])
        a, b = pairs[0]
        raise InputError(
            f"{same.size} duplicate point pair(s); first: points {a} and {b} coincide at "
            f"{p[a].tolist()}",
            code="duplicate_points",
            errors=[
                {
                    "loc": ["points", j],
                    "msg": f"point {j} duplicates point {i}",
                    "type": "duplicate_points",
                }
                for i, j in pairs
            ],
        )
    # Points are distinct: p[0] and p[1] span a line. The predicates see the
    # points scaled by a power of two (exact) so that no product overflows.
    big = float(np.abs(p).max())
    if big > 0.0:
        p = p * np.ldexp(1.0, -int(np.frexp(big)[1]))
    if d == 2:
        if not orient2d(p[0], p[1], p).any():
            raise _error(f"all {n} points are collinear: there is no triangle", "collinear_points")
        return
    off_line = np.zeros(n, bool)
    for u, v in ((0, 1), (1, 2), (2, 0)):
        off_line |= orient2d(p[0, [u, v]], p[1, [u, v]], p[:, [u, v]]) != 0
    if off_line.any():
        k = int(np.argmax(off_line))
        if orient3d(p[0], p[1], p[k], p).any():
            return
    raise _error(f"all {n} points are coplanar: there is no tetrahedron", "coplanar_points")


def run_delaunay(params: DelaunayParams, progress: Progress) -> dict:
    """The triangles or tetrahedra, the hull facets as cell set ``hull``, and counts."""
    from meshcore.delaunay import delaunay, delaunay3d

    p = params.array()
    t0 = time.perf_counter()
    if p.shape[1] == 2:
        tri = delaunay(p, progress=progress)
        seconds = time.perf_counter() - t0
        t, i = np.nonzero(tri.neighbors < 0)
        # The edge opposite corner i, counter-clockwise around the hull.
        hull = np.stack(
            [tri.triangles[t, (i + 1) % 3], tri.triangles[t, (i + 2) % 3]], axis=1
        ).astype(np.int64)
        cells, kind = tri.triangles, "triangle"
        facet_type = "line"
    else:
        tz = delaunay3d(p, progress=progress)
        seconds = time.perf_counter() - t0
        hull = tz.hull_facets
        cells, kind = tz.tetra, "tetra"
        facet_type = "triangle"
    mesh = Mesh(
        points=p,
        cells=(CellBlock(kind, cells), CellBlock(facet_type, hull)),
        cell_sets={
            "hull": [np.empty(0, np.int64), np.arange(len(hull), dtype=np.int64)],
        },
    )
    stats = {
        "points": int(len(p)),
        "triangles" if kind == "triangle" else "tetrahedra": int(len(cells)),
        "hull_facets": int(len(hull)),
        "seconds": round(seconds, 6),
    }
    return {"mesh": mesh, "stats": stats}


#: Five points of a square pyramid: the cube-like ties broken exactly.
DELAUNAY_EXAMPLE = {
    "points": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]],
}
