"""Length-weighted Laplacian smoothing of quad meshes that never inverts a cell.

Used by the direct quad methods (paving §8.5.1, recursive partition §8.7.2,
"a point relocation step"). Each sweep moves every free point to the mean of
its neighbours weighted by the edge lengths (Jacobi); a move is then undone
wherever the least quality (8.4) of the quads around the moved point would
drop, a quad that is not strictly convex (exact
:func:`~meshcore.geometry.predicates.orient2d`) counting as -1, until no
moved point sees a drop. Every quad that changed has a moved corner whose
least quality did not drop, so a sweep never inverts a cell nor lowers the
least quality of the mesh.
"""

from __future__ import annotations

import numpy as np

from meshcore.mesh.quality import quad_quality
from meshcore.partition.kernel import strictly_convex_rows

__all__ = ["SWEEPS", "boundary_edges", "boundary_points", "smooth_quads"]

#: Default number of sweeps.
SWEEPS = 8
_UNDO_ROUNDS = 20
_REPAIR_Q = 0.3  # quads below this quality get their free corners repaired one by one
_REPAIR_ROUNDS = 3
_REPAIR_STEPS = (1.0, 0.75, 0.5, 0.25)


def boundary_edges(cells: np.ndarray) -> np.ndarray:
    """(b, 2) int64: the edges of one cell only (the mesh's boundary), sorted pairs."""
    e = np.sort(np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    eu, cnt = np.unique(e, axis=0, return_counts=True)
    return eu[cnt == 1]


def boundary_points(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n,) bool: the points on an edge of one cell only (the mesh's boundary)."""
    out = np.zeros(len(points), bool)
    out[boundary_edges(cells).ravel()] = True
    return out


def smooth_quads(points: np.ndarray, quads: np.ndarray, fixed: np.ndarray, sweeps: int = SWEEPS):
    """Length-weighted Laplacian smoothing that never inverts nor lowers the least quality.

    Parameters
    ----------
    points : (n, 2) float64
    quads : (m, 4) int64, counter-clockwise, strictly convex
    fixed : (n,) bool
        Points that stay (the boundary).
    sweeps : int

    Returns
    -------
    points : (n, 2) float64
    undone : int
        Moves undone because the least quality around the point would drop
        (a quad not strictly convex, by the exact test, counting as -1).

    References
    ----------
    Methods text §8.5.1 (smoothing of paved meshes), §8.4.4 (8.4).
    """
    P = points.copy()
    e = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    e = np.unique(e, axis=0)
    a, b = np.concatenate([e[:, 0], e[:, 1]]), np.concatenate([e[:, 1], e[:, 0]])
    free = ~fixed
    undone = 0
    n = len(P)
    corner = quads.ravel()
    cell_of = np.repeat(np.arange(len(quads)), 4)
    for _ in range(sweeps):
        q_old = quad_quality(P, quads)
        local_old = np.full(n, np.inf)
        np.minimum.at(local_old, corner, q_old[cell_of])
        w = np.hypot(*(P[b] - P[a]).T)
        sw = np.bincount(a, weights=w, minlength=n)
        tx = np.bincount(a, weights=w * P[b, 0], minlength=n)
        ty = np.bincount(a, weights=w * P[b, 1], minlength=n)
        target = P.copy()
        ok = free & (sw > 0)
        target[ok, 0] = tx[ok] / sw[ok]
        target[ok, 1] = ty[ok] / sw[ok]
        moved = ok.copy()
        for _ in range(_UNDO_ROUNDS):
            Q = np.where(moved[:, None], target, P)
            convex = strictly_convex_rows(Q, quads)
            q_new = np.where(convex, quad_quality(Q, quads), -1.0)
            local_new = np.full(n, np.inf)
            np.minimum.at(local_new, corner, q_new[cell_of])
            bad = moved & (local_new < local_old)
            if not bad.any():
                break
            undone += int(bad.sum())
            moved &= ~bad
        else:
            moved[:] = False
        P = np.where(moved[:, None], target, P)
    P = _repair(P, quads, free)
    return P, undone


def _repair(P: np.ndarray, quads: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Point by point (the few free corners of quads below _REPAIR_Q): the best of a
    few positions between the point and the centre of its quads, kept when the least
    quality around it rises (exact convexity as in the sweeps)."""
    q = quad_quality(P, quads)
    order = np.argsort(quads.ravel(), kind="stable")
    flat = quads.ravel()[order]
    cells = np.repeat(np.arange(len(quads)), 4)[order]
    starts = np.searchsorted(flat, np.arange(len(P) + 1))
    for _ in range(_REPAIR_ROUNDS):
        bad = np.unique(quads[q < _REPAIR_Q])
        bad = bad[free[bad]]
        if len(bad) == 0:
            break
        for v in bad:  # sequential by nature (each move changes the next); few points
            around = cells[starts[v] : starts[v + 1]]
            centre = P[quads[around]].reshape(-1, 2).mean(axis=0)
            best, best_q = P[v].copy(), float(q[around].min())
            for t in _REPAIR_STEPS:
                old = P[v].copy()
                P[v] = (1 - t) * old + t * centre
                sub = quads[around]
                ok = strictly_convex_rows(P, sub).all()
                qq = float(quad_quality(P, sub).min()) if ok else -1.0
                P[v] = old
                if qq > best_q:
                    best, best_q = (1 - t) * old + t * centre, qq
            P[v] = best
            q[around] = quad_quality(P, quads[around])
    return P
