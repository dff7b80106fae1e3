"""Facets seeded at the size they end at, rather than split round after round.

Delaunay refinement splits an oversized subface at its circumcentre, and the
centres of one batch are kept ``separation`` times their radius apart
(:meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.crowded`): a facet far
larger than its size grows by about 1.5 times its points per round. The thin
plate's two large faces (1 x 1, refined to its size of about its 0.01
thickness) took about 20 such rounds, each retriangulating the facets and
inserting a batch in the kernel. :func:`seed_facets` puts the points of such
a facet (a thin one, ``refinement``'s feature size rule, whose largest
subface circumradius is above :data:`SEED_FAR` times the bound) in one batch
instead: a triangular lattice in its plane, of spacing
:data:`SPACING` times the facet's size, kept inside the facet (float sides of its input
triangles), :data:`MARGIN` spacings away from its boundary subsegments (so
that no point lies in a subsegment's diametral ball), out of the protecting
balls and cylinders (:mod:`meshcore.tets.angles`) and half a spacing away
from the points already in the facet. The refinement's rounds then only
finish the band along the boundary. Every point lies in the facet's plane
(its frame's origin is a facet vertex) up to rounding, as a circumcentre
does.

References
----------
Methods text §9.3.5 (new points on the surface); J. R. Shewchuk, "Tetrahedral
Mesh Generation by Delaunay Refinement" (SoCG 1998) for the subface bound.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from meshcore.delaunay.recovery3d import SurfaceRecovery, ball_pairs
from meshcore.geometry.constructions import point_segment_distance
from meshcore.mesh.topology import group_slots, unique_ints

__all__ = ["MARGIN", "SEED_FAR", "SPACING", "far_facets", "seed_facets"]

#: The lattice's spacing, as a fraction of the size (equilateral triangles of circumradius
#: 0.52 times the size, under the bound of 0.7): at the size itself, the tetrahedra between
#: the two faces of the 1 x 1 x 0.01 plate at size 0.0109 were above the size bound and
#: their centres encroached the lattice (14,574 more subface splits, then 6 recovery
#: rounds; 0.9: 420 splits, none).
SPACING = 0.9

#: A facet is seeded when its largest subface circumradius exceeds this times the bound.
SEED_FAR = 3.0
#: Lattice points closer than this times the spacing to a boundary subsegment are left out
#: (a subsegment is at most the size: its diametral ball, of radius at most 0.56 spacings,
#: holds none).
MARGIN = 0.75


def _lattice_shape(uv: np.ndarray, h: float) -> tuple[int, int]:
    """(points per row, rows) of the lattice of spacing ``h`` over the box of ``uv``."""
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    nu = int(min(math.floor((hi[0] - lo[0]) / h), 2**40)) + 2
    nv = int(min(math.floor((hi[1] - lo[1]) / (h * math.sqrt(3.0) / 2.0)), 2**40)) + 2
    return nu, nv


def _lattice(uv: np.ndarray, h: float, shape: tuple[int, int]) -> np.ndarray:
    """The points of the triangular lattice of spacing ``h`` (rows along u, every other
    row shifted by ``h / 2``) in the bounding box of ``uv``; ``shape`` its
    :func:`_lattice_shape`."""
    lo = uv.min(axis=0)
    dv = h * math.sqrt(3.0) / 2.0
    nu, nv = shape
    j, i = np.divmod(np.arange(nu * nv), nu)
    u = lo[0] + h * (i + 0.5 * (j % 2))
    v = lo[1] + dv * j
    return np.stack([u, v], 1)


def seed_facets(b: SurfaceRecovery, facets: np.ndarray, size: np.ndarray) -> int:
    """Add a triangular lattice of spacing ``SPACING`` times ``size`` (one per facet) to
    each facet of ``facets``; the number of points added.

    Points closer than ``MARGIN`` times the spacing to a boundary subsegment
    of the facet, or than half a spacing to a point already in the facet,
    are not added. The facets are retriangulated once
    (:meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.retriangulate`).
    None is added when the lattices would hold more points than the
    refinement may still add (``Knobs.max_points``): the rounds then reach
    that limit as before (a 1 x 1 x 1e-5 plate's lattice asked for 3e9).
    """
    origin, e1, e2 = b.frame
    corners_uv = []
    for f in facets.tolist():
        d = b.P[np.unique(b.facets[b.group_tris[f]])] - origin[f]
        corners_uv.append(np.stack([d @ e1[f], d @ e2[f]], 1))
    h_all = (SPACING * size).tolist()
    shapes = [_lattice_shape(uv, h) for uv, h in zip(corners_uv, h_all, strict=True)]
    if sum(nu * nv for nu, nv in shapes) > b.knobs.max_points - b.n:
        return 0
    X_all, f_all = [], []
    # The boundary subsegments and the points of each facet, grouped in one pass each.
    n_facets = len(b.group_tris)
    by_seg, seg_at = group_slots(b.edge_groups[b.seg_edge].T.reshape(-1), n_facets)
    by_pt, pt_at = group_slots(b.pt_facet, n_facets)
    for k, (f, h, cuv) in enumerate(zip(facets.tolist(), h_all, corners_uv, strict=True)):
        uv = _lattice(cuv, h, shapes[k])
        X = origin[f] + uv[:, :1] * e1[f] + uv[:, 1:] * e2[f]
        X = X[b.in_facet(X, np.full(len(X), f))]
        segs = unique_ints(by_seg[seg_at[f] : seg_at[f + 1]] % len(b.seg))
        if len(X) and segs.size:
            A, B = b.P[b.seg[segs, 0]], b.P[b.seg[segs, 1]]
            half = 0.5 * np.linalg.norm(B - A, axis=1)
            xi, si = ball_pairs(X, 0.5 * (A + B), half + MARGIN * h)
            close = point_segment_distance(X[xi], A[si], B[si])[0] < MARGIN * h
            X = np.delete(X, xi[close], axis=0)
        mine = by_pt[pt_at[f] : pt_at[f + 1]]
        if len(X) and mine.size:
            d, _ = cKDTree(b.P[mine]).query(X)
            X = X[d >= 0.5 * h]
        if len(X):
            X = X[(b.in_balls(X) < 0) & (b.in_cylinders(X) < 0)]
        X_all.append(X)
        f_all.append(np.full(len(X), f, dtype=np.int64))
    X = np.concatenate(X_all) if X_all else np.zeros((0, 3))
    if len(X) == 0:
        return 0
    ids = b.add(X, np.full(len(X), -1, dtype=np.int64), np.concatenate(f_all))
    b.retriangulate(np.asarray(facets, dtype=np.int64))
    return int((ids >= 0).sum())


def far_facets(b: SurfaceRecovery, bound: np.ndarray, seeded: np.ndarray) -> np.ndarray:
    """The facets not yet ``seeded`` (bool per facet) whose largest subface circumradius
    exceeds ``SEED_FAR`` times their ``bound`` (per facet, inf where none)."""
    candidate = ~seeded & np.isfinite(bound)
    if not candidate.any():
        return np.zeros(0, dtype=np.int64)
    _, r = b.sub_circles()
    largest = np.zeros(len(bound))
    np.maximum.at(largest, b.sub_facet, r)
    return np.flatnonzero(candidate & (largest > SEED_FAR * bound))
