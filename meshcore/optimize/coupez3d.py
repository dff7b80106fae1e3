"""The tetrahedral part of :func:`meshcore.optimize.optimize`: correction and optimization (§8.3.4).

The balls of the free vertices (those not on the boundary) are the
sub-topologies; the compiled pass is :func:`meshcore.optimize.kernel3d.sweep`.
Passes repeat until one changes nothing or ``max_sweeps`` ran; the result is
verified (every tet positive by the exact orient3d, a mesh topology, the
boundary faces exactly the input's) before it is returned.
"""

from __future__ import annotations

import numpy as np

from meshcore.geometry.predicates3d import orient3d
from meshcore.optimize import coupez as _c
from meshcore.optimize import kernel3d as k3


def _signs(P, T):
    return -orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], P[T[:, 3]])


def optimize3d(mesh, P, T, bnd, total, allow_remove, measure, max_sweeps, progress):
    """Correct or optimize the tetrahedra ``T`` over points ``P`` (checked by the caller)."""
    if total < 0:  # every tet numbered the other way: normalized
        T = T[:, [0, 2, 1, 3]].copy()
        bnd = bnd[:, ::-1].copy()
    n, m = len(P), len(T)
    P = P.copy()
    fixed = np.zeros(n, np.uint8)
    fixed[bnd.ravel()] = 1
    inverted = int(np.sum(_signs(P, T) <= 0))
    use = "correction" if inverted else "optimization"
    q0 = float(_c._measure_q(P, T, _c.MEASURES[measure]).min())
    Tw = T.copy()
    alive = np.ones(m, np.uint8)
    head = np.full(n, -1, np.int64)
    nxt = np.full(4 * m, -1, np.int64)
    prv = np.full(4 * m, -1, np.int64)
    k3.build(Tw, m, n, head, nxt, prv)
    cnt = np.array([n, m, 0, 0], np.int64)
    counters = np.zeros(3, np.int64)
    todo = np.ones(n, np.uint8)
    sur = [float(k3.sur(P, Tw, alive, m))]
    sweeps = 0
    for _ in range(max_sweeps):
        dirty = np.zeros(n, np.uint8)
        changed = k3.sweep(
            P,
            Tw,
            alive,
            head,
            nxt,
            prv,
            cnt,
            fixed,
            todo,
            dirty,
            allow_remove,
            measure,
            _c.TOL.sur_tie,
            _c.TOL.quality_gain,
            counters,
        )
        todo |= dirty
        sweeps += 1
        sur.append(float(k3.sur(P, Tw, alive, m)))
        if progress is not None:
            progress(sweeps / max_sweeps, f"pass {sweeps}")
        if not changed:
            break
    Tn = Tw[alive.astype(bool)]
    _c._verify(P, Tn, bnd, use, sweeps)
    Pn, Tn, removed = _c._compact(P, Tn, 0)
    stats = {
        "use": use,
        "sur": sur,
        "measure": abs(total),
        "sweeps": sweeps,
        "inverted_before": inverted,
        "inverted_after": 0,
        "points_inserted": 0,
        "points_removed": removed,
        "operators": {
            "ball_move": int(counters[k3.C_MOVE]),
            "ball_kernel_move": int(counters[k3.C_KERNEL]),
            "ball_collapse": int(counters[k3.C_COLLAPSE]),
        },
        "least_quality_before": q0,
        "stages": 1,
    }
    return _c._report(Pn, Tn, measure, stats)
