"""The tetrahedral part of :func:`meshcore.optimize.optimize` (§8.3.3-§8.3.4, Figure 8.11).

Correction and optimization of a tet mesh: on a tangled one, first the
barycentric move of :func:`.coupez.barycentric`; then the balls of the free
vertices (those not on the boundary) are the sub-topologies; the compiled pass is
:func:`meshcore.optimize.kernel3d.sweep`. Passes repeat until one changes
nothing or ``max_sweeps`` ran.

Generation from one closed surface (:func:`generate3d`): the initial
topology is Op(P, δ𝒮), P the surface vertex nearest the centroid of the
surface's vertices joined to every triangle not holding it. Then passes
(:func:`_loop3d`) of, in order, moves of free vertices, fans Op(Q, δ𝒮) on
the balls of all vertices, on edge shells, and (while a tet is not
positive) on larger sets around it: the tet and a face neighbour, the
shells of its edges replaced by their best triangulated ring (edge
removal), the union of the balls of an edge's ends, of its four vertices,
face-connected sets of 8 to 64 tets, the star cavities of existing
vertices near it, and with insertion star cavities of a new point G
(:mod:`.kernel3d`). Choices the text leaves open:

* Flat tets (four coplanar surface points, common on planar faces) add
  nothing to Sur, so (8.1) cannot see them: among configurations of equal
  Sur, fewer non-positive tets wins before the quality. A tet counts as
  flat, not positive, when its exact orient3d is positive but its volume is
  within the rounding that translating the input by 1e6 puts on it
  (``coupez.TOL.flat``; :func:`meshcore.mesh.tetstore.solid`), and Sur ties
  within that rounding too: four points of a planar quad make a flat tet
  wherever the input lies (at the origin rounding made them positive by
  1e-18, at 1e6 exactly zero), so where the input lies decides nothing.
  Centroids and kernel points are worked out relative to a vertex of the
  set, so that their rounding does not grow with the distance to the origin. A flat tet capping
  a planar surface quad is held by the shell of the quad's inner diagonal,
  whose ring has the quad's other diagonal as a side: no fan Op(q, δ𝒮) of
  that shell is positive, but a triangulation of its ring may be, and
  otherwise the star cavity of a vertex Z that sees the quad (every tet
  across a face of δ𝒮 that Z does not see positively joins 𝒮, so
  Op(Z, δ𝒮) is positive when the growth meets no surface face; the 6×6
  cube without insertion needed both).
* Restarts: when the first stage (and, with insertion, the G passes) ends
  stable but invalid, the generation starts again from Op(P', δ𝒮) with P'
  the next vertex by distance to the centroid (the text: "any point in δ𝒮
  could be used"), up to ``coupez.RESTARTS`` initial vertices; ``stats["restarts"]``
  lists the stuck ones. Some surfaces have no tetrahedralization of their
  points without flat tets (the 12×6 ring: its side quads are planar and
  their diagonals turn the same way round each section, as in Schönhardt's
  prism; TetGen -pY adds 11 points): without insertion they fail wherever
  they lie; with it, Op(G, δ𝒮) makes them.
* Stages: the first without insertion; with ``insert_points``, if tets are
  still not positive, the same passes where the larger sets may also take
  Op(G, δ𝒮) with G a new point seeing all of δ𝒮 (relaxation from the
  centroid), then rounds bisecting interior edges over ``size`` at their
  midpoint M (Op(M, δ𝒮), 𝒮 the edge's shell), each followed by the passes
  without insertion. Splitting a tet at its centroid would leave its long
  edges in place, so the edge is split instead; surface edges never are.

* Optimization stage (the third use, "possibly after an optimization
  stage", §8.3.2): the same passes once the mesh is valid, with the
  ``SLIVER`` kind of :func:`.kernel3d.fan_sweep` (face pairs and, with
  insertion, star cavities around tets under ``SLIVER_Q``), every
  replacement raising its set's worst quality: the least quality never
  drops.

The result is verified (every tet positive by the exact orient3d, and in
generation not flat either, a mesh topology, the boundary faces exactly the
input's) before it is returned; otherwise the job fails saying how many tets
are still inverted or flat and where. A given mesh (correction, optimization)
is judged by the exact orient3d alone: the flat rule below is generation's,
so a valid input mesh, however thin its tets, is never refused.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.mesh import tetstore as ts
from meshcore.optimize import coupez as _c
from meshcore.optimize import kernel3d as k3


@njit(cache=True)
def solid_tets(P, T, flat):
    """:func:`.tetstore.solid` of each tet of ``T`` (positive and not flat to ``flat``):
    the kernels' rule itself, so :func:`.coupez.signs` and the kernels agree at a tie."""
    out = np.empty(T.shape[0], np.bool_)
    for t in range(T.shape[0]):
        out[t] = ts.solid(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3], flat)
    return out


def optimize3d(mesh, P, T, bnd, total, allow_remove, measure, max_sweeps, progress):
    """Correct or optimize the tetrahedra ``T`` over points ``P`` (checked by the caller)."""
    if total < 0:  # every tet numbered the other way: normalized
        T = T[:, [0, 2, 1, 3]].copy()
        bnd = bnd[:, ::-1].copy()
    fixed = np.zeros(len(P), np.uint8)
    fixed[bnd.ravel()] = 1
    state = _c.LoopState(k3, P, T, fixed)
    inverted = state.inverted()
    use = "correction" if inverted else "optimization"
    q0 = float(_c.measure_q(P, T, _c.MEASURES[measure]).min())
    counters = np.zeros(3, np.int64)
    todo = np.ones(len(P), np.uint8)
    sur = [state.sur()]
    moved = [0]
    ops = {}
    if inverted:
        _c.barycentric(state, moved, sur, ops)
    sweeps = moved[0]
    for _ in range(max_sweeps):
        dirty = np.zeros(len(P), np.uint8)
        changed = k3.sweep(
            state.P, state.T, state.alive, state.head, state.nxt, state.prv, state.cnt,
            state.fixed, todo, dirty, allow_remove, measure, _c.TOL.sur_tie,
            _c.TOL.quality_gain, state.flat, counters,
        )  # fmt: skip
        todo |= dirty
        sweeps += 1
        sur.append(state.sur())
        if progress is not None:
            progress(sweeps / max_sweeps, f"pass {sweeps}")
        if not changed:
            break
    P, Tn = state.points(), state.cells()
    _c.verify(P, Tn, bnd, use, sweeps, state.flat)
    Pn, Tn, removed = _c.compact(P, Tn, 0)
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
            "barycentric_move": ops.get("barycentric_move", 0),
            "ball_move": int(counters[k3.C_MOVE]),
            "ball_kernel_move": int(counters[k3.C_KERNEL]),
            "ball_collapse": int(counters[k3.C_COLLAPSE]),
        },
        "least_quality_before": q0,
        "stages": 1,
    }
    return _c.make_result(Pn, Tn, measure, stats)


# ----------------------------------------------------------------------------- generation


def _loop3d(
    state, allow_remove, insert, measure, max_sweeps, sweeps, sur, ops, progress, frac, polish=False
):
    """Passes of the synthetic algorithm on tetrahedra until stable or ``max_sweeps``.

    A pass tries, in order, moves of free vertices (:func:`.kernel3d.sweep`),
    fans on vertex balls, fans on edge shells, then (while a tet is not
    positive) fans on larger sets around it, and with ``insert`` the new
    point G of Op(G, δ𝒮) there; with ``polish`` (the optimization stage),
    then the same sets around tets of quality under ``SLIVER_Q``, replaced
    only when their worst quality rises. It stops at the first kind that
    changed something.
    """
    cap = len(state.P)
    todo = np.ones(cap, np.uint8)
    todo_shell = np.ones(cap, np.uint8)
    counters = np.zeros(10, np.int64)
    kinds = ("move", k3.BALL, k3.SHELL, k3.UNION) + ((k3.SLIVER,) if polish else ())
    for _ in range(max_sweeps):
        changed = 0
        for kind in kinds:
            dirty = np.zeros(cap, np.uint8)
            if kind == "move":
                mark = todo.copy()
                changed = k3.sweep(
                    state.P, state.T, state.alive, state.head, state.nxt, state.prv,
                    state.cnt, state.fixed, mark, dirty, False, measure,
                    _c.TOL.sur_tie, _c.TOL.quality_gain, state.flat, counters,
                )  # fmt: skip
            else:
                if kind == k3.UNION and state.inverted() == 0:
                    continue
                mark = todo if kind == k3.BALL else todo_shell
                while True:
                    changed, status = k3.fan_sweep(
                        state.P, state.T, state.alive, state.head, state.nxt, state.prv,
                        state.free, state.cnt, state.fixed, mark, dirty, kind, allow_remove,
                        insert, measure, _c.TOL.sur_tie, _c.TOL.quality_gain, state.flat,
                        counters,
                    )  # fmt: skip
                    if status != 2:
                        break
                    if state.cnt[ts.N_PTS] >= len(state.P):
                        state.grow_points(len(state.P))
                        cap = len(state.P)
                        todo = np.ones(cap, np.uint8)
                        todo_shell = np.ones(cap, np.uint8)
                        dirty = np.zeros(cap, np.uint8)
                        mark = todo
                    state.grow_rows()
                    mark[:] = 1
                if kind == k3.SHELL:
                    todo_shell[:] = 0
            todo |= dirty
            todo_shell |= dirty
            if changed:
                break
        sweeps[0] += 1
        sur.append(state.sur())
        if progress is not None:
            progress(frac[0] + (frac[1] - frac[0]) * min(1.0, sweeps[0] / max_sweeps), "pass")
        if not changed:
            break
    for name, c in (
        ("ball_move", k3.C_MOVE),
        ("ball_kernel_move", k3.C_KERNEL),
        ("ball_fan", k3.C_BALL_FAN),
        ("shell_fan", k3.C_SHELL_FAN),
        ("union_fan", k3.C_UNION_FAN),
        ("sliver_fan", k3.C_SLIVER_FAN),
        ("inserted_g", k3.C_INSERT),
        ("closed_removed", k3.C_CLOSED),
        ("edge_removal", k3.C_REMOVAL),
    ):
        ops[name] = ops.get(name, 0) + int(counters[c])


def initial_topology(P: np.ndarray, F: np.ndarray, p: int) -> np.ndarray:
    """Op(P, δ𝒮) on a closed surface: vertex ``p`` joined to every outward triangle not
    holding it (§8.3.2, "Initialization"; Figure 8.11).

    A mesh topology (every face in one or two tets) whose boundary faces are
    exactly the surface's triangles and whose signed volumes add up to the
    enclosed volume; tets may be flat or inverted.
    """
    keep = ~(F == p).any(axis=1)
    f = F[keep]
    return np.column_stack([np.full(len(f), p), f]).astype(np.int64)


def initial_candidates(P: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The surface vertices by distance to the centroid of the surface's vertices, nearest
    first (near ties by index: :func:`.coupez.by_distance`): the P of Op(P, δ𝒮) and, in
    order, those of the restarts (§8.3.2, footnote: "any point in δ𝒮 could be used")."""
    verts = np.unique(F)
    return verts[_c.by_distance(P[verts], P[verts].mean(axis=0))]


def _long_edges(state, size):
    """The distinct edges of the live tets longer than ``size``, longest first (lengths equal
    to rounding in index order, :func:`.coupez.near_order`)."""
    T = state.cells()
    e = np.sort(T[:, ts.EDGES].reshape(-1, 2), axis=1)
    e = np.unique(e, axis=0)
    d = state.P[e[:, 0]] - state.P[e[:, 1]]
    length = np.sqrt(np.sum(d * d, axis=1))
    pick = length > size
    return np.ascontiguousarray(e[pick][_c.near_order(-length[pick])])


def _insert_stage3d(state, size, measure, max_sweeps, sweeps, sur, ops, progress, rounds):
    """Second stage (§8.3.3) in 3D: Op(M, δ𝒮) on the shells of interior edges over ``size``.

    A round bisects the interior edges longer than ``size`` at their midpoint
    M (longest first, none sharing a vertex with a shell already split in the
    round: 𝒮 is the edge's shell), then optimizes (moves of the new free
    points, fans); until none is split or ``rounds`` ran. Surface edges are
    never split (the boundary is kept). Returns the points inserted.
    """
    inserted = 0
    for _ in range(rounds):
        edges = _long_edges(state, size)
        if not len(edges):
            break
        n0 = int(state.cnt[ts.N_PTS])
        if len(state.P) < n0 + len(edges):
            state.grow_points(len(edges) + n0)
        if not ts.room(state.T, state.cnt, np.int64(8 * len(edges) + 64)):
            state.grow_rows(8 * len(edges))
        added = k3.insert_midpoints(
            state.P, state.T, state.alive, state.head, state.nxt, state.prv,
            state.free, state.cnt, state.fixed, edges, state.flat,
        )  # fmt: skip
        if added <= 0:
            break
        inserted += added
        _loop3d(state, False, False, measure, max_sweeps, sweeps, sur, ops, progress, (0.5, 0.95))
    return inserted


def generate3d(surface, insert, size, measure, max_sweeps, progress):
    """Tetrahedra of the volume a closed surface bounds (§8.3.3, Figure 8.11); see optimize."""
    F = surface.triangles
    verts = np.unique(F)
    Pall = surface.points
    # only the surface's vertices, renumbered
    new = np.full(len(Pall), -1, np.int64)
    new[verts] = np.arange(len(verts))
    P, S = Pall[verts], new[F]
    e = P[S] - P[np.roll(S, -1, axis=1)]
    h = float(size) if size is not None else float(np.median(np.sqrt(np.sum(e * e, axis=2))))
    bnd = S
    stages = 2 if insert else 1
    restarts = []
    for p in initial_candidates(P, S)[: _c.RESTARTS]:
        T = initial_topology(P, S, int(p))
        state = _c.LoopState(
            k3, P, T, np.ones(len(P), np.uint8), len(P) if insert else 0, _c.flatness(P)
        )
        inverted = state.inverted()
        q0 = float(_c.measure_q(P, T, _c.MEASURES[measure]).min())
        sweeps, sur, ops = [0], [state.sur()], {}
        _loop3d(state, False, False, measure, max_sweeps, sweeps, sur, ops, progress, (0.0, 0.4))
        if insert and state.inverted():  # stuck without points: Op(G, δ𝒮) around what is left
            _loop3d(state, False, True, measure, max_sweeps, sweeps, sur, ops, progress, (0.4, 0.5))
        left = state.inverted()
        if not left:
            break
        restarts.append({"vertex": int(p), "inverted": left, "sweeps": sweeps[0]})
    _c.verify(state.points(), state.cells(), bnd, "generation", sweeps[0], state.flat)
    if insert:
        _insert_stage3d(state, h, measure, max_sweeps, sweeps, sur, ops, progress, rounds=30)
        _c.verify(state.points(), state.cells(), bnd, "generation", sweeps[0], state.flat)
    # the optimization stage (§8.3.2, "possibly after an optimization stage"; the third use)
    q1 = float(_c.measure_q(state.points(), state.cells(), _c.MEASURES[measure]).min())
    frac = (0.95, 1.0)
    _loop3d(state, False, insert, measure, max_sweeps, sweeps, sur, ops, progress, frac, True)
    _c.verify(state.points(), state.cells(), bnd, "generation", sweeps[0], state.flat)
    Pn, Tn, _ = _c.compact(state.points(), state.cells(), len(P))  # G of a removed pillow
    stats = {
        "use": "generation",
        "sur": sur,
        "measure": float(surface.volume),
        "sweeps": sweeps[0],
        "inverted_before": inverted,
        "inverted_after": 0,
        "points_inserted": int(len(Pn) - len(P)),
        "points_removed": 0,
        "operators": ops,
        "least_quality_before": q0,
        "least_quality_before_optimization": q1,
        "stages": stages,
        "boundary_points": int(len(P)),
        "restarts": restarts,
    }
    return _c.make_result(Pn, Tn, measure, stats)
