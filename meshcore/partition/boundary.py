"""Size map and boundary discretization shared by the direct 2D methods.

:func:`size_map` turns ``size`` / ``size_field`` into the control space of
Remark 8.10 (a function ``h(x)`` read bilinearly from a grid);
:func:`resample_boundary` splits every ring segment of a
:class:`~meshcore.domain.planar.Domain` into pieces following ``h`` and, on
request, makes the number of pieces of every ring even (Remark 8.9: a
closed front of quads has an even number of sides).

Choices the text leaves open
----------------------------
* A scattered ``size_field`` is interpolated by inverse squared distance
  to its four nearest points, sampled on a grid of at most 256 cells a side
  over the domain's bounding box, ``size`` bounding it from above. (The
  triangulator interpolates linearly on a Delaunay triangulation; the grid
  is what the algorithms read in both cases.)
* A segment of length ``L`` gets ``max(1, round(I))`` pieces where ``I`` is
  the integral of ``1 / h`` along it, the points at equal steps of that
  integral.
* Parity repair: in a ring with an odd count, the segment whose pieces move
  least away from ``h`` (relative error) when given one piece more is split
  once more; ``repairs`` names the ring and the input segment.

References
----------
Methods text Remark 8.9 (even boundary count), Remark 8.10 (control space),
§8.7.2 (separators subdivided by the sizes at their ends).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import Domain, parse_size_field
from meshcore.errors import InputError, positive_parameter

__all__ = ["BoundaryResampling", "SizeMap", "resample_boundary", "size_map"]

_GRID_CELLS = 256
_SAMPLES = 16  # points per segment integrating 1 / h


@dataclass(frozen=True)
class SizeMap:
    """``h(x)``: ``H`` (ny, nx) on the grid ``[x0, y0, dx, dy]``; 1x1 means constant."""

    H: np.ndarray
    grid: np.ndarray

    @property
    def uniform(self) -> bool:
        return self.H.size == 1

    @property
    def smallest(self) -> float:
        return float(self.H.min())

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        if self.uniform:
            return np.full(len(xy), float(self.H[0, 0]))
        ny, nx = self.H.shape
        fx = np.clip((xy[:, 0] - self.grid[0]) / self.grid[2], 0.0, nx - 1.0)
        fy = np.clip((xy[:, 1] - self.grid[1]) / self.grid[3], 0.0, ny - 1.0)
        i = np.minimum(fx.astype(np.int64), nx - 2)
        j = np.minimum(fy.astype(np.int64), ny - 2)
        u, v = fx - i, fy - j
        H = self.H
        return (1 - v) * ((1 - u) * H[j, i] + u * H[j, i + 1]) + v * (
            (1 - u) * H[j + 1, i] + u * H[j + 1, i + 1]
        )


def size_map(domain: Domain, size=None, size_field=None) -> SizeMap:
    """The control space ``h(x)`` of Remark 8.10 from ``size`` and/or ``size_field``.

    Parameters
    ----------
    domain : Domain
    size : float, optional
        Target edge length (an upper bound when a field is given too).
    size_field : dict, optional
        ``{"points": (k, 2), "values": (k,)}``: target lengths at scattered
        points (inverse squared distance to the 4 nearest, module docstring).

    Returns
    -------
    SizeMap

    Raises
    ------
    InputError
        Neither given (``loc=("size",)``), or a bad value (``loc`` names it).

    References
    ----------
    Methods text Remark 8.10.
    """
    size = positive_parameter(size, "size")
    if size_field is None:
        if size is None:
            raise InputError("give size or size_field", loc=("size",), code="missing_size")
        return SizeMap(np.array([[size]]), np.zeros(4))
    fp, fv = parse_size_field(size_field)
    lo = domain.points.min(axis=0)
    ext = domain.points.max(axis=0) - lo
    step = float(ext.max()) / _GRID_CELLS
    nx = int(math.ceil(ext[0] / step)) + 1
    ny = int(math.ceil(ext[1] / step)) + 1
    X, Y = np.meshgrid(lo[0] + step * np.arange(nx), lo[1] + step * np.arange(ny))
    q = np.column_stack([X.ravel(), Y.ravel()])
    k = min(4, len(fp))
    d, idx = cKDTree(fp).query(q, k=k)
    d, idx = d.reshape(len(q), k), idx.reshape(len(q), k)
    exact = d[:, 0] == 0
    with np.errstate(divide="ignore", invalid="ignore"):  # exact hits: inf weights, set below
        w = 1.0 / d**2
        H = (w * fv[idx]).sum(axis=1) / w.sum(axis=1)
    H[exact] = fv[idx[exact, 0]]
    H = H.reshape(ny, nx)
    if size is not None:
        H = np.minimum(H, size)
    return SizeMap(H, np.array([lo[0], lo[1], step, step]))


@dataclass(frozen=True)
class BoundaryResampling:
    """The resampled rings.

    Attributes
    ----------
    points : (n, 2) float64
        The input ring vertices (first ``domain.boundary_point_count`` rows,
        same order) then the added boundary points.
    loops : list of (n_k,) int64
        Ring ``k`` as a cycle of point indices, domain on the left (outer
        rings counter-clockwise, holes clockwise).
    ring_polygon : (R,) int64
        The polygon of each ring (MultiPolygon part).
    repairs : list of dict
        ``{"ring": k, "segment": s}`` for each odd ring made even by one more
        split of its input segment ``s`` (index into ``domain.segments``).
    """

    points: np.ndarray
    loops: list
    ring_polygon: np.ndarray
    repairs: list


def _pieces(a: np.ndarray, b: np.ndarray, sizes: SizeMap) -> np.ndarray:
    """Integral of 1 / h along each segment (trapezoid rule, _SAMPLES points)."""
    s = np.linspace(0.0, 1.0, _SAMPLES)
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    if sizes.uniform:
        return length / float(sizes.H[0, 0])
    xy = a[:, None, :] + s[None, :, None] * d[:, None, :]
    inv = 1.0 / sizes(xy.reshape(-1, 2)).reshape(len(a), _SAMPLES)
    return length * (0.5 * (inv[:, 1:] + inv[:, :-1])).mean(axis=1)


def resample_boundary(domain: Domain, sizes: SizeMap, even: bool) -> BoundaryResampling:
    """Split every ring segment following ``h``; with ``even``, every ring even.

    Parameters
    ----------
    domain : Domain
        Constraint segments are not handled here (callers refuse them).
    sizes : SizeMap
    even : bool
        Make the number of pieces of every ring even (Remark 8.9).

    Returns
    -------
    BoundaryResampling
        Every input segment is a chain of the new pieces (points on it, in
        order).

    References
    ----------
    Methods text Remark 8.9, Remark 8.10; module docstring.
    """
    P = domain.points
    seg = domain.segments
    a, b = P[seg[:, 0]], P[seg[:, 1]]
    integral = _pieces(a, b, sizes)
    # rounded first: lengths equal up to rounding get equal counts after any scaling
    n = np.maximum(np.rint(np.round(integral, 7)), 1).astype(np.int64)
    repairs = []
    if even:
        for k in range(domain.ring_count):
            lo, hi = int(domain.ring_offsets[k]), int(domain.ring_offsets[k + 1])
            if int(n[lo:hi].sum()) % 2 == 0:
                continue
            t = integral[lo:hi]
            err_now = np.abs(t / n[lo:hi] - 1.0)
            err_new = np.abs(t / (n[lo:hi] + 1) - 1.0)
            s = lo + int(np.argmin(err_new - err_now))
            n[s] += 1
            repairs.append({"ring": k, "segment": s})
    # points at equal steps of the integral of 1/h (uniform steps for constant h)
    new_pts = []
    chains = []
    base = len(P)
    s_grid = np.linspace(0.0, 1.0, _SAMPLES)
    for s in range(len(seg)):
        m = int(n[s])
        if m == 1:
            chains.append(np.array([seg[s, 0]], np.int64))
            continue
        if sizes.uniform:
            t = np.arange(1, m) / m
        else:
            xy = a[s] + s_grid[:, None] * (b[s] - a[s])
            inv = 1.0 / sizes(xy)
            cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]))])
            t = np.interp(np.arange(1, m) / m * cum[-1], cum, s_grid)
        pts = a[s] + t[:, None] * (b[s] - a[s])
        ids = base + np.arange(m - 1)
        base += m - 1
        new_pts.append(pts)
        chains.append(np.concatenate([[seg[s, 0]], ids]).astype(np.int64))
    points = np.concatenate([P, *new_pts]) if new_pts else P.copy()
    loops = []
    for k in range(domain.ring_count):
        lo, hi = int(domain.ring_offsets[k]), int(domain.ring_offsets[k + 1])
        # follow the segments head to tail (a reversed ring lists them backwards)
        after = {int(seg[s, 0]): s for s in range(lo, hi)}
        order, s = [], lo
        for _ in range(hi - lo):
            order.append(s)
            s = after[int(seg[s, 1])]
        loops.append(np.concatenate([chains[s] for s in order]))
    return BoundaryResampling(points, loops, domain.ring_polygon.copy(), repairs)
