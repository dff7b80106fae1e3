"""Grid meshes of a planar domain: ``grid`` (§8.2).

A regular grid of squares of side ``size`` (placed by ``origin`` and
``angle``) is laid over the domain and, following the three steps of §8.2:

1. the cells that do not meet the domain are removed (exact tests);
2. the cells that meet the boundary are treated as ``boundary`` asks:

   ``keep``
       every cell whose open interior meets the domain's is kept whole: the
       staircase approximation ("the final mesh will only be a piecewise
       linear approximation of the given domain"). A cell meets the domain
       when a boundary segment meets its open interior (separating-axis test:
       strict box overlap and the cell's corners not all on one closed side of
       the segment, by :func:`~meshcore.geometry.predicates.orient2d`) or,
       crossed by none, when its centre is inside (scan-line parity). The
       kept cells cover the domain. ``stats`` gives the area difference and
       the Hausdorff distance between the staircase and the domain boundary.
   ``fit``
       the boundary cells are modified so that the mesh covers the domain
       exactly (below);
   ``split``
       as ``fit``, but the cut cells become triangles only;

3. the interior cells become mesh elements: perfect squares, or with
   ``cells="triangle"`` two right triangles (every quad split along the
   same diagonal, so the mesh stays conforming).

Fitting the boundary (``fit`` and ``split``)
--------------------------------------------
* **Core and band.** The *core* cells are the cells with four inside
  corners and no boundary or constraint segment within about 0.75 cell
  (every cell around a segment sample, samples half a cell apart, and its
  eight neighbours is "near"). They stay perfect squares. Where two core
  cells meet at a corner only, the cells around that node leave the core
  (its outline is then a set of simple loops). The near cells form the
  *band*.
* **Snapping.** A grid node of the band closer than ``0.2`` cell to the
  boundary is moved onto it: onto a domain vertex (a corner) when one is
  that close (at most one node can be: nodes are a cell apart), else onto
  its projection on the nearest segment (a node exactly on a segment stays
  where it is). Snapping removes the slivers a grid line passing just by a
  node would cut, and makes every crossing of a grid edge with the boundary
  at least 0.2 cell from that edge's nodes.
* **Cut cells.** The band's grid edges are split where they cross the
  boundary or a constraint (proper crossings by
  :func:`~meshcore.geometry.predicates.orient2d`, the point computed on
  the segment) and at domain vertices lying exactly on them; their pieces
  inside the domain (the side of an unsnapped node, else the exact ray
  parity of the midpoint) become constraints, the crossing and snap points
  are inserted into the boundary rings, and the band (the domain minus the
  core, a polygon with holes) is triangulated by
  :func:`meshcore.triangulation.refinement.triangulate` with
  ``empty=True, keep_boundary=True``: no point is added, every triangle lies
  in one cut cell (a *piece*: a grid cell intersected with the domain, its
  nodes possibly snapped). The core outline is a kept boundary of the band,
  so the two meshes share its nodes and edges.
* **Templates** (the configuration patterns of §8.2 step 3, by the
  piece's number of corners ``k``; with ``split`` every piece stays as
  its triangles)::

      whole      k = 4, the grid square itself         -> 1 quad (a square)
      quad       k = 4, strictly convex (snapped or cut) -> 1 quad
      concave    k = 4, not strictly convex             -> 2 triangles
      triangle   k = 3, a cut corner                    -> 1 triangle
      pentagon   k = 5, a corner cut off                -> 1 quad + 1 triangle
      polygon    k >= 6 (several crossings, a vertex)   -> quads and triangles

  Inside a piece, adjacent triangles are paired into strictly convex quads
  (exact orientation) whose scaled Jacobian is at least 0.5, greedily, best
  quad quality (8.4) first (a sequential loop, compiled): a pentagon gets
  its best quad, a polygon as many good quads as pairing finds; a pair
  failing the Jacobian bound stays two triangles (counted as ``concave``
  for a four-corner piece).

Guarantees (``fit``, ``split``): the cell areas sum to the domain's area
(up to rounding of the crossing points, relative 1e-12), every input
segment (boundary and constraint) is a chain of mesh edges, every input
vertex is a mesh vertex, every cell is counter-clockwise with positive area
(triangles from the exact constrained triangulation, quads checked strictly
convex by exact orientation), the mesh is conforming.

Choices the text leaves open
----------------------------
* **Size.** "A function of the smallest distance between two contour
  points ... and of available memory": by default the smallest distance
  between two boundary vertices, enlarged when the grid's bounding box would
  hold more than ``max_cells`` cells. A ``size`` given that would pass
  ``max_cells`` is refused with the estimate.
* **Placement.** ``origin`` (default the lower-left corner of the domain's
  bounding box) and ``angle`` (degrees, counter-clockwise). All decisions
  are made in the grid's frame, ``(x - origin) R(angle) / size``, where
  nodes have integer coordinates; a domain vertex keeps its input
  coordinates in the output, grid nodes are ``origin + size R (i, j)``,
  crossing and snap points are computed on their input segment.
* **Constraints** in ``keep`` mode are not represented (a cell is kept
  whole).
* **Default treatment**: ``fit``.

References
----------
Methods text §8.2 (steps 1-3, the configuration patterns of Chapters 17-18).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshcore.domain.planar import Domain, parse_domain, ray_parity
from meshcore.errors import AlgorithmError, InputError, as_number
from meshcore.geometry.constructions import point_segment_distance
from meshcore.geometry.predicates import orient2d
from meshcore.grid.band import outline_loops
from meshcore.limits import MAX_CELLS
from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.quality import quad_quality, triangle_shape
from meshcore.mesh.topology import edge_keys, isin_ints, unique_ints
from meshcore.triangulation.refinement import triangulate

__all__ = ["MAX_CELLS", "GridResult", "grid"]

Progress = Callable[[float, str], None] | None


TEMPLATES = ("whole", "quad", "concave", "triangle", "pentagon", "polygon")


@dataclass(frozen=True)
class _Tolerances:
    """Lengths in cell units (the grid's frame)."""

    #: Nodes closer than this to the boundary are snapped onto it.
    snap: float = 0.2
    #: Segment samples are this far apart (cells around them are "near").
    sample: float = 0.5
    #: Two triangles of a piece make a quad only if its scaled Jacobian reaches this.
    min_jacobian: float = 0.5
    #: Hausdorff distance (keep): boundaries sampled this finely.
    hausdorff_sample: float = 1.0 / 64.0


TOL = _Tolerances()


@dataclass(frozen=True, eq=False)
class GridResult:
    """What :func:`grid` returns.

    Attributes
    ----------
    mesh : Mesh
        2D points, a ``quad`` and/or a ``triangle`` block, counter-clockwise,
        cell sets ``interior`` (perfect squares, or their halves) and
        ``boundary`` (the rest).
    stats : dict
        Counts and figures (see :func:`grid`).
    timings : dict
        Seconds per phase.
    """

    mesh: Mesh
    stats: dict
    timings: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------


def _number(value, name: str) -> float:
    x = as_number(value, name)
    if not math.isfinite(x):
        raise InputError(f"{name} must be finite, got {value!r}", loc=(name,), code="non_finite")
    return x


def _choice(value, name: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise InputError(
            f"{name} must be one of {', '.join(allowed)}, got {value!r}",
            loc=(name,),
            code="bad_parameter",
        )
    return value


def _as_domain(domain) -> Domain:
    if isinstance(domain, Domain):
        return domain
    try:
        return parse_domain(domain)
    except InputError as exc:
        raise exc.prefixed("domain") from None


@dataclass(frozen=True)
class _Frame:
    """The grid's frame: ``u = (x - origin) R / h - shift``, nodes at integers."""

    origin: np.ndarray
    cos: float
    sin: float
    h: float
    shift: np.ndarray

    def local(self, p: np.ndarray) -> np.ndarray:
        d = p - self.origin
        u = (d[:, 0] * self.cos + d[:, 1] * self.sin) / self.h
        v = (-d[:, 0] * self.sin + d[:, 1] * self.cos) / self.h
        return np.column_stack([u - self.shift[0], v - self.shift[1]])

    def world(self, q: np.ndarray) -> np.ndarray:
        u = (q[:, 0] + self.shift[0]) * self.h
        v = (q[:, 1] + self.shift[1]) * self.h
        return np.column_stack(
            [
                self.origin[0] + u * self.cos - v * self.sin,
                self.origin[1] + u * self.sin + v * self.cos,
            ]
        )


def _smallest_distance(points: np.ndarray) -> float:
    d, _ = cKDTree(points).query(points, k=2)
    return float(d[:, 1].min())


def _extent(dom: Domain, origin, cos, sin, h):
    """Grid frame and node counts ``(nx + 1, ny + 1)`` for size ``h``."""
    d = dom.points - origin
    u = (d[:, 0] * cos + d[:, 1] * sin) / h
    v = (-d[:, 0] * sin + d[:, 1] * cos) / h
    i0, j0 = math.floor(u.min()) - 1, math.floor(v.min()) - 1
    nx = math.ceil(u.max()) + 1 - i0
    ny = math.ceil(v.max()) + 1 - j0
    return np.array([i0, j0], dtype=np.float64), nx, ny


def estimated_cells(domain, *, size=None, angle: float = 0.0) -> int:
    """Cells of the grid's bounding box for ``size`` (the default when None); a size not
    above 0 is an :class:`InputError` ``bad_parameter`` at ``size``."""
    dom = _as_domain(domain)
    a = math.radians(_number(angle, "angle"))
    h = _number(size, "size") if size is not None else _smallest_distance(dom.points)
    if h <= 0:  # 0 divided by zero below; below 0, a count of a negative extent
        raise InputError(f"size must be above 0, got {size!r}", loc=("size",), code="bad_parameter")
    pts = dom.points
    d = pts - pts.min(axis=0)
    u = d[:, 0] * math.cos(a) + d[:, 1] * math.sin(a)
    v = -d[:, 0] * math.sin(a) + d[:, 1] * math.cos(a)
    nx = (float(u.max() - u.min())) / h + 3
    ny = (float(v.max() - v.min())) / h + 3
    return int(min(nx * ny, 1e18))


# ---------------------------------------------------------------------------
# Scan lines and candidates
# ---------------------------------------------------------------------------


def _inside_rows(L: np.ndarray, seg: np.ndarray, nrow: int, ncol: int, off: float) -> np.ndarray:
    """(nrow, ncol) bool: point ``(i + off, j + off)`` strictly inside (even-odd).

    Crossings of the rows ``y = j + off`` with the segments (half-open in y,
    so a vertex on a row counts once); a point exactly on a crossing counts
    as outside. Decisions are float comparisons: callers only trust them
    away from the boundary.
    """
    a, b = L[seg[:, 0]], L[seg[:, 1]]
    lo = np.where((a[:, 1] <= b[:, 1])[:, None], a, b)
    hi = np.where((a[:, 1] <= b[:, 1])[:, None], b, a)
    r0 = np.ceil(lo[:, 1] - off).astype(np.int64)
    r1 = np.ceil(hi[:, 1] - off).astype(np.int64)  # rows r0 .. r1 - 1
    r0 = np.clip(r0, 0, nrow)
    r1 = np.clip(r1, 0, nrow)
    cnt = np.maximum(r1 - r0, 0)
    s = np.repeat(np.arange(len(seg)), cnt)
    row = r0[s] + (np.arange(len(s)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    y = row + off
    t = (y - lo[s, 1]) / (hi[s, 1] - lo[s, 1])
    x = lo[s, 0] + t * (hi[s, 0] - lo[s, 0]) - off
    order = np.lexsort((x, row))
    row, x = row[order], x[order]
    # consecutive pairs within a row are the inside intervals (even-odd)
    start = np.searchsorted(row, np.arange(nrow))
    rank = np.arange(len(row)) - start[row]
    first = rank % 2 == 0
    xa, xb, rr = x[first], x[np.flatnonzero(first) + 1], row[first]
    c0 = np.clip(np.floor(xa).astype(np.int64) + 1, 0, ncol)
    c1 = np.clip(np.ceil(xb).astype(np.int64), 0, ncol)
    ok = c1 > c0
    diff = np.zeros(nrow * (ncol + 1), dtype=np.int32)
    np.add.at(diff, rr[ok] * (ncol + 1) + c0[ok], 1)
    np.add.at(diff, rr[ok] * (ncol + 1) + c1[ok], -1)
    return (np.cumsum(diff.reshape(nrow, ncol + 1), axis=1)[:, :ncol]) > 0


def _samples(L: np.ndarray, seg: np.ndarray, step: float):
    """Points along each segment at most ``step`` apart: (k, 2) and their segment."""
    a, b = L[seg[:, 0]], L[seg[:, 1]]
    n = np.ceil(np.hypot(*(b - a).T) / step).astype(np.int64) + 1
    s = np.repeat(np.arange(len(seg)), n)
    k = np.arange(len(s)) - np.repeat(np.cumsum(n) - n, n)
    t = k / (n[s] - 1)
    return a[s] + t[:, None] * (b[s] - a[s]), s


def _cell_seg_pairs(L, seg, nx, ny, ring: int = 1):
    """Unique (cell, segment) pairs: cells within ``ring`` cells of a sample."""
    q, s = _samples(L, seg, TOL.sample)
    ci = np.floor(q[:, 0]).astype(np.int64)
    cj = np.floor(q[:, 1]).astype(np.int64)
    keys = []
    for di in range(-ring, ring + 1):
        for dj in range(-ring, ring + 1):
            i = np.clip(ci + di, 0, nx - 1)
            j = np.clip(cj + dj, 0, ny - 1)
            keys.append((j * nx + i) * len(seg) + s)
    key = unique_ints(np.concatenate(keys))
    return key // len(seg), key % len(seg)


def _open_cell_hits(L, seg, cells, segs, nx):
    """Whether segment ``segs[k]`` meets the open interior of cell ``cells[k]``."""
    i = (cells % nx).astype(np.float64)
    j = (cells // nx).astype(np.float64)
    a, b = L[seg[segs, 0]], L[seg[segs, 1]]
    box = (
        (np.maximum(a[:, 0], b[:, 0]) > i)
        & (np.minimum(a[:, 0], b[:, 0]) < i + 1)
        & (np.maximum(a[:, 1], b[:, 1]) > j)
        & (np.minimum(a[:, 1], b[:, 1]) < j + 1)
    )
    signs = np.stack(
        [
            orient2d(a, b, np.column_stack([i + di, j + dj]))
            for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1))
        ],
        axis=1,
    )
    split = ~((signs >= 0).all(axis=1) | (signs <= 0).all(axis=1))
    return box & split


# ---------------------------------------------------------------------------
# keep: the staircase
# ---------------------------------------------------------------------------


def _staircase(dom: Domain, L: np.ndarray, nx: int, ny: int) -> np.ndarray:
    """(ny, nx) bool: the cells whose open interior meets the domain's."""
    seg = dom.segments
    cells, segs = _cell_seg_pairs(L, seg, nx, ny, ring=1)
    hit = _open_cell_hits(L, seg, cells, segs, nx)
    crossed = np.zeros(nx * ny, dtype=bool)
    crossed[cells[hit]] = True
    centre = _inside_rows(L, seg, ny, nx, 0.5).ravel()
    return (crossed | centre).reshape(ny, nx)


def _outline_edges(mask: np.ndarray) -> np.ndarray:
    """Directed boundary edges of a cell set, the set on the left, as node pairs."""
    ny, nx = mask.shape
    m = np.zeros((ny + 2, nx + 2), dtype=bool)
    m[1:-1, 1:-1] = mask
    w = nx + 1

    def nid(i, j):
        return j * w + i

    out = []
    j, i = np.nonzero(mask & ~m[:-2, 1:-1])  # bottom
    out.append(np.column_stack([nid(i, j), nid(i + 1, j)]))
    j, i = np.nonzero(mask & ~m[2:, 1:-1])  # top
    out.append(np.column_stack([nid(i + 1, j + 1), nid(i, j + 1)]))
    j, i = np.nonzero(mask & ~m[1:-1, 2:])  # right
    out.append(np.column_stack([nid(i + 1, j), nid(i + 1, j + 1)]))
    j, i = np.nonzero(mask & ~m[1:-1, :-2])  # left
    out.append(np.column_stack([nid(i, j + 1), nid(i, j)]))
    return np.concatenate(out)


def _hausdorff(A: np.ndarray, B: np.ndarray, step: float) -> float:
    """Hausdorff distance between two segment sets (k, 2, 2), to within ``step / 2``.

    Each set is sampled every ``step`` at most; a sample's distance to the
    other set is that to the segment of the nearest sample of the other set,
    between the true distance and ``step / 2`` above it.
    """

    def sample(S):
        n = np.ceil(np.hypot(*(S[:, 1] - S[:, 0]).T) / step).astype(np.int64) + 1
        s = np.repeat(np.arange(len(S)), n)
        k = np.arange(len(s)) - np.repeat(np.cumsum(n) - n, n)
        t = (k / (n[s] - 1))[:, None]
        return S[s, 0] + t * (S[s, 1] - S[s, 0]), s

    def directed(P, S):
        q, owner = sample(S)
        _, nearest = cKDTree(q).query(P)
        s = owner[nearest]
        d, _ = point_segment_distance(P, S[s, 0], S[s, 1])
        return float(d.max())

    return max(directed(sample(A)[0], B), directed(sample(B)[0], A))


# ---------------------------------------------------------------------------
# fit / split: the band
# ---------------------------------------------------------------------------


def _drop_pinches(core: np.ndarray) -> int:
    """Remove core cells around nodes where two core cells meet at a corner only."""
    dropped = 0
    while True:
        a, b, c, d = core[:-1, :-1], core[:-1, 1:], core[1:, :-1], core[1:, 1:]
        pinch = (a & d & ~b & ~c) | (b & c & ~a & ~d)
        if not pinch.any():
            return dropped
        j, i = np.nonzero(pinch)
        for dj in (0, 1):
            for di in (0, 1):
                dropped += int(core[j + dj, i + di].sum())
                core[j + dj, i + di] = False


@njit(cache=True)
def _greedy_pairs(cand_a, cand_b, n_tri):  # pragma: no cover - compiled
    """Greedy matching over candidates given best first (inherently sequential)."""
    used = np.zeros(n_tri, dtype=np.bool_)
    take = np.zeros(len(cand_a), dtype=np.bool_)
    for k in range(len(cand_a)):
        a, b = cand_a[k], cand_b[k]
        if not used[a] and not used[b]:
            used[a] = True
            used[b] = True
            take[k] = True
    return take


def _fit(dom: Domain, frame: _Frame, L: np.ndarray, nx: int, ny: int, mode: str, cells: str):
    nx1 = nx + 1
    N = nx1 * (ny + 1)
    V = len(dom.points)
    nb = len(dom.segments)
    seg = np.concatenate([dom.segments, dom.constraints]).astype(np.int64)
    S = len(seg)
    timings: dict[str, float] = {}
    clock = time.process_time()

    def lap(name):
        nonlocal clock
        now = time.process_time()
        timings[name] = timings.get(name, 0.0) + now - clock
        clock = now

    # -- near cells, core ---------------------------------------------------
    cand_cell, cand_seg = _cell_seg_pairs(L, seg, nx, ny, ring=1)
    near = np.zeros(nx * ny, dtype=bool)
    near[cand_cell] = True
    inside = _inside_rows(L, dom.segments, ny + 1, nx1, 0.0)  # nodes
    core = inside[:-1, :-1] & inside[:-1, 1:] & inside[1:, :-1] & inside[1:, 1:]
    core &= ~near.reshape(ny, nx)
    _drop_pinches(core)
    band_cells = np.flatnonzero(~core.ravel() & near)
    lap("core")

    # -- snapping -----------------------------------------------------------
    q, qs = _samples(L, seg, TOL.sample)
    qc = np.floor(q[:, 1]).astype(np.int64) * nx1 + np.floor(q[:, 0]).astype(np.int64)
    key = unique_ints(
        np.concatenate([(qc + o) * S + qs for o in (0, 1, nx1, nx1 + 1)])
    )  # (node, segment) pairs: corners of the sample's cell
    pn, ps = key // S, key % S
    nodeL = np.column_stack([pn % nx1, pn // nx1]).astype(np.float64)
    a, b = L[seg[ps, 0]], L[seg[ps, 1]]
    dseg, tseg = point_segment_distance(nodeL, a, b)
    da = np.hypot(*(nodeL - a).T)
    db = np.hypot(*(nodeL - b).T)
    # vertex snaps first: the nearest vertex within TOL.snap
    dv = np.minimum(da, db)
    vid = np.where(da <= db, seg[ps, 0], seg[ps, 1])
    close_v = dv < TOL.snap
    snap_vertex = np.full(N, -1, dtype=np.int64)
    if close_v.any():
        o = np.lexsort((dv[close_v], pn[close_v]))
        nodes_v, vv = pn[close_v][o], vid[close_v][o]
        firstv = np.r_[True, nodes_v[1:] != nodes_v[:-1]]
        snap_vertex[nodes_v[firstv]] = vv[firstv]
    # segment snaps for the others
    close_s = (dseg < TOL.snap) & (snap_vertex[pn] < 0)
    snap_seg = np.full(N, -1, dtype=np.int64)
    snap_t = np.zeros(N)
    if close_s.any():
        o = np.lexsort((dseg[close_s], pn[close_s]))
        nodes_s = pn[close_s][o]
        firsts = np.r_[True, nodes_s[1:] != nodes_s[:-1]]
        chosen = np.flatnonzero(close_s)[o][firsts]
        snap_seg[pn[chosen]] = ps[chosen]
        snap_t[pn[chosen]] = tseg[chosen]
    vnodes = np.flatnonzero(snap_vertex >= 0)
    snodes = np.flatnonzero(snap_seg >= 0)
    # positions: exactly-on nodes stay, the others go to the projection
    sa, sb = L[seg[snap_seg[snodes], 0]], L[seg[snap_seg[snodes], 1]]
    nL = np.column_stack([snodes % nx1, snodes // nx1]).astype(np.float64)
    on = orient2d(sa, sb, nL) == 0
    tt = snap_t[snodes]
    projL = np.where(on[:, None], nL, sa + tt[:, None] * (sb - sa))
    PA, PB = dom.points[seg[snap_seg[snodes], 0]], dom.points[seg[snap_seg[snodes], 1]]
    projP = np.where(on[:, None], frame.world(nL), PA + tt[:, None] * (PB - PA))
    posL_arr = np.zeros((N, 2))  # only snapped rows used
    posL_arr[snodes] = projL
    lap("snap")

    # -- the global point table (grid frame and world) ----------------------
    alias = np.arange(N, dtype=np.int64)
    alias[vnodes] = N + snap_vertex[vnodes]
    snapped = np.zeros(N, dtype=bool)  # on the boundary now
    snapped[snodes] = True
    snapped[vnodes] = True
    moved = np.zeros(N, dtype=bool)  # snapped somewhere else than where it was
    moved[snodes] = ~on
    vL = np.column_stack([vnodes % nx1, vnodes // nx1]).astype(np.float64)
    moved[vnodes] = (L[snap_vertex[vnodes]] != vL).any(axis=1)
    extraL: list[np.ndarray] = []
    extraP: list[np.ndarray] = []
    n_extra = 0

    def coords_L(ids):
        ids = np.asarray(ids, dtype=np.int64)
        out = np.empty((len(ids), 2))
        g = ids < N
        gi = ids[g]
        base = np.column_stack([gi % nx1, gi // nx1]).astype(np.float64)
        sn = snap_seg[gi] >= 0
        base[sn] = posL_arr[gi[sn]]
        out[g] = base
        v = (ids >= N) & (ids < N + V)
        out[v] = L[ids[v] - N]
        e = ids >= N + V
        if e.any():
            allL = np.concatenate(extraL)
            out[e] = allL[ids[e] - N - V]
        return out

    # -- band edges and their splits -----------------------------------------
    bi, bj = band_cells % nx, band_cells // nx
    n00 = bj * nx1 + bi
    e_h = np.concatenate([n00, n00 + nx1])  # horizontal edges: (n, n + 1)
    e_v = np.concatenate([n00, n00 + 1])  # vertical edges: (n, n + nx1)
    edges = np.unique(
        np.concatenate([np.column_stack([e_h, e_h + 1]), np.column_stack([e_v, e_v + nx1])]),
        axis=0,
    )
    # drop the core outline's edges (they are rings of the band)
    core_out = _outline_edges(core)
    if len(core_out):
        ck = np.sort(core_out, axis=1)
        ekey = edge_keys(edges[:, 0], edges[:, 1], N)
        edges = edges[~isin_ints(ekey, edge_keys(ck[:, 0], ck[:, 1], N))]
    E = len(edges)
    # (edge, segment) candidates: the four edges of each candidate cell, found
    # in the sorted edge keys
    ekey = edge_keys(edges[:, 0], edges[:, 1], N)
    cc, cs = cand_cell, cand_seg
    ci, cj = cc % nx, cc // nx
    c00 = cj * nx1 + ci
    four = [
        (c00, c00 + 1),
        (c00 + nx1, c00 + nx1 + 1),
        (c00, c00 + nx1),
        (c00 + 1, c00 + nx1 + 1),
    ]
    pe, pseg = [], []
    for u0, u1 in four:
        k = edge_keys(u0, u1, N)
        pos = np.searchsorted(ekey, k)
        ok = (pos < E) & (ekey[np.minimum(pos, E - 1)] == k)
        pe.append(pos[ok])
        pseg.append(cs[ok])
    pe = np.concatenate(pe)
    pseg = np.concatenate(pseg)
    pk = unique_ints(pe * S + pseg)
    pe, pseg = pk // S, pk % S
    A = coords_L(alias[edges[pe, 0]])
    B = coords_L(alias[edges[pe, 1]])
    p, qv = L[seg[pseg, 0]], L[seg[pseg, 1]]
    # a snapped endpoint is on its segment (or vertex): no crossing with those
    excl = np.zeros(len(pe), dtype=bool)
    for end in (0, 1):
        nd = edges[pe, end]
        excl |= snap_seg[nd] == pseg
        sv = snap_vertex[nd]
        excl |= (sv >= 0) & ((seg[pseg, 0] == sv) | (seg[pseg, 1] == sv))
    o1 = orient2d(A, B, p).astype(np.int64)
    o2 = orient2d(A, B, qv).astype(np.int64)
    o3 = orient2d(p, qv, A).astype(np.int64)
    o4 = orient2d(p, qv, B).astype(np.int64)
    cross = (o1 * o2 < 0) & (o3 * o4 < 0) & ~excl
    d = B - A
    dd = np.einsum("ij,ij->i", d, d)

    def strictly_between(x, rows=slice(None)):
        t = np.einsum("ij,ij->i", x - A[rows], d[rows]) / dd[rows]
        return (t > 0) & (t < 1), t

    split_e, split_id, split_t = [], [], []
    for col, o in ((0, o1), (1, o2)):
        x = L[seg[pseg, col]]
        btw, t = strictly_between(x)
        ok = (o == 0) & btw & ~excl
        split_e.append(pe[ok])
        split_id.append(N + seg[pseg[ok], col])
        split_t.append(t[ok])
    # proper crossings: the point on the segment
    cr = np.flatnonzero(cross)
    den = (qv[cr, 0] - p[cr, 0]) * d[cr, 1] - (qv[cr, 1] - p[cr, 1]) * d[cr, 0]
    s_par = ((A[cr, 0] - p[cr, 0]) * d[cr, 1] - (A[cr, 1] - p[cr, 1]) * d[cr, 0]) / den
    s_par = np.clip(s_par, 0.0, 1.0)
    XL = p[cr] + s_par[:, None] * (qv[cr] - p[cr])
    PA, PB = dom.points[seg[pseg[cr], 0]], dom.points[seg[pseg[cr], 1]]
    XP = PA + s_par[:, None] * (PB - PA)
    x_ids = N + V + np.arange(len(cr))
    extraL.append(XL)
    extraP.append(XP)
    n_extra = len(cr)
    _, tx = strictly_between(XL, cr)
    split_e.append(pe[cr])
    split_id.append(x_ids)
    split_t.append(tx)
    split_e = np.concatenate(split_e)
    split_id = np.concatenate(split_id)
    split_t = np.concatenate(split_t)
    # dedupe (a vertex found through both its segments)
    if len(split_e):
        uk, first = unique_ints(split_e * (N + V + n_extra) + split_id, return_index=True)
        split_e, split_id, split_t = split_e[first], split_id[first], split_t[first]
    lap("crossings")

    # -- points on each segment: snaps, crossings -> augmented chains ---------
    on_seg = [snap_seg[snodes], pseg[cr]]
    on_id = [snodes, x_ids]
    on_t = [snap_t[snodes], s_par]
    on_seg = np.concatenate(on_seg)
    on_id = np.concatenate(on_id)
    on_t = np.concatenate(on_t)
    # projections of snapped nodes were clipped t in (0, 1) by construction
    o = np.lexsort((on_t, on_seg))
    on_seg, on_id, on_t = on_seg[o], on_id[o], on_t[o]
    seg_first = np.searchsorted(on_seg, np.arange(S + 1))

    def chain(s):
        """Ids along segment s from its start to its end."""
        lo, hi = seg_first[s], seg_first[s + 1]
        return [N + int(seg[s, 0]), *on_id[lo:hi].tolist()]

    # (id, segment) incidences: the ids lying on each segment
    inc_id = np.concatenate([on_id, N + seg[:, 0], N + seg[:, 1]])
    inc_seg = np.concatenate([on_seg, np.arange(S), np.arange(S)])
    inc_key = unique_ints(inc_id * S + inc_seg)

    # -- edge pieces -> constraints ------------------------------------------
    # per edge: [start, splits sorted by t, end]
    n_split = np.bincount(split_e, minlength=E)
    o = np.lexsort((split_t, split_e))
    split_e, split_id = split_e[o], split_id[o]
    # pieces: for each edge, consecutive ids of the sequence
    seq_len = n_split + 2
    seq_start = np.cumsum(seq_len) - seq_len
    seq = np.empty(int(seq_len.sum()), dtype=np.int64)
    seq[seq_start] = alias[edges[:, 0]]
    seq[seq_start + seq_len - 1] = alias[edges[:, 1]]
    inner_pos = np.repeat(seq_start + 1, n_split) + (
        np.arange(len(split_e)) - np.repeat(np.cumsum(n_split) - n_split, n_split)
    )
    seq[inner_pos] = split_id
    last = np.zeros(len(seq), dtype=bool)
    last[seq_start + seq_len - 1] = True
    ia = np.flatnonzero(~last)
    u0, u1 = seq[ia], seq[ia + 1]
    # inside: an unsnapped node end decides; two boundary ends: on a common
    # segment -> along the boundary (dropped), else the midpoint's parity
    is_node = lambda ids: (ids < N) & ~snapped[np.minimum(ids, N - 1)]  # noqa: E731
    node0, node1 = is_node(u0), is_node(u1)
    keep = np.zeros(len(u0), dtype=bool)
    flat_inside = inside.ravel()
    keep[node0] = flat_inside[u0[node0]]
    only1 = ~node0 & node1
    keep[only1] = flat_inside[u1[only1]]
    both = np.flatnonzero(~node0 & ~node1)
    if both.size:
        # ids on a common segment?
        def segs_of(ids):
            lo = np.searchsorted(inc_key, ids * S)
            hi = np.searchsorted(inc_key, ids * S + S)
            return lo, hi

        lo0, hi0 = segs_of(u0[both])
        common = np.zeros(len(both), dtype=bool)
        for k in range(int((hi0 - lo0).max()) if len(both) else 0):
            idx = lo0 + k
            valid = idx < hi0
            sid = inc_key[np.minimum(idx, len(inc_key) - 1)] % S
            kk = u1[both] * S + sid
            pos = np.searchsorted(inc_key, kk)
            hitk = (pos < len(inc_key)) & (inc_key[np.minimum(pos, len(inc_key) - 1)] == kk)
            common |= valid & hitk
        test = both[~common]
        if test.size:
            mid = 0.5 * (coords_L(u0[test]) + coords_L(u1[test]))
            rs = dom.segments
            rings = dom.segment_ring
            rows = ray_parity(
                mid,
                np.full(len(test), -1, dtype=np.int64),
                L[rs[:, 0]],
                L[rs[:, 1]],
                rings,
                dom.ring_count,
            )
            par = np.bincount(rows[:, 0], minlength=len(test)) % 2 == 1
            keep[test] = par
    cons = np.column_stack([u0[keep], u1[keep]])
    # chained along grid lines (fewer polylines for the domain check)
    pe_of = np.repeat(np.arange(E), seq_len - 1)[keep]
    n0 = edges[pe_of, 0]
    vertical = edges[pe_of, 1] - n0 != 1
    line_key = np.where(vertical, (n0 % nx1) * (ny + 1) + n0 // nx1, n0)
    order = np.lexsort((np.flatnonzero(keep), line_key, vertical))
    cons = cons[order]
    vertical = vertical[order]
    brk = np.r_[True, (cons[1:, 0] != cons[:-1, 1]) | (vertical[1:] != vertical[:-1])]
    run = np.cumsum(brk) - 1
    lap("pieces")

    # -- rings of the band ----------------------------------------------------
    rings_ids: list[np.ndarray] = []
    ring_outer: list[bool] = []
    for k in range(dom.ring_count):
        s0, s1 = int(dom.ring_offsets[k]), int(dom.ring_offsets[k + 1])
        order = range(s0, s1) if not dom.ring_reversed[k] else range(s1 - 1, s0 - 1, -1)
        ids = [x for s in order for x in chain(s)]
        rings_ids.append(np.array(ids, dtype=np.int64))
        ring_outer.append(not bool(dom.ring_is_hole[k]))
    if len(core_out):
        for loop in outline_loops(core_out, N):
            xy = np.column_stack([loop % nx1, loop // nx1]).astype(np.float64)
            area2 = float(
                np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
            )
            # core on the left: CCW = outer loop of the core = hole of the band
            rings_ids.append(loop[::-1])
            ring_outer.append(area2 < 0)
    constraint_lines = [chain(s) + [N + int(seg[s, 1])] for s in range(nb, S)]
    lines = (constraint_lines, cons, run)
    band_dom = _band_domain(rings_ids, ring_outer, lines, coords_L)
    lap("band rings")
    try:
        tri = triangulate(band_dom, empty=True, keep_boundary=True)
    except InputError as exc:  # pragma: no cover - a defect of the band's construction
        raise AlgorithmError(f"grid: the band between the core and the boundary: {exc}") from None
    lap("band triangulation")
    tp = tri.mesh.points
    if len(tp) != len(band_dom.points):
        raise AlgorithmError("grid: the band's triangulation added points")
    # band points -> global ids (by exact coordinates)
    all_ids = unique_ints(
        np.concatenate(
            [*rings_ids, cons.ravel(), *(np.asarray(c, dtype=np.int64) for c in constraint_lines)]
        )
    )
    gl = coords_L(all_ids)
    gid = _match_rows(tp, gl, all_ids)
    T = gid[tri.mesh.cells[0].data]
    # pieces: components across non-segment edges
    tdata = tri.mesh.cells[0].data
    nt = len(tdata)
    he = np.concatenate([tdata[:, [0, 1]], tdata[:, [1, 2]], tdata[:, [2, 0]]])
    owner = np.tile(np.arange(nt), 3)
    hk = np.minimum(he[:, 0], he[:, 1]) * len(tp) + np.maximum(he[:, 0], he[:, 1])
    sk = np.minimum(tri.segments[:, 0], tri.segments[:, 1]) * len(tp) + np.maximum(
        tri.segments[:, 0], tri.segments[:, 1]
    )
    free = ~isin_ints(hk, sk)
    o = np.argsort(hk[free], kind="stable")
    fk, fo, fe = hk[free][o], owner[free][o], np.flatnonzero(free)[o]
    pair = np.flatnonzero(fk[1:] == fk[:-1])
    ta, tb = fo[pair], fo[pair + 1]
    g = coo_matrix((np.ones(len(ta)), (ta, tb)), shape=(nt, nt))
    n_pieces, piece = connected_components(g, directed=False)
    ntri_piece = np.bincount(piece, minlength=n_pieces)
    lap("pieces")

    # -- templates: pair triangles of a piece into convex quads ----------------
    quads = np.zeros((0, 4), dtype=np.int64)
    tri_left = np.ones(nt, dtype=bool)
    if mode == "fit" and len(pair):
        # the quad of triangles ta, tb across their shared edge (x, y)
        sa_edge = he[fe[pair]]
        x, y = sa_edge[:, 0], sa_edge[:, 1]
        apex_a = tdata[ta].sum(axis=1) - x - y
        apex_b = tdata[tb].sum(axis=1) - x - y
        # in ta the edge runs x -> y or y -> x; orient the quad counter-clockwise
        ta_rows = tdata[ta]
        nxt_of_x = np.where(
            ta_rows[:, 0] == x,
            ta_rows[:, 1],
            np.where(ta_rows[:, 1] == x, ta_rows[:, 2], ta_rows[:, 0]),
        )
        fwd = nxt_of_x == y  # ta has x -> y, so tb has y -> x
        q4 = np.where(
            fwd[:, None],
            np.column_stack([apex_a, x, apex_b, y]),
            np.column_stack([apex_a, y, apex_b, x]),
        )
        P4 = tp[q4]
        convex = np.ones(len(q4), dtype=bool)
        for c in range(4):
            convex &= orient2d(P4[:, c], P4[:, (c + 1) % 4], P4[:, (c + 2) % 4]) > 0
        convex[convex] = _quad_jacobian(tp, q4[convex]) >= TOL.min_jacobian
        cand = np.flatnonzero(convex)
        qual = quad_quality(tp, q4[cand])
        order = cand[np.argsort(-qual, kind="stable")]
        take = _greedy_pairs(ta[order], tb[order], nt)
        chosen = order[take]
        quads = q4[chosen]
        tri_left[ta[chosen]] = False
        tri_left[tb[chosen]] = False
    band_quads = gid[quads]
    band_tris = T[tri_left]
    lap("templates")

    # template counts per piece (module docstring)
    corners = ntri_piece + 2
    merged_in = np.zeros(n_pieces, dtype=np.int64)
    if len(quads):
        merged_in = np.bincount(piece[ta[chosen]], minlength=n_pieces)
    four = corners == 4
    grid_only = np.ones(n_pieces, dtype=bool)  # every corner an unmoved grid node
    tv = T.ravel()
    np.logical_and.at(grid_only, np.repeat(piece, 3), (tv < N) & ~moved[np.minimum(tv, N - 1)])
    whole_piece = four & grid_only
    templates = {
        "whole": int(whole_piece.sum()),
        "quad": int((four & ~grid_only & ((merged_in == 1) | (mode == "split"))).sum()),
        "concave": int((four & ~grid_only & (merged_in == 0) & (mode == "fit")).sum()),
        "triangle": int((corners == 3).sum()),
        "pentagon": int((corners == 5).sum()),
        "polygon": int((corners >= 6).sum()),
    }
    if len(band_quads):
        gnode = (band_quads < N).all(axis=1)
        whole = gnode.copy()
        whole[gnode] = ~moved[band_quads[gnode]].any(axis=1)
    else:
        whole = np.zeros(0, dtype=bool)

    # -- assemble ----------------------------------------------------------
    if mode == "fit" and len(band_quads):
        extra_interior, boundary_q = band_quads[whole], band_quads[~whole]
    else:
        extra_interior, boundary_q = np.zeros((0, 4), np.int64), np.zeros((0, 4), np.int64)
    # used ids: the corners of the core cells (a dilation of the core mask), then the band's
    mask = np.zeros(N + V + n_extra, dtype=bool)
    nm = mask[:N].reshape(ny + 1, nx1)
    nm[:-1, :-1] |= core
    nm[:-1, 1:] |= core
    nm[1:, :-1] |= core
    nm[1:, 1:] |= core
    mask[band_quads.ravel()] = True
    mask[band_tris.ravel()] = True
    used = np.flatnonzero(mask)
    remap = np.full(N + V + n_extra, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    pts = np.empty((len(used), 2))
    g = used < N
    gi = used[g]
    gL = np.column_stack([gi % nx1, gi // nx1]).astype(np.float64)
    world = frame.world(gL)
    sn = snap_seg[gi] >= 0
    if sn.any():
        lookup = np.full(N, -1, dtype=np.int64)
        lookup[snodes] = np.arange(len(snodes))
        world[sn] = projP[lookup[gi[sn]]]
    pts[g] = world
    v = (used >= N) & (used < N + V)
    pts[v] = dom.points[used[v] - N]
    e = used >= N + V
    if e.any():
        pts[e] = np.concatenate(extraP)[used[e] - N - V]
    # the quads, interior first, written once into their final array
    cid = np.flatnonzero(core.ravel())
    c00 = cid + cid // nx  # cell (i, j) -> its node (i, j)
    n_core, n_extra_int = len(cid), len(extra_interior)
    quads_out = np.empty((n_core + n_extra_int + len(boundary_q), 4), dtype=np.int64)
    for c, off in enumerate((0, 1, nx1 + 1, nx1)):
        quads_out[:n_core, c] = remap[c00 + off]
    quads_out[n_core : n_core + n_extra_int] = remap[extra_interior]
    quads_out[n_core + n_extra_int :] = remap[boundary_q]
    band_tris = remap[band_tris]
    lap("assemble")
    stats = {
        "snapped_nodes": int(len(snodes) + len(vnodes)),
        "snapped_to_corners": int(len(vnodes)),
        "crossings": int(n_extra),
        "pieces": int(n_pieces),
        "templates": templates,
        "core_cells": int(core.sum()),
    }
    return pts, quads_out, n_core + n_extra_int, band_tris, stats, timings


def _used(ids: np.ndarray, n: int) -> np.ndarray:
    """The sorted distinct values of ``ids`` (all in ``[0, n)``), by a mask."""
    mask = np.zeros(n, dtype=bool)
    mask[ids.ravel()] = True
    return np.flatnonzero(mask)


def _match_rows(a: np.ndarray, b: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """For each row of ``a``, ``ids`` of the row of ``b`` with the same coordinates."""
    ka = np.ascontiguousarray(a).view(np.complex128).ravel()
    kb = np.ascontiguousarray(b).view(np.complex128).ravel()
    ob = np.argsort(kb)
    pos = np.searchsorted(kb[ob], ka)
    pos = np.minimum(pos, len(kb) - 1)
    if not (kb[ob][pos] == ka).all():  # pragma: no cover - a defect
        raise AlgorithmError("grid: a band point lost its identity")
    return ids[ob[pos]]


def _band_domain(rings_ids, ring_outer, lines, coords_L) -> Domain:
    """The band as a validated Domain: outer rings with the holes they contain."""
    outer = [k for k, o in enumerate(ring_outer) if o]
    holes = [k for k, o in enumerate(ring_outer) if not o]
    coords = [coords_L(r) for r in rings_ids]
    owner = {}
    if len(outer) > 1 and holes:
        segs0 = np.concatenate([c for k in outer for c in [coords[k]]])
        segs1 = np.concatenate([np.roll(coords[k], -1, axis=0) for k in outer])
        seg_ring = np.concatenate([np.full(len(coords[k]), i) for i, k in enumerate(outer)])
        q = np.array([coords[k][0] for k in holes])
        rows = ray_parity(
            q, np.full(len(q), -1, dtype=np.int64), segs0, segs1, seg_ring, len(outer)
        )
        areas = [abs(_shoelace(coords[k])) for k in outer]
        for h_i, r_i in rows.tolist():
            prev = owner.get(h_i)
            if prev is None or areas[r_i] < areas[prev]:
                owner[h_i] = r_i
    else:
        owner = {i: 0 for i in range(len(holes))}
    polys = [[coords[k].tolist()] for k in outer]
    for i, k in enumerate(holes):
        polys[owner[i]].append(coords[k].tolist())
    geometry = {"type": "MultiPolygon", "coordinates": polys}
    segments = [coords_L(np.asarray(line, dtype=np.int64)).tolist() for line in lines[0]]
    cons, run = lines[1], lines[2]
    if len(cons):
        starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
        # a run's ids: the first start, then every end
        ids = np.empty(len(cons) + len(starts), dtype=np.int64)
        slot = np.arange(len(cons)) + run + 1
        ids[slot] = cons[:, 1]
        ids[starts + np.arange(len(starts))] = cons[starts, 0]
        xy = coords_L(ids)
        bounds = starts + np.arange(len(starts))
        segments += [a for a in np.split(xy, bounds[1:])]
    try:
        return parse_domain(geometry, segments or None)
    except InputError as exc:
        raise AlgorithmError(
            f"grid: the band between the core and the boundary is invalid: {exc}"
        ) from None


def _shoelace(xy: np.ndarray) -> float:
    return 0.5 * float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))


# ---------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------


def _quad_jacobian(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Scaled Jacobian of planar quads: the least corner ``sin`` of the edge angle."""
    if len(quads) == 0:
        return np.zeros(0)
    P = points[quads]
    out = np.full(len(quads), np.inf)
    for c in range(4):
        e1 = P[:, (c + 1) % 4] - P[:, c]
        e2 = P[:, (c + 3) % 4] - P[:, c]
        cr = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        out = np.minimum(out, cr / (np.hypot(*e1.T) * np.hypot(*e2.T)))
    return out


def _split_quads(quads: np.ndarray) -> np.ndarray:
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def grid(
    domain,
    *,
    size: float | None = None,
    origin=None,
    angle: float = 0.0,
    boundary: str = "fit",
    cells: str = "quad",
    max_cells: int = MAX_CELLS,
    progress: Progress = None,
) -> GridResult:
    """Mesh a planar domain with a regular grid of squares (§8.2).

    Parameters
    ----------
    domain : Domain or dict
        A parsed domain (:func:`meshcore.domain.planar.parse_domain`, holes
        and constraints allowed) or its GeoJSON geometry.
    size : float, optional
        Cell side. Default: the smallest distance between two boundary
        vertices, enlarged to keep the grid's bounding box under ``max_cells``.
    origin : (2,) float, optional
        A grid node. Default: the lower-left corner of the domain's bounding box.
    angle : float
        Rotation of the grid, degrees counter-clockwise.
    boundary : {"keep", "fit", "split"}
        Treatment of the cells meeting the boundary (module docstring).
    cells : {"quad", "triangle"}
        Interior cells as squares, or each as two right triangles (fitted
        quads are split the same way).
    max_cells : int
        Largest number of cells of the grid's bounding box.
    progress : callable(fraction, message), optional

    Returns
    -------
    GridResult
        ``stats``: ``size``, ``cells`` (by kind: ``interior`` perfect
        squares or their halves, ``boundary`` the rest), ``quads``,
        ``triangles``, ``area`` and ``domain_area``; ``keep``: ``area_error``
        (mesh minus domain) and ``hausdorff`` (between the staircase and the
        domain boundary, sampled every 1/64 cell, so to within 1/64 cell);
        ``fit`` and ``split``: ``snapped_nodes``, ``snapped_to_corners``,
        ``crossings``, ``pieces``, ``templates`` (pieces by template),
        ``boundary_quality`` (least and mean (8.4) of the boundary quads,
        shape ratio of the boundary triangles, least scaled Jacobian of the
        boundary quads).

    Guarantees
    ----------
    ``keep``: the cells cover the domain; each cell's open interior meets it.
    ``fit``/``split``: the area is the domain's (to rounding), every input
    segment is a chain of mesh edges, every input vertex a mesh vertex, no
    cell has non-positive area, the mesh conforms. Interior cells are
    perfect squares (or halves of them) in every mode.

    Raises
    ------
    InputError
        A bad domain (``loc`` under ``domain``), a bad ``size``, ``origin``,
        ``angle``, ``boundary``, ``cells`` or ``max_cells`` (``loc`` names
        it), ``too_many_cells`` when ``size`` would pass ``max_cells``.

    References
    ----------
    Methods text §8.2 (module docstring).
    """
    timings: dict[str, float] = {}
    clock = time.process_time()

    def lap(name):
        nonlocal clock
        now = time.process_time()
        timings[name] = timings.get(name, 0.0) + now - clock
        clock = now

    def report(f, msg):
        if progress is not None:
            progress(f, msg)

    dom = _as_domain(domain)
    boundary = _choice(boundary, "boundary", ("keep", "fit", "split"))
    cells = _choice(cells, "cells", ("quad", "triangle"))
    a = _number(angle, "angle")
    if isinstance(max_cells, bool) or not isinstance(max_cells, (int, np.integer)) or max_cells < 1:
        raise InputError(
            f"max_cells must be a positive integer, got {max_cells!r}",
            loc=("max_cells",),
            code="bad_parameter",
        )
    if origin is None:
        o = dom.points.min(axis=0)
    else:
        try:
            o = np.asarray(origin, dtype=np.float64).reshape(2)
        except (TypeError, ValueError):
            raise InputError(
                f"origin must be [x, y], got {origin!r}", loc=("origin",), code="bad_parameter"
            ) from None
        if not np.isfinite(o).all():
            raise InputError("origin must be finite", loc=("origin",), code="non_finite")
    if size is None:
        h = _smallest_distance(dom.points)
        est = estimated_cells(dom, size=h, angle=a)
        if est > max_cells:
            h *= math.sqrt(est / max_cells) * 1.01
    else:
        h = _number(size, "size")
        est = estimated_cells(dom, size=size, angle=a)  # refuses a size not above 0
        if est > max_cells:
            raise InputError(
                f"size {h:g} makes a grid of about {est} cells, more than max_cells={max_cells}",
                loc=("size",),
                code="too_many_cells",
            )
    rad = math.radians(a)
    cos, sin = math.cos(rad), math.sin(rad)
    shift, nx, ny = _extent(dom, o, cos, sin, h)
    frame = _Frame(o, cos, sin, h, shift)
    L = frame.local(dom.points)
    nx1 = nx + 1
    lap("setup")
    report(0.1, "grid: cells meeting the domain")

    stats: dict = {"size": h, "grid": [nx, ny]}
    if boundary == "keep":
        kept = _staircase(dom, L, nx, ny)
        cj, ci = np.nonzero(kept)
        c00 = cj * nx1 + ci
        quads = np.column_stack([c00, c00 + 1, c00 + nx1 + 1, c00 + nx1])
        used = _used(quads, nx1 * (ny + 1))
        remap = np.full(nx1 * (ny + 1), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        pts = frame.world(np.column_stack([used % nx1, used // nx1]).astype(np.float64))
        quads_all, n_interior, band_tris = remap[quads], len(quads), np.zeros((0, 3), np.int64)
        lap("staircase")
        out = _outline_edges(kept)
        oL = np.column_stack([out.ravel() % nx1, out.ravel() // nx1]).astype(np.float64)
        stair = frame.world(oL).reshape(-1, 2, 2)
        bnd = dom.points[dom.segments]
        mesh_area = len(quads) * h * h
        stats.update(
            area_error=mesh_area - dom.area,
            hausdorff=_hausdorff(stair, bnd, TOL.hausdorff_sample * h),
        )
        lap("errors")
    else:
        pts, quads_all, n_interior, band_tris, fstats, ft = _fit(
            dom, frame, L, nx, ny, boundary, cells
        )
        timings.update(ft)
        stats.update(fstats)
        clock = time.process_time()
    report(0.9, "grid: assembling")
    interior_q, boundary_q = quads_all[:n_interior], quads_all[n_interior:]
    if cells == "triangle":
        tris = np.concatenate([_split_quads(interior_q), _split_quads(boundary_q), band_tris])
        blocks = [CellBlock("triangle", tris)]
        n_int = 2 * n_interior
        sets = {
            "interior": [np.arange(n_int)],
            "boundary": [np.arange(n_int, len(tris))],
        }
    else:
        quads = quads_all
        blocks = [CellBlock("quad", quads)]
        sets = {
            "interior": [np.arange(n_interior)],
            "boundary": [np.arange(n_interior, len(quads))],
        }
        if len(band_tris):
            blocks.append(CellBlock("triangle", band_tris))
            sets["interior"].append(np.zeros(0, dtype=np.int64))
            sets["boundary"].append(np.arange(len(band_tris)))
    mesh = Mesh(pts, tuple(blocks), cell_sets=sets)
    nq = sum(len(b) for b in blocks if b.type == "quad")
    nt = sum(len(b) for b in blocks if b.type == "triangle")
    stats.update(
        quads=int(nq),
        triangles=int(nt),
        points=int(len(pts)),
        cells={
            "interior": int(n_int if cells == "triangle" else n_interior),
            "boundary": int(nq + nt - (n_int if cells == "triangle" else n_interior)),
        },
        domain_area=dom.area,
    )
    if boundary != "keep":
        bq = quad_quality(pts, boundary_q) if len(boundary_q) else np.zeros(0)
        bt = triangle_shape(pts, band_tris) if len(band_tris) else np.zeros(0)
        sj = _quad_jacobian(pts, boundary_q)
        stats["boundary_quality"] = {
            "quad_min": float(bq.min()) if bq.size else None,
            "quad_mean": float(bq.mean()) if bq.size else None,
            "quad_min_scaled_jacobian": float(sj.min()) if sj.size else None,
            "triangle_shape_min": float(bt.min()) if bt.size else None,
            "triangle_shape_mean": float(bt.mean()) if bt.size else None,
        }
        # interior cells are squares of side h; the boundary cells by the shoelace
        # formula, relative to a mesh point (no cancellation far from the origin)
        rel = pts - pts.min(axis=0)
        parts = [n_interior * h * h]
        for data in (boundary_q, band_tris):
            P = rel[data]
            k = data.shape[1]
            parts += [
                0.5
                * float(
                    (P[:, c, 0] * P[:, (c + 1) % k, 1] - P[:, (c + 1) % k, 0] * P[:, c, 1]).sum()
                )
                for c in range(k)
            ]
        area = math.fsum(parts)
        stats["area"] = area
    else:
        stats["area"] = stats["domain_area"] + stats["area_error"]
    lap("stats")
    report(1.0, "grid: done")
    return GridResult(mesh=mesh, stats=stats, timings=timings)
