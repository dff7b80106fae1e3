"""The size map of ``tetrahedralize``: target edge lengths at scattered 3D points.

The control space of Remark 8.10 in 3D, as ``size_field`` is in 2D
(:mod:`meshcore.triangulation.refinement`): sizes given at scattered
points, interpolated linearly on *our* Delaunay tetrahedralization of those
points (:func:`meshcore.delaunay.kernel3d.delaunay3d`), the nearest given
value outside their convex hull (or everywhere when fewer than four points,
or all of them coplanar, span no tetrahedron). A query point is located by
a visibility walk whose every step is an exact ``orient3d`` sign, started
from a tetrahedron of the nearest field point; its barycentric weights are
then plain floating point (clipped to the tetrahedron): a value, not a
sign. With ``size`` given too, the smaller of the two holds everywhere.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.delaunay.kernel3d import delaunay3d
from meshcore.domain.planar import parse_size_field
from meshcore.errors import InputError
from meshcore.geometry.predicates import WORK_SIZE
from meshcore.geometry.predicates3d import orient3d_filtered


@njit(cache=True)
def _replaced_sign(P, tet, i, q, c, work):
    """orient3d of tetrahedron ``tet`` with its vertex ``i`` replaced by ``q`` (``c``: a
    (4, 3) scratch buffer)."""
    for k in range(4):
        for a in range(3):
            c[k, a] = q[a] if k == i else P[tet[k], a]
    return orient3d_filtered(
        c[0, 0], c[0, 1], c[0, 2], c[1, 0], c[1, 1], c[1, 2],
        c[2, 0], c[2, 1], c[2, 2], c[3, 0], c[3, 1], c[3, 2], work,
    )  # fmt: skip


@njit(cache=True)
def _locate(P, tetra, neighbors, start, Q, work):
    """The tetrahedron whose closure holds each query point (-1: outside the hull)."""
    out = np.empty(len(Q), np.int64)
    c = np.empty((4, 3))
    cap = 4 * len(tetra) + 8
    for j in range(len(Q)):
        t = start[j]
        q = Q[j]
        for _ in range(cap):
            moved = False
            for i in range(4):
                if _replaced_sign(P, tetra[t], i, q, c, work) < 0:
                    t = neighbors[t, i]
                    moved = True
                    break
            if not moved or t < 0:
                break
        out[j] = t
    return out


class SizeField3d:
    """Target edge lengths at scattered 3D points, interpolated (module docstring).

    Parameters
    ----------
    size_field : mapping or object
        ``{"points": [[x, y, z], ...], "values": [h, ...]}`` or an object with
        ``points`` and ``values``.
    Raises
    ------
    InputError
        Located at the bad point or value, as
        :func:`meshcore.domain.planar.parse_size_field`.
    """

    def __init__(self, size_field) -> None:
        self.points, self.values = parse_size_field(size_field, dim=3)
        self._tree = cKDTree(self.points)
        self._tets = None
        if len(self.points) >= 4:
            try:
                self._tets = delaunay3d(self.points)
            except InputError:  # coplanar field points: nearest value everywhere
                pass
        if self._tets is not None:
            tetra = self._tets.tetra
            self._first_tet = np.empty(len(self.points), dtype=np.int64)
            self._first_tet[tetra.ravel()] = np.repeat(np.arange(len(tetra)), 4)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """(k,) float64: the size at each of the points ``X`` (k, 3)."""
        X = np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 3)
        nearest = self._tree.query(X)[1]
        sizes = self.values[nearest]
        if self._tets is not None and len(X):
            P, tetra = self._tets.points, self._tets.tetra
            t = _locate(
                P, tetra, self._tets.neighbors, self._first_tet[nearest], X, np.empty(WORK_SIZE)
            )
            inside = np.flatnonzero(t >= 0)
            corners = P[tetra[t[inside]]]  # (k, 4, 3)

            def det(c):
                return np.einsum(
                    "ij,ij->i", c[:, 1] - c[:, 0], np.cross(c[:, 2] - c[:, 0], c[:, 3] - c[:, 0])
                )

            full = det(corners)
            weights = np.empty((len(inside), 4))
            with np.errstate(divide="ignore", invalid="ignore"):  # flat in float: nearest
                for i in range(4):
                    c = corners.copy()
                    c[:, i] = X[inside]
                    weights[:, i] = det(c) / full  # barycentric: signed volumes over the whole
                weights = np.clip(weights, 0.0, None)  # rounding just outside a face
                total = weights.sum(axis=1)
                ok = total > 0
            sizes[inside[ok]] = (
                np.einsum("ij,ij->i", weights[ok], self.values[tetra[t[inside[ok]]]]) / total[ok]
            )
        return sizes
