r"""Optimization of quad (and mixed quad-triangle) meshes: the operators of §8.4.3.

Operators, each applied where it raises the local quality (the least
quality of the cells it replaces, strictly) or, for those that rebuild a
hexagon, relaxes the vertex valences (below), and leaves every new cell valid
(planar: strictly convex by the exact
:func:`~meshcore.geometry.predicates.orient2d_filtered` at every corner, in a
compiled loop; on a
surface: the corner turns of :mod:`meshcore.mesh.quality`):

``valence2``
    An interior vertex held by two cells only is removed: two quads become
    one quad, a quad and a triangle one triangle.
``valence3``
    An interior vertex held by three quads is removed: their hexagon is
    split into two quads along one of its three main diagonals.
``collapse``
    A quad whose two opposite vertices are interior and held by three cells
    each is removed: the two vertices merge at their midpoint (the
    "doublet" collapse).
``swap``
    The edge between two quads is replaced by one of the two other
    connexions of their hexagon (edge swapping, Chapter 18 of the text).
``hexagon``
    Four quads around two adjacent interior valence-3 vertices (a
    six-sided set with two interior vertices, the next case of "a set of
    adjacent quads forming a six side polygon") become two quads.

``valence3``, ``swap`` and ``hexagon`` rebuild a hexagon as two quads and
take the split by the *topological* criterion of §8.4.3 first: the drop of
``sum |valence - ideal|`` over the hexagon's vertices and the vertices that
disappear (ideal 4 inside, the vertex's angle in right angles on the
boundary: "the relaxation of the degree of the internal vertices"), the new
quads staying valid and above ``swap_floor`` (and the mesh's least quality);
with valences unchanged, the split must raise the least quality.

``smooth``
    Laplacian smoothing of interior vertices, colour by colour (vertices of
    one colour share no cell, so every move is judged on its own cells): a
    move is undone when one of its cells turns invalid or drops below
    ``max(smooth_floor, least quality of the mesh)`` (a cell already below
    that may not drop at all). A whole pass is kept only when the mean
    quality of the mesh rises. So no cell inverts and the least quality
    never drops. (A per-vertex rule "the vertex's cells must improve" was
    measured to stall: 0.758 mean against 0.827 on a Gmsh mesh of 5k
    triangles, Gmsh's Blossom reaching 0.804.)

``lift``
    Last, once: every interior vertex of a cell under ``lift_below`` tries
    eight directions at two step lengths (a pattern search) and moves where
    the least quality of its cells rises most. Done once at the end because
    a higher least quality would hold the smoothing back.

Each sweep applies the operators in the order valence2, valence3, collapse,
hexagon, swap, smooth, a set of non-overlapping candidates at a time (best
gain first, by a compiled greedy selection); sweeps repeat until no
operator changes the topology or ``sweeps`` is reached; after the first,
``swap`` tries a pair without an irregular vertex (it can only raise the
quality) only next to a cell made since its last run: on Gmsh's meshes of
1k, 10k and 100k triangles no such pair swapped elsewhere, and the search
cost as much as in the first sweep (100k: swaps 1.25 -> 0.70 s CPU, the
same mesh; restricting the pairs near irregular vertices too lost 9 of 346
swaps there, mean 0.8606 -> 0.8601), and once a run has swapped nothing
a pair next to an irregular vertex too (the Gmsh meshes of 1k and 10k
triangles and the square with a hole: the same meshes, swaps 10k
45 -> 35 ms CPU). Then a longer
smoothing over every interior vertex (``final_smooth_passes``), then the
lift. Candidates are found
and rebuilt by compiled loops over configurations (numba), the edge and
incidence tables rebuilt by one compiled call each after an operator changes
the cells, and every quality and sign is evaluated vectorized by
:mod:`meshcore.mesh.quality` and the predicates, except on a planar mesh under
(8.4) without a metric: there compiled loops (:mod:`meshcore.quads.vertex_moves`:
the new cells of the operators in one call per run, only for the hexagon splits
their topological criterion allows; all the passes of one smoothing; one call per
round of the lift) evaluate cells with the same operations as
:func:`meshcore.mesh.quality.quad_quality` (a few cells per move, where a
vectorized call costs more than the cells), the exact convexity test only
where the quality is at most ``CONVEX_PROOF``. Configurations whose cells are
all above ``active_below`` are not smoothed. (The Python and numpy calls of the
sweeps were most of a small mesh's time: Gmsh's 1k-triangle mesh 11 -> 8 ms.)

Cost (``benchmarks/quads.py``, matching + optimize on Gmsh's 10k-triangle
mesh, CPU): 78 smoothing passes over about 4,400 vertices are 55-60 % of it
with the default 12 per sweep and 30 after. ``passes`` sets them:
:func:`~meshcore.quads.combination.combine` without ``all_quad`` asks 1, and 40
to 80 after as the mesh grows (mean / least 0.8559 / 0.599 against 0.8542 /
0.594 there, 0.7924 / 0.607 against 0.7920 / 0.601 at 1k triangles, the whole
call 203 -> 155 ms; 2 and 40: 0.8551, 3 and 40: 0.8544, 1 and 30: 0.8539; at
97k triangles 1 and 40 gave 0.8554 / 0.552 against 0.8602 / 0.526, 1 and 60
0.8596, 1 and 80 0.8623 / 0.552 in 4.0 against 4.7 s), the others keep the defaults
(issue 20's 40 stars, all-quad at size 0.1: mean 0.8265 with them, 0.8233
with 1 and 40; ``quad_medial``'s star 1 at 0.1: least 0.607 -> 0.606).
Measured and dropped, each lowering the mean quality: a looser stop for
the active set (``smooth_still`` 1e-2 / 3e-2: mean 0.848 / 0.842 against
0.854), fewer passes per sweep (6: 0.853; none and 40 final passes: 0.854,
but 0.787 against 0.792 at 1k triangles), over-relaxation (1.3 / 1.6: 0.853 / 0.846), and a jump
to the converged Laplacian positions (one sparse solve; most jumps were
refused by the quality floor: 0.853); a pass kept only when it raises the
mean by 1e-5 or 3e-5 (``smooth_gain``) stopped no pass earlier at 1k or 10k;
3 or 2 sweeps with those passes (1k: 0.7923 / 0.605, 0.7855; 10k: 0.8554, 0.8536).

Choices the text leaves open
----------------------------
* The measure is the combination's: (8.4)/(8.6) (``angle``, also for
  ``simplified``, which is about one diagonal only) or (8.8) (``shape``);
  triangles count with their shape ratio.
* A new diagonal that is already an edge of the mesh elsewhere would make
  the mesh non-conforming: such a split is not proposed.
* On a surface (points in 3D) only the operators that move no point apply
  (``valence2``, ``valence3``, ``swap``, ``hexagon``): a midpoint or a mean
  of surface points lies off the surface.
* Vertices on the boundary never move and are never removed.

References
----------
Methods text §8.4.3 (the operators and their acceptance by quality),
§8.4.4 ((8.4), (8.6), (8.8)); Chapter 18 (edge swapping, relaxation).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import numpy as np
from numba import njit

from meshcore.geometry.predicates import orient2d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import edge_keys, isin_ints, unique_ints
from meshcore.partition.smoothing import boundary_points
from meshcore.quads.relaxation import relax_quads
from meshcore.quads.vertex_moves import (
    _angle_quality_rows,
    _checked_rows,
    _colors,
    _edge_table,
    _incidence,
    _lift_round,
    _neighbour_csr,
    _smooth_order,
    _smooth_passes,
    _split_drops,
    _split_scores,
    _swap_pairs,
    _valid_planar,
    lift_corners,
)

__all__ = [
    "OPERATORS",
    "DomainMoves",
    "OptimizeResult",
    "corners_relaxed",
    "domain_moves",
    "lifted_least",
    "optimize_quads",
    "sliding_nodes",
]

OPERATORS = ("valence2", "valence3", "collapse", "swap", "hexagon", "smooth", "lift")


@dataclass(frozen=True)
class _Tolerances:
    #: Least rise of the local least quality for an operator to apply.
    gain: float = 1e-9
    #: Least rise of the mesh's mean quality for a smoothing pass to be kept.
    smooth_gain: float = 1e-12
    #: Only configurations holding a cell of lower quality are worked on
    #: (nearly perfect regions cannot gain and cost most of the time).
    active_below: float = 0.95
    #: Smoothing may lower a cell's quality (for a better mean) down to this
    #: floor but never below the mesh's least quality nor below its own
    #: quality when it is under the floor.
    smooth_floor: float = 0.4
    #: A swap that relaxes the valences may leave a cell this low (smoothing follows).
    swap_floor: float = 0.3
    #: Cells under this quality get their vertices moved to raise the least
    #: quality around them (the "lift" pattern search), in this many rounds.
    lift_below: float = 0.6
    lift_rounds: int = 6
    #: A smoothing move shorter than this times the vertex's distance to a
    #: neighbour leaves the neighbours out of the next pass.
    smooth_still: float = 1e-3
    #: Smoothing passes per sweep.
    smooth_passes: int = 12
    #: Smoothing passes after the last sweep (the topology settled), before the
    #: lift, over the vertices of cells under ``final_active_below`` (above 1:
    #: every interior vertex). Laplacian smoothing converges slowly: 12 passes
    #: per sweep leave mean quality on the table (97k triangles: 0.853 -> 0.861).
    final_smooth_passes: int = 30
    final_active_below: float = 1.01


TOL = _Tolerances()


@dataclass(frozen=True)
class OptimizeResult:
    """The optimized mesh, how many times each operator applied, the point renumbering."""

    mesh: Mesh
    operators: dict = field(default_factory=dict)
    #: (n,) int64: the new index of each input point, -1 for the removed ones.
    point_map: np.ndarray | None = None


# ----------------------------------------------------------------------------- cells
# All cells are rows of C (c, 4), a triangle with -1 in its last slot.


def _cell_quality(P, C, measure: str, metric) -> np.ndarray:
    """Quality of each row of C: the quad measure, or the triangle shape ratio."""
    if P.shape[1] == 2 and measure == "angle" and metric is None:
        return _angle_quality_rows(P, C)
    q = np.empty(len(C))
    tri = C[:, 3] < 0
    if tri.any():
        q[tri] = quality.triangle_shape(P, C[tri, :3])
    if (~tri).any():
        quads = C[~tri]
        if measure == "shape":
            q[~tri] = quality.quad_shape(P, quads, metric)
        else:
            q[~tri] = quality.quad_quality(P, quads, metric)
    return q


def _valid(P, C) -> np.ndarray:
    """Rows of C that are strictly convex (planar, exact) or of positive quality (surface)."""
    ok = np.ones(len(C), bool)
    if not len(C):
        return ok
    if P.shape[1] == 2:
        return _valid_planar(P, C)
    tri = C[:, 3] < 0
    t, q = np.flatnonzero(tri), np.flatnonzero(~tri)
    if len(t):
        ok[t] = quality.signed_area(P, C[t, :3]) > 0
    if len(q):
        ok[q] = quality.quad_quality(P, C[q]) > 0
    return ok


def _checked(P, C, measure: str, metric) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_cell_quality` and :func:`_valid` of the rows of C: planar (8.4) without a
    metric in one compiled loop, where a quality above ``CONVEX_PROOF`` proves strict
    convexity and the exact signs are taken for the other rows only."""
    if P.shape[1] == 2 and measure == "angle" and metric is None:
        return _checked_rows(P, C)
    return _cell_quality(P, C, measure, metric), _valid(P, C)


# ----------------------------------------------------------------------------- kernels
# Compiled loops over candidate configurations (each a handful of cells).


@njit(cache=True)
def _rotated(C, c, v, out):
    """Write cell c's vertices starting at v into out; return its size (0 if v is absent)."""
    nv = 4 if C[c, 3] >= 0 else 3
    for s in range(nv):
        if C[c, s] == v:
            for j in range(nv):
                out[j] = C[c, (s + j) % nv]
            return nv
    return 0


@njit(cache=True)
def _hexagons(C, sets):
    """Boundary cycle (6 vertices, in the cells' sense) of each set of cells, or -1 rows."""
    k = sets.shape[0]
    H = np.full((k, 6), -1, np.int64)
    src = np.empty(16, np.int64)
    dst = np.empty(16, np.int64)
    bs = np.empty(16, np.int64)
    bd = np.empty(16, np.int64)
    for i in range(k):
        ne = 0
        for j in range(sets.shape[1]):
            c = sets[i, j]
            if c < 0:
                continue
            nv = 4 if C[c, 3] >= 0 else 3
            for a in range(nv):
                src[ne] = C[c, a]
                dst[ne] = C[c, (a + 1) % nv]
                ne += 1
        nb = 0
        for e in range(ne):
            inner = False
            for f in range(ne):
                if src[f] == dst[e] and dst[f] == src[e]:
                    inner = True
                    break
            if not inner:
                if nb == 16:
                    break
                bs[nb] = src[e]
                bd[nb] = dst[e]
                nb += 1
        if nb != 6:
            continue
        cur = bs[0]
        ok = True
        for step in range(6):
            H[i, step] = cur
            nxt = -1
            for e in range(6):
                if bs[e] == cur:
                    nxt = bd[e]
            if nxt < 0:
                ok = False
                break
            cur = nxt
        if not ok or cur != bs[0]:
            H[i, 0] = -1
            continue
        for a in range(6):
            for b in range(a + 1, 6):
                if H[i, a] == H[i, b]:
                    ok = False
        if not ok:
            H[i, 0] = -1
    return H


@njit(cache=True)
def _valence2(C, ptr, cells, verts):
    """Per interior valence-2 vertex: its two cells and the merged cell (-1 row if none)."""
    k = verts.shape[0]
    old = np.full((k, 2), -1, np.int64)
    new = np.full((k, 4), -1, np.int64)
    x = np.empty(4, np.int64)
    y = np.empty(4, np.int64)
    for i in range(k):
        v = verts[i]
        c0 = cells[ptr[v]]
        c1 = cells[ptr[v] + 1]
        if C[c0, 3] < 0:
            c0, c1 = c1, c0
        n0 = _rotated(C, c0, v, x)
        n1 = _rotated(C, c1, v, y)
        if n0 != 4:
            continue
        # x = (v, a, p, b); y = (v, b, q, a) or (v, b, a)
        a, b = x[1], x[3]
        if y[1] != b or y[n1 - 1] != a:
            continue
        old[i, 0] = c0
        old[i, 1] = c1
        if n1 == 4:
            new[i, 0], new[i, 1], new[i, 2], new[i, 3] = a, x[2], b, y[2]
        else:
            new[i, 0], new[i, 1], new[i, 2] = a, x[2], b
    return old, new


@njit(cache=True)
def _collapses(C, alive, ptr, cells, interior):
    """The quads with two opposite interior valence-3 vertices (corners 0 and 2 first,
    then 1 and 3, each in row order) whose two vertices' other cells are four distinct
    cells.

    Returns the five cells involved (the quad first), the four rebuilt cells and the
    two vertices (the first kept, the second merged into it).
    """
    quads = np.empty(2 * C.shape[0], np.int64)
    first = np.empty(2 * C.shape[0], np.int64)
    k = 0
    for f in range(2):
        for r in range(C.shape[0]):
            a, b = C[r, f], C[r, f + 2]
            if not alive[r] or C[r, 3] < 0 or not (interior[a] and interior[b]):
                continue
            if ptr[a + 1] - ptr[a] == 3 and ptr[b + 1] - ptr[b] == 3:
                quads[k], first[k] = r, f
                k += 1
    old = np.full((k, 5), -1, np.int64)
    new = np.full((k, 4, 4), -1, np.int64)
    pair = np.full((k, 2), -1, np.int64)
    for i in range(k):
        q = quads[i]
        v1 = C[q, first[i]]
        v2 = C[q, (first[i] + 2) % 4]
        old[i, 0] = q
        n = 1
        ok = True
        for v in (v1, v2):
            for j in range(ptr[v], ptr[v + 1]):
                c = cells[j]
                if c == q:
                    continue
                for s in range(n):
                    if old[i, s] == c:
                        ok = False  # v1 and v2 share another cell
                if n == 5:
                    ok = False
                    break
                old[i, n] = c
                n += 1
        if not ok or n != 5:
            old[i, 0] = -1
            continue
        for s in range(4):
            c = old[i, 1 + s]
            for j in range(4):
                u = C[c, j]
                new[i, s, j] = v1 if u == v2 else u
        pair[i, 0] = v1
        pair[i, 1] = v2
    ok = old[:, 0] >= 0
    return old[ok], new[ok], pair[ok]


@njit(cache=True)
def _select(gain, old, ncells):
    """Greedy set of candidates with disjoint cells, largest gain first."""
    order = np.argsort(-gain)
    taken = np.zeros(ncells, np.bool_)
    pick = np.zeros(gain.shape[0], np.bool_)
    for o in order:
        free = True
        for j in range(old.shape[1]):
            c = old[o, j]
            if c >= 0 and taken[c]:
                free = False
                break
        if not free:
            continue
        pick[o] = True
        for j in range(old.shape[1]):
            c = old[o, j]
            if c >= 0:
                taken[c] = True
    return pick


# ----------------------------------------------------------------------------- the optimizer


def _ideal_valence(P, C, interior) -> np.ndarray:
    """4 inside; on the boundary, the vertex's angle in right angles (at least 1)."""
    n = len(P)
    total = np.zeros(n)
    C = C[(~interior[C] & (C >= 0)).any(axis=1)]  # the angles of the boundary's cells only
    tri = C[:, 3] < 0
    for rows, k, cols in ((C[~tri], 4, 4), (C[tri, :3], 3, 3)):
        if not len(rows):
            continue
        ang = quality.cell_angles(P, rows, "quad" if k == 4 else "triangle")
        np.add.at(total, rows[:, :cols].ravel(), ang.ravel())
    ideal = np.maximum(np.rint(total / 90.0), 1).astype(np.int64)
    ideal[interior] = 4
    return ideal


class _State:
    """Points, cells and alive flags of the mesh being optimized."""

    def __init__(self, P, C, measure, metric, interior):
        self.ideal = _ideal_valence(P, C, interior)
        self.P = np.array(P, dtype=np.float64)  # moved in place from here on
        self.C = C
        self.alive = np.ones(len(C), bool)
        self.q = _cell_quality(P, C, measure, metric)
        self.measure = measure
        self.metric = metric
        self.interior = interior
        #: len(C) when the swaps last ran (None before the first sweep), and how many
        #: pairs they swapped
        self.swapped = None
        self.swaps = 0
        self._inc = self._edges = self._nbrs = None

    def incidence(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~meshcore.quads.vertex_moves._incidence` of the alive cells, kept until
        the cells change (most operator runs change nothing)."""
        if self._inc is None:
            self._inc = _incidence(self.C, self.alive, len(self.P))
        return self._inc

    def edges(self):
        """:func:`~meshcore.quads.vertex_moves._edge_table` of the alive cells ``(a, b,
        sorted keys, their cells, unique keys, first edges)``, kept until the cells change."""
        if self._edges is None:
            self._edges = _edge_table(self.C, self.alive, len(self.P))
        return self._edges

    def neighbours(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR vertex -> edge neighbours of the alive cells ``(nptr, nidx, degree)``,
        kept until the cells change."""
        if self._nbrs is None:
            a, b, _, _, _, first = self.edges()
            self._nbrs = _neighbour_csr(a, b, first, len(self.P))
        return self._nbrs

    def replace(self, old: np.ndarray, new: np.ndarray, newq: np.ndarray) -> None:
        old = old[old >= 0]
        self.alive[old] = False
        self._inc = self._edges = self._nbrs = None
        self.C = np.concatenate([self.C, new])
        self.alive = np.concatenate([self.alive, np.ones(len(new), bool)])
        self.q = np.concatenate([self.q, newq])


def _old_min(st: _State, old: np.ndarray) -> np.ndarray:
    qq = np.where(old >= 0, st.q[np.maximum(old, 0)], np.inf)
    return qq.min(axis=1)


def _hex_splits(st: _State, sets: np.ndarray, edge_keys: np.ndarray):
    """Best two-quad split of the hexagon of each cell set: (sets, new quads (k, 2, 4),
    gain, their qualities (k, 2)).

    The gain is first the drop of ``sum |valence - ideal|`` over the vertices
    whose valence the split changes (the "topological criterion" of §8.4.3,
    degrees relaxed towards 4, :func:`~meshcore.quads.vertex_moves._split_drops`), a
    split being allowed to lower the quality down to :func:`_floor`; then the rise of
    the least quality (:func:`~meshcore.quads.vertex_moves._split_scores`).
    """
    ptr, _ = st.incidence()
    H = _hexagons(st.C, sets)
    drop, rows = _split_drops(st.C, sets, H, edge_keys, len(st.P), ptr, st.ideal)
    # the cells of the allowed splits only are evaluated
    need = np.repeat(drop.ravel() >= 0, 2)
    q = np.zeros(len(rows))
    valid = np.zeros(len(rows), bool)
    q[need], valid[need] = _checked(st.P, rows[need], st.measure, st.metric)
    best, gain = _split_scores(sets, drop, q, valid, st.q, _floor(st, TOL.swap_floor))
    at = np.arange(len(sets))
    return sets, rows.reshape(-1, 3, 2, 4)[at, best], gain, q.reshape(-1, 3, 2)[at, best]


def _floor(st: _State, floor: float | None = None) -> float:
    """Lowest quality a relaxing change may leave a cell at: never below the mesh's least."""
    return max(float(st.q[st.alive].min()), TOL.smooth_floor if floor is None else floor)


def _apply_hex(st: _State, sets, new, gain, newq) -> int:
    good = gain > TOL.gain
    sets, new, gain, newq = sets[good], new[good], gain[good], newq[good]
    if not len(sets):
        return 0
    pick = _select(gain, sets, len(st.C))
    st.replace(sets[pick].ravel(), new[pick].reshape(-1, 4), newq[pick].ravel())
    return int(pick.sum())


def _op_valence2(st: _State) -> int:
    ptr, cells = st.incidence()
    val = np.diff(ptr)
    verts = np.flatnonzero((val == 2) & st.interior)
    if not len(verts):
        return 0
    old, new = _valence2(st.C, ptr, cells, verts)
    ok = old[:, 0] >= 0
    old, new = old[ok], new[ok]
    if not len(old):
        return 0
    q, valid = _checked(st.P, new, st.measure, st.metric)
    gain = np.where(valid, q - _old_min(st, old), -np.inf)
    good = gain > TOL.gain
    old, new, gain, q = old[good], new[good], gain[good], q[good]
    if not len(old):
        return 0
    pick = _select(gain, old, len(st.C))
    st.replace(old[pick].ravel(), new[pick], q[pick])
    return int(pick.sum())


def _valence3_vertices(st: _State, ptr, cells):
    val = np.diff(ptr)
    v = np.flatnonzero((val == 3) & st.interior)
    if not len(v):
        return v, np.zeros((0, 3), np.int64)
    sets = cells[ptr[v][:, None] + np.arange(3)]
    allquad = (st.C[sets, 3] >= 0).all(axis=1)
    return v[allquad], sets[allquad]


def _op_valence3(st: _State) -> int:
    ptr, cells = st.incidence()
    keys = st.edges()[4]
    _, sets = _valence3_vertices(st, ptr, cells)
    if not len(sets):
        return 0
    return _apply_hex(st, *_hex_splits(st, sets, keys))


def _op_hexagon(st: _State) -> int:
    n = len(st.P)
    ptr, cells = st.incidence()
    a, b, _, _, keys, _ = st.edges()
    v3, sets3 = _valence3_vertices(st, ptr, cells)
    if len(v3) < 2:
        return 0
    is3 = np.zeros(n, bool)
    is3[v3] = True
    row = np.full(n, -1, np.int64)
    row[v3] = np.arange(len(v3))
    e = np.flatnonzero(is3[a] & is3[b] & (a < b))
    if not len(e):
        return 0
    six = np.sort(np.concatenate([sets3[row[a[e]]], sets3[row[b[e]]]], axis=1), axis=1)
    dup = six[:, 1:] == six[:, :-1]
    ok = dup.sum(axis=1) == 2
    six, dup = six[ok], dup[ok]
    if not len(six):
        return 0
    keep = np.ones_like(six, bool)
    keep[:, 1:] &= ~dup
    sets = six[keep].reshape(-1, 4)
    return _apply_hex(st, *_hex_splits(st, sets, keys))


def _op_swap(st: _State) -> int:
    _, _, ks, cs, keys, _ = st.edges()
    ptr, _ = st.incidence()
    # a swap can only relax valences next to an irregular vertex, or lift a poor pair; a
    # later sweep: poor pairs only next to the cells made since the last run, and
    # irregular pairs only there too when that run swapped nothing
    since = -1 if st.swapped is None else st.swapped
    pairs = _swap_pairs(
        st.C, st.alive, ks, cs, ptr, st.ideal, st.q, TOL.active_below, since, not st.swaps
    )
    st.swapped = len(st.C)
    st.swaps = _apply_hex(st, *_hex_splits(st, pairs, keys)) if len(pairs) else 0
    return st.swaps


def _op_collapse(st: _State) -> int:
    ptr, cells = st.incidence()
    old, new, pair = _collapses(st.C, st.alive, ptr, cells, st.interior)
    if not len(old):
        return 0
    mid = 0.5 * (st.P[pair[:, 0]] + st.P[pair[:, 1]])
    # evaluate the four rebuilt cells with the merged vertex at the midpoint: the
    # midpoints are appended as temporary points
    base = len(st.P)
    tmp = np.arange(base, base + len(old))
    rows = new.copy()
    rows[rows == pair[:, 0][:, None, None]] = -2
    rows = np.where(rows == -2, tmp[:, None, None], rows)
    Pt = np.concatenate([st.P, mid])
    flat = rows.reshape(-1, 4)
    metric = _extended(st.metric, pair)
    q, valid = _checked(Pt, flat, st.measure, metric)
    q, valid = q.reshape(-1, 4), valid.reshape(-1, 4).all(axis=1)
    gain = np.where(valid, q.min(axis=1) - _old_min(st, old), -np.inf)
    good = gain > TOL.gain
    old, new, pair, mid, gain, q = old[good], new[good], pair[good], mid[good], gain[good], q[good]
    if not len(old):
        return 0
    # a vertex may be merged by one collapse only: two picked collapses never share a cell,
    # and each vertex's cells are all in its collapse, so the vertices are distinct too
    pick = _select(gain, old, len(st.C))
    old, new, pair, mid, q = old[pick], new[pick], pair[pick], mid[pick], q[pick]
    st.P[pair[:, 0]] = mid
    if st.metric is not None and np.ndim(st.metric) == 3:
        st.metric = st.metric.copy()
        st.metric[pair[:, 0]] = 0.5 * (st.metric[pair[:, 0]] + st.metric[pair[:, 1]])
    # the rebuilt cells' qualities are those evaluated at the midpoints (same points, and
    # the merged vertex's metric is the one _extended gave it)
    st.replace(old.ravel(), new.reshape(-1, 4), q.ravel())
    return int(pick.sum())


def _extended(metric, pair):
    if metric is None or np.ndim(metric) != 3:
        return metric
    return np.concatenate([metric, 0.5 * (metric[pair[:, 0]] + metric[pair[:, 1]])])


def _segments(ptr: np.ndarray, verts: np.ndarray):
    """Positions into a CSR array of the rows ``verts``: (index, segment starts, counts)."""
    cnt = ptr[verts + 1] - ptr[verts]
    starts = np.cumsum(cnt) - cnt
    idx = np.repeat(ptr[verts] - starts, cnt) + np.arange(cnt.sum())
    return idx, starts, cnt


def _targets(P: np.ndarray, verts, nptr, nidx) -> np.ndarray:
    """Laplacian targets: the mean of each vertex's edge neighbours (CSR ``nptr, nidx``)."""
    idx, starts, cnt = _segments(nptr, verts)
    return np.add.reduceat(P[nidx[idx]], starts, axis=0) / cnt[:, None]


def _op_lift(st: _State) -> int:
    """Move the vertices of the worst cells to raise the least quality around them.

    A pattern search (derivative free): each interior vertex of a cell under
    ``lift_below`` tries 8 directions at a step of a quarter, then a
    sixteenth, of its mean edge length, and takes the position with the
    best least quality of its cells when that beats the current one (and
    every cell stays valid). Colour by colour, so each move is judged alone.
    Under (8.4) without a metric (compiled) a round searches again only the
    vertices of the cells a move changed since their last search (the same
    search would find nothing else).
    Returns the vertices moved.
    """
    n = len(st.P)
    live = np.flatnonzero(st.alive)
    bad = live[st.q[live] < TOL.lift_below]
    if not len(bad) or st.P.shape[1] != 2:
        return 0
    verts = unique_ints(st.C[bad][st.C[bad] >= 0])
    verts = verts[st.interior[verts]]
    if not len(verts):
        return 0
    ptr, cells = st.incidence()
    movable = np.zeros(n, bool)
    movable[verts] = True
    color = _colors(st.C, ptr, cells, movable)
    ang = np.arange(8) * (np.pi / 4)
    dirs = np.tile(np.column_stack([np.cos(ang), np.sin(ang)]), (2, 1))
    steps = np.repeat([0.25, 0.0625], 8)  # times the mean edge length
    moved = np.zeros(n, bool)
    if st.measure == "angle" and st.metric is None:  # planar (8.4): one compiled loop per round
        order = verts[np.argsort(color[verts], kind="stable")]
        dirty = np.ones(n, bool)
        for _ in range(TOL.lift_rounds):
            args = (st.P, st.C, st.q, order, ptr, cells, dirs, steps, TOL.gain, moved, dirty)
            if not _lift_round(*args):
                break
        return int(moved.sum())
    for _ in range(TOL.lift_rounds):
        any_move = False
        for c in range(int(color[verts].max()) + 1):
            vs = verts[color[verts] == c]
            if not len(vs):
                continue
            cnt = ptr[vs + 1] - ptr[vs]
            pos = np.repeat(np.arange(len(vs)), cnt)
            idx = (
                np.repeat(ptr[vs], cnt)
                + np.arange(cnt.sum())
                - np.repeat(np.cumsum(cnt) - cnt, cnt)
            )
            cc = cells[idx]
            rows = st.C[cc]
            cur = np.full(len(vs), np.inf)
            np.minimum.at(cur, pos, st.q[cc])
            # mean length from the vertex to the other vertices of its cells
            other = np.where(rows >= 0, rows, vs[pos][:, None])
            dist = np.linalg.norm(st.P[other] - st.P[vs[pos]][:, None, :], axis=2).sum(axis=1)
            h = np.bincount(pos, weights=dist, minlength=len(vs)) / np.maximum(
                np.bincount(pos, weights=(rows >= 0).sum(axis=1) - 1, minlength=len(vs)), 1
            )
            best = cur.copy()
            here = st.P[vs]
            best_p = here.copy()
            # the 16 trial positions of every vertex appended as points, all judged in
            # one call: trial j of vertex i is point n + j * len(vs) + i
            trial = here[None] + (steps[:, None, None] * h[None, :, None]) * dirs[:, None, :]
            trial = trial.reshape(-1, 2)
            Pt = np.concatenate([st.P, trial])
            nt = len(steps)
            tid = (n + np.arange(nt)[:, None] * len(vs) + pos[None, :]).ravel()
            rows_t = np.tile(rows, (nt, 1))
            rows_t = np.where(rows_t == np.tile(vs[pos], nt)[:, None], tid[:, None], rows_t)
            mt = st.metric
            if mt is not None and np.ndim(mt) == 3:
                mt = np.concatenate([mt, np.tile(mt[vs], (nt, 1, 1))])
            nq = np.where(_valid(Pt, rows_t), _cell_quality(Pt, rows_t, st.measure, mt), -np.inf)
            ms = np.full(nt * len(vs), np.inf)
            np.minimum.at(ms, tid - n, nq)
            ms = ms.reshape(nt, len(vs))
            for j in range(nt):  # in the order of the trials: the first clear best wins
                better = ms[j] > best + TOL.gain
                best[better] = ms[j][better]
                best_p[better] = trial.reshape(nt, len(vs), 2)[j][better]
            win = best > cur + TOL.gain
            if not win.any():
                continue
            any_move = True
            st.P[vs[win]] = best_p[win]
            keep = win[pos]
            st.q[cc[keep]] = _cell_quality(st.P, rows[keep], st.measure, st.metric)
            moved[vs[win]] = True
        if not any_move:
            break
    return int(moved.sum())


def _op_smooth(st: _State, passes: int, below: float | None = None) -> int:
    """Smoothing passes by colours, each pass kept only when the mean quality rises.

    Vertices of one colour share no cell, so each move is judged on its own
    cells: it is undone when one of them turns invalid or drops below
    :func:`_floor` (cells already below keep at least their quality). A pass
    (every colour once) is kept only when the mean quality of the mesh
    rises; else it is undone and smoothing stops. After the first pass only
    the vertices that moved and their neighbours are tried again.
    """
    n = len(st.P)
    nptr, nidx, deg = st.neighbours()
    ptr, cells = st.incidence()
    below = TOL.active_below if below is None else below
    movable, color, order = _smooth_order(st.C, st.q, ptr, cells, st.interior, deg, below)
    if not len(order):  # nothing to move (an empty mesh: no least quality to keep)
        return 0
    live = np.flatnonzero(st.alive)
    moved = np.zeros(n, bool)  # kept moves, however small
    if st.P.shape[1] == 2 and st.measure == "angle" and st.metric is None:  # (8.4): compiled
        tol = (TOL.smooth_floor, TOL.smooth_still, TOL.smooth_gain)
        csr = (nptr, nidx, ptr, cells)
        _smooth_passes(st.P, st.C, st.q, live, order, movable, csr, passes, tol, moved)
        return int(moved.sum())
    by_color = np.split(order, np.flatnonzero(np.diff(color[order])) + 1)
    active = movable.copy()
    for _ in range(passes):
        P0, q0, mean0 = st.P.copy(), st.q.copy(), float(st.q[live].mean())
        floor = _floor(st)
        moved_now = np.zeros(n, bool)
        kept = np.zeros(n, bool)
        for verts in by_color:
            verts = verts[active[verts]]
            if not len(verts):
                continue
            target = _targets(st.P, verts, nptr, nidx)
            # the cells of these vertices, each listed once per vertex (no two share one)
            idx, starts, _ = _segments(ptr, verts)
            cc = cells[idx]
            rows = st.C[cc]
            old_q = st.q[cc]
            here = st.P[verts].copy()
            st.P[verts] = target  # tried in place, undone where refused
            new_q = _cell_quality(st.P, rows, st.measure, st.metric)
            new_q = np.where(_valid(st.P, rows), new_q, -np.inf)
            omin = np.minimum.reduceat(old_q, starts)
            nmin = np.minimum.reduceat(new_q, starts)
            pos = np.repeat(np.arange(len(verts)), np.diff(np.append(starts, len(cc))))
            ok = nmin >= np.minimum(omin, floor)
            st.P[verts[~ok]] = here[~ok]
            if not ok.any():
                continue
            keep = ok[pos]
            st.q[cc[keep]] = new_q[keep]
            kept[verts[ok]] = True
            # a move shorter than smooth_still times the distance to a neighbour does
            # not wake the neighbours up for the next pass
            step = np.linalg.norm(target - here, axis=1)
            far = np.linalg.norm(st.P[nidx[nptr[verts]]] - here, axis=1)
            moved_now[verts[ok & (step > TOL.smooth_still * far)]] = True
        if not float(st.q[live].mean()) > mean0 + TOL.smooth_gain:
            st.P, st.q = P0, q0
            break
        moved |= kept
        if not moved_now.any():
            break
        # next pass: only where something moved, or next to it
        mv = np.flatnonzero(moved_now)
        idx, _, _ = _segments(nptr, mv)
        active = np.zeros(n, bool)
        active[mv] = True
        active[nidx[idx]] = True
        active &= movable
    return int(moved.sum())


def optimize_quads(
    mesh: Mesh,
    *,
    measure: str = "angle",
    metric=None,
    sweeps: int = 4,
    passes: tuple[int, int] | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> OptimizeResult:
    """Improve a quad or mixed mesh by the operators of §8.4.3 and smoothing.

    Parameters
    ----------
    mesh : Mesh
        Quads and triangles, conforming, counter-clockwise in the plane (or
        consistently oriented on a surface); every cell valid.
    measure : {"angle", "simplified", "shape"}
        ``shape`` optimizes (8.8), the others (8.4)/(8.6).
    metric : (d, d) or (n, d, d) float64, optional
    sweeps : int
        Rounds of all operators at most.
    passes : (int, int), optional
        Smoothing passes per sweep and after the last sweep (None:
        ``smooth_passes`` and ``final_smooth_passes`` of the module's tolerances).
    progress : callable(fraction, message), optional

    Returns
    -------
    OptimizeResult
        The mesh (quads block, then triangles if any; unused points
        dropped) and per operator the number of applications (for
        ``smooth``: vertices moved).

    References
    ----------
    §8.4.3 (module docstring).
    """
    P = np.asarray(mesh.points, dtype=np.float64)
    n = len(P)
    blocks = mesh.cells_by_type
    quads = blocks.get("quad", np.zeros((0, 4), np.int64))
    tris = blocks.get("triangle", np.zeros((0, 3), np.int64))
    C = np.concatenate([quads, np.column_stack([tris, np.full(len(tris), -1)])]).astype(np.int64)
    if metric is not None and np.ndim(metric) == 2:
        metric = np.asarray(metric, dtype=np.float64)
    _, _, ks, _, _, _ = _edge_table(C, np.ones(len(C), bool), n)
    ukey, cnt = unique_ints(ks, counts=True)
    bkeys = ukey[cnt == 1]
    interior = np.ones(n, bool)
    interior[bkeys // n] = False
    interior[bkeys % n] = False
    used = np.zeros(n, bool)
    used[C[C >= 0]] = True
    interior &= used
    st = _State(P, C, "shape" if measure == "shape" else "angle", metric, interior)
    planar = P.shape[1] == 2
    per_sweep, final = (TOL.smooth_passes, TOL.final_smooth_passes) if passes is None else passes
    ops = dict.fromkeys(OPERATORS, 0)
    steps = [
        ("valence2", _op_valence2),
        ("valence3", _op_valence3),
        ("collapse", _op_collapse),
        ("hexagon", _op_hexagon),
        ("swap", _op_swap),
        ("smooth", partial(_op_smooth, passes=per_sweep)),
    ]
    for sweep in range(sweeps):
        changed = 0
        for i, (name, op) in enumerate(steps):
            if progress is not None:
                progress((sweep + i / len(steps)) / sweeps, f"optimization: {name}")
            if not planar and name in ("collapse", "smooth", "lift"):
                continue
            k = op(st)
            ops[name] += k
            if name not in ("smooth", "lift"):
                changed += k
                if k:  # removed vertices are no longer interior vertices of any cell
                    still = np.zeros(n, bool)
                    c = st.C[st.alive]
                    still[c[c >= 0]] = True
                    st.interior &= still
        if changed == 0:
            break
    # last, once: raising the worst cells raises the mesh's least quality, which would
    # then hold smoothing back (it never lets a cell under the least quality)
    if planar:
        if progress is not None:
            progress(0.96, "optimization: smooth")
        if final:
            ops["smooth"] += _op_smooth(st, final, TOL.final_active_below)
        if progress is not None:
            progress(0.98, "optimization: lift")
        ops["lift"] += _op_lift(st)
    C = st.C[st.alive]
    used = np.zeros(n, bool)
    used[C[C >= 0]] = True
    new = np.cumsum(used) - 1
    Cn = np.where(C >= 0, new[np.maximum(C, 0)], -1)
    tri = Cn[:, 3] < 0
    out = [CellBlock("quad", Cn[~tri])]
    if tri.any():
        out.append(CellBlock("triangle", Cn[tri, :3]))
    if progress is not None:
        progress(1.0, "optimization done")
    return OptimizeResult(Mesh(st.P[used], tuple(out)), ops, np.where(used, new, -1))


# ----------------------------------------------------------------------------- relaxation
# Simultaneous untangling and smoothing (Escobar et al. 2003): every quad corner
# contributes its condition number (|a|^2 + |b|^2) / (2 h(sigma)), a and b its two
# edges, sigma = a x b, with the regularized h(sigma) = (sigma + sqrt(sigma^2 +
# 4 delta^2)) / 2, which is positive for every sigma, so that a folded mesh has a
# finite energy (untangling) and a valid one the plain condition number as
# delta -> 0 (its minimum, 1, is a right angle between equal edges).


def _loops(C: np.ndarray, n: int) -> list[np.ndarray]:
    """The boundary loops of a quad mesh (vertex ids, counter-clockwise)."""
    a, b = C.ravel(), np.roll(C, -1, axis=1).ravel()
    key = edge_keys(a, b, n)
    uk, cnt = unique_ints(key, counts=True)
    once = isin_ints(key, uk[cnt == 1])
    nxt = np.full(n, -1, np.int64)
    nxt[a[once]] = b[once]
    seen = np.zeros(n, bool)
    loops = []
    for s in a[once]:
        if seen[s]:
            continue
        loop = [s]
        seen[s] = True
        v = nxt[s]
        while v != s and v >= 0 and not seen[v]:
            loop.append(v)
            seen[v] = True
            v = nxt[v]
        loops.append(np.array(loop, np.int64))
    return loops


def sliding_nodes(points: np.ndarray, quads: np.ndarray, fixed: np.ndarray, on_segments=False):
    """Boundary nodes that may slide along a straight piece of the boundary.

    Between two consecutive ``fixed`` nodes of a boundary loop, the nodes are
    free to slide on the segment joining those two when all of them lie on it
    (exact :func:`~meshcore.geometry.predicates.orient2d`); every other
    boundary node stays where it is. With ``on_segments`` (the caller knows that
    every input vertex is a fixed node and the boundary is the input's, so each
    such run lies on one input segment) every run slides without that test: its
    points were interpolated along the segment, on it only to rounding, so the
    exact test let few of them slide, and not the same ones once the input is
    translated or scaled.

    Parameters
    ----------
    points : (n, 2) float64
    quads : (q, 4) int
        Counter-clockwise, conforming.
    fixed : (n,) bool
        Nodes that never move (input vertices, corners of partition regions).

    Returns
    -------
    node, a, b : (s,) int64
        Node ``node[i]`` slides on the segment from ``a[i]`` to ``b[i]``.
    """
    P = np.asarray(points, np.float64)
    n = len(P)
    node, sa, sb = [], [], []
    for loop in _loops(np.asarray(quads, np.int64), n):
        at = np.flatnonzero(fixed[loop])
        if at.size == 0:
            continue
        loop = np.roll(loop, -at[0])
        at = np.append(at - at[0], len(loop))
        for i, j in zip(at[:-1], at[1:], strict=True):
            inner = loop[i + 1 : j]
            if not inner.size:
                continue
            a, b = loop[i], loop[j % len(loop)]
            if a == b:
                continue
            if on_segments or np.all(
                orient2d(
                    np.broadcast_to(P[a], (len(inner), 2)),
                    np.broadcast_to(P[b], (len(inner), 2)),
                    P[inner],
                )
                == 0
            ):
                node.append(inner)
                sa.append(np.full(len(inner), a))
                sb.append(np.full(len(inner), b))
    if not node:
        z = np.zeros(0, np.int64)
        return z, z, z
    return np.concatenate(node), np.concatenate(sa), np.concatenate(sb)


class DomainMoves(NamedTuple):
    """How the nodes of a domain's all-quad mesh may move (:func:`domain_moves`)."""

    #: (n,) bool: the input vertices and the nodes on interior constraints.
    fixed: np.ndarray
    #: (node, a, b): the other boundary nodes, sliding on their input segment.
    slide: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: (n,) bool: the mesh's boundary nodes.
    border: np.ndarray


def domain_moves(mesh: Mesh, dom) -> DomainMoves:
    """The fixed, sliding and boundary nodes of an all-quad mesh of ``dom`` (the input
    vertices first): the input vertices and the nodes on interior constraints fixed, the
    other boundary nodes sliding along their input segment (:func:`sliding_nodes` with
    ``on_segments``). Made once for :func:`corners_relaxed` and :func:`lifted_least`,
    which move no node off its segment nor change the cells.

    References
    ----------
    §8.4.3 (the smoothing of the optimization, boundary nodes kept on the boundary).
    """
    P = mesh.points
    Q = mesh.cells_by_type["quad"]
    fixed = np.zeros(len(P), bool)
    fixed[: len(dom.points)] = True  # the input vertices come first
    fixed[_on_constraints(P, unique_ints(Q.ravel()), dom)] = True
    return DomainMoves(fixed, sliding_nodes(P, Q, fixed, True), boundary_points(P, Q))


def corners_relaxed(
    mesh: Mesh, moves: DomainMoves, below: float, power: float, most: int, iterations: int
) -> tuple[Mesh, int]:
    """The all-quad mesh of a domain with its corner angles optimized
    (:func:`relax_quads` with ``angle_power`` ``power``) over the quads
    under quality ``below`` and their neighbours (none if more than
    ``most``; L-BFGS-B ``iterations`` at most), the nodes moving as ``moves``
    (:func:`domain_moves`). Kept (returns 1) when every quad stays strictly convex (exact)
    and the mean quality (8.4) rises while the least stays at or above the lower of
    its value and 0.5, to ``TOL.gain`` (a node sliding next to a sharp input corner
    changes that corner's quality by rounding)."""
    P = mesh.points
    Q = mesh.cells_by_type["quad"]
    q = quality.quad_quality(P, Q)
    bad = np.zeros(len(P), bool)
    bad[Q[q < below].ravel()] = True
    active = bad[Q].any(axis=1)
    if not active.any() or active.sum() > most:
        return mesh, 0
    new = relax_quads(
        P,
        Q,
        moves.fixed,
        slide=moves.slide,
        active=active,
        iterations=iterations,
        angle_power=power,
        border=moves.border,
    )
    if not _valid(new, Q).all():
        return mesh, 0
    q2 = quality.quad_quality(new, Q)
    if q2.mean() <= q.mean() or q2.min() < min(q.min(), 0.5) - TOL.gain:
        return mesh, 0
    return Mesh(new, mesh.cells), 1


def lifted_least(
    mesh: Mesh, moves: DomainMoves, judged: np.ndarray, below: float
) -> tuple[Mesh, int]:
    """The all-quad mesh of a domain with the least corner quality (8.3) of its ``judged``
    quads raised around those under ``below``
    (:func:`meshcore.quads.vertex_moves.lift_corners`), the nodes moving as ``moves``
    (:func:`domain_moves`). No judged quad falls under ``below`` nor, when
    under it already, at all, and no other quad falls (a spike's tip quad keeps its
    tip's quality, the worst corner it can have); every quad stays strictly convex.
    Returns (mesh, moves made).

    :func:`_op_lift` judges every quad of a node: a quad that no move can raise (one
    with an input corner of 22 degrees at a spike's tip) held the node next to it,
    and the quad beyond kept a 40-degree corner (issue 20's stars 6, 9, 20, 28 and 39
    at size 0.1, least quality away from the sharp corners 0.442-0.489 -> 0.500-0.558).
    """
    P = mesh.points
    Q = mesh.cells_by_type["quad"]
    new, made = lift_corners(
        P, Q, moves.fixed, moves.slide, judged, below, below, border=moves.border
    )
    if not made:
        return mesh, 0
    return Mesh(new, mesh.cells), made


def _on_constraints(P: np.ndarray, candidates: np.ndarray, dom) -> np.ndarray:
    """The ``candidates`` (node ids) lying on an interior constraint segment of
    ``dom`` (exact :func:`~meshcore.geometry.predicates.orient2d` and the
    segment's box): they may not move, or the constraint would bend."""
    hits = []
    X = P[candidates]
    for a, b in P[dom.constraints].tolist():  # a loop over the input constraints
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        near = np.flatnonzero(((X >= lo) & (X <= hi)).all(axis=1))
        if near.size:
            side = orient2d(
                np.broadcast_to(a, (near.size, 2)), np.broadcast_to(b, (near.size, 2)), X[near]
            )
            hits.append(candidates[near[side == 0]])
    return np.concatenate(hits) if hits else np.zeros(0, np.int64)
