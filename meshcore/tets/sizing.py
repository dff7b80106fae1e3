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

:func:`estimated_tetrahedra` says up front about how many tetrahedra a
``size``, ``max_volume`` or ``size_field`` asks for, so that a runaway request
is refused before it runs (as 2D's ``estimated_triangles``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.delaunay.kernel3d import delaunay3d
from meshcore.domain.planar import parse_size_field
from meshcore.domain.surface import as_surface
from meshcore.errors import InputError, positive_parameter
from meshcore.geometry.predicates import WORK_SIZE
from meshcore.geometry.predicates3d import orient3d_filtered

#: Largest estimate accepted: about the tetrahedra of the refinement's point limit
#: (``Knobs.max_points``, 300,000 points: 1.79-1.97M tetrahedra on a torus and a cube).
MAX_TETRAHEDRA = 1_500_000
#: Tetrahedra of a Delaunay-refined mesh per regular tetrahedron of the target edge that
#: fits in its volume: the icosphere of radius 1 at size 0.05 makes 450,149 tetrahedra
#: where its volume holds 282k regular ones (the 32 x 16 torus at 0.1: 257,840 for 159k).
_FILL = 1.6
#: Cells of the grid along the bounding box's longest side where a size field is averaged
#: for the estimate (at most 32**3 = 32,768 values).
_GRID_CELLS = 32


class Estimate(NamedTuple):
    """What :func:`estimated_tetrahedra` says of a request's bounds."""

    #: About how many tetrahedra the bounds together ask for (0 without bounds, at most 10**18).
    tetrahedra: int
    #: The bound that alone asks for the most ("size", "max_volume" or "size_field"; the first
    #: of equals in that order), the one to relax; None without bounds.
    binding: str | None


def estimated_tetrahedra(surface, *, size=None, max_volume=None, size_field=None) -> Estimate:
    """About how many tetrahedra ``tetrahedralize`` makes for these bounds, and which binds.

    Parameters
    ----------
    surface : Surface or dict
        As ``tetrahedralize``; its enclosed volume is what is filled.
    size, max_volume
        As ``tetrahedralize``: a target edge length (a regular tetrahedron of
        that edge has volume size**3 / (6 sqrt 2)), a largest tetrahedron
        volume.
    size_field : mapping or SizeField3d, optional
        As ``tetrahedralize``: target edge lengths at scattered points, here
        interpolated at the centres of the cells of a grid over the surface's
        bounding box, the smaller of them and ``size``, averaged as
        1 / size**3 (as 2D's ``estimated_triangles`` averages its field over
        the domain's box).

    Returns
    -------
    Estimate
        ``tetrahedra``: with several bounds the larger count; 0 when none is
        given (the mesh then follows the surface's own spacing); at most
        10**18. ``binding``: the bound whose count alone is the largest (the
        field's alone without ``size``). Meant for refusing runaway requests
        up front, naming the bound to relax (Remark 8.10's control space).

    Raises
    ------
    InputError
        A surface, bound or size field ``tetrahedralize`` refuses, located as
        there (a bound that is not a finite number above 0: ``bad_parameter``
        at its name).
    """
    surf = as_surface(surface)
    size, max_volume = (
        positive_parameter(size, "size"),
        positive_parameter(max_volume, "max_volume"),
    )
    alone = {}  # the tetrahedron volume each given bound asks for alone
    if size is not None:
        alone["size"] = _regular_volume(size)
    if max_volume is not None:
        alone["max_volume"] = max_volume
    together = dict(alone)
    if size_field is not None:
        H = _grid_sizes(surf, size_field)
        alone["size_field"] = _mean_volume(H)
        together.pop("size", None)  # with the field, the smaller of the two at each cell:
        together["size_field"] = (
            alone["size_field"] if size is None else _mean_volume(np.minimum(H, size))
        )
    if not alone:
        return Estimate(0, None)
    counts = {name: _count(surf, volume) for name, volume in alone.items()}
    return Estimate(_count(surf, min(together.values())), max(counts, key=counts.get))


def _count(surf, volume) -> int:
    """Tetrahedra of about ``volume`` filling the surface (at most 10**18; ``volume`` is 0
    where size**3 underflows)."""
    count = _FILL * surf.volume / volume if volume > 0 else math.inf
    return int(min(count, 1e18))


def _mean_volume(sizes: np.ndarray) -> float:
    """The harmonic mean of the volumes of regular tetrahedra of edges ``sizes``."""
    with np.errstate(divide="ignore"):  # 1 / 0 where size**3 underflows: 0 in _count
        return 1.0 / float(np.mean(1.0 / _regular_volume(sizes)))


def _regular_volume(size):
    """The volume of a regular tetrahedron of edge ``size`` (0 where size**3 underflows)."""
    return np.minimum(size, 1e100) ** 3 / (6.0 * math.sqrt(2.0))  # no overflow


def _grid_sizes(surf, size_field) -> np.ndarray:
    """The field's value at the centres of the cells of a grid over the surface's bounding
    box (32 along its longest side)."""
    field = size_field if isinstance(size_field, SizeField3d) else SizeField3d(size_field)
    P = surf.points[surf.vertices]
    lo, hi = P.min(axis=0), P.max(axis=0)
    step = (hi - lo).max() / _GRID_CELLS
    axes = [lo[k] + step * (np.arange(math.ceil((hi[k] - lo[k]) / step)) + 0.5) for k in range(3)]
    return field(np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3))


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
