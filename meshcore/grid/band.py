"""The gap between kept cells and a domain's boundary, meshed and merged (§8.2, Figure 8.7).

Shared by :func:`meshcore.grid.quad_grid` and :func:`meshcore.grid.pattern`:
given cells kept strictly inside a domain (grid squares or pattern cells),
the remaining region, between the kept cells' outline and the domain
boundary, is built as a polygon with holes, meshed by
:func:`meshcore.triangulation.refinement.triangulate` with the outline as a
kept boundary (no point added on it), optionally turned into quads only by
:func:`meshcore.quads.combination.combine` with ``all_quad`` (then the kept
cells are split the same way: quads into four, triangles into three quads,
so that the interface conforms), and merged with the kept cells by
:func:`meshcore.product.merge.merged`, which checks the interface conforms.

Choices
-------
* **Outline.** The kept cells' boundary edges (held by one cell), oriented
  with the cells on their left, chained into loops. A vertex where two
  kept cells touch at a corner only (two outgoing outline edges) would make
  a non-manifold ring: the kept cells around it are dropped, until none is
  left (a few rounds).
* **Domain boundary.** The gap's own boundary segments are the input
  segments split into equal pieces no longer than the size ``h``
  (``keep_boundary`` then adds none), so every input vertex is a mesh
  vertex and every input segment a chain of edges; constraints likewise.
* **Rings into polygons.** Loops with the gap on their left: counter-clockwise
  ones are outer rings, clockwise ones holes, each hole in the smallest
  outer ring that contains one of its vertices (exact ray parity).

References
----------
Methods text §8.2 (Figures 8.6, 8.7: steps iii and iv), §8.5.2.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.domain.planar import Domain, parse_domain, ray_parity
from meshcore.errors import AlgorithmError, InputError
from meshcore.mesh import CellBlock, Mesh
from meshcore.product.merge import merged
from meshcore.quads.combination import combine
from meshcore.triangulation.refinement import triangulate

__all__ = ["band_domain", "drop_pinches", "fill_gap", "outline_loops", "split_into_quads"]


def _half_edges(blocks: list[np.ndarray]):
    """Directed edges of every cell (counter-clockwise) and the cell (block, row) owning each."""
    he, owner = [], []
    base = 0
    for data in blocks:
        k = data.shape[1]
        for c in range(k):
            he.append(np.column_stack([data[:, c], data[:, (c + 1) % k]]))
            owner.append(base + np.arange(len(data)))
        base += len(data)
    return np.concatenate(he), np.concatenate(owner)


def _outline(blocks: list[np.ndarray], n: int):
    he, owner = _half_edges(blocks)
    fwd = he[:, 0] * n + he[:, 1]
    rev = he[:, 1] * n + he[:, 0]
    bnd = ~np.isin(fwd, rev)
    return he[bnd], owner[bnd], he, owner


def drop_pinches(blocks: list[np.ndarray], n: int) -> list[np.ndarray]:
    """The cells left once no vertex has two outgoing outline edges.

    Parameters
    ----------
    blocks : list of (m_i, k_i) int64
        Counter-clockwise cells over ``n`` points.
    """
    while True:
        edges, _, he, owner = _outline(blocks, n)
        out = np.bincount(edges[:, 0], minlength=n)
        bad = out > 1
        if not bad.any():
            return blocks
        drop = np.zeros(sum(len(b) for b in blocks), dtype=bool)
        drop[owner[bad[he[:, 0]]]] = True
        keep, base = [], 0
        for data in blocks:
            keep.append(data[~drop[base : base + len(data)]])
            base += len(data)
        blocks = keep


@njit(cache=True)
def _cycles(succ_from, succ_to, n_nodes):  # pragma: no cover - compiled
    """Order directed edges into cycles (each node has at most one successor)."""
    nxt = np.full(n_nodes, -1, dtype=np.int64)
    for k in range(len(succ_from)):
        nxt[succ_from[k]] = succ_to[k]
    seen = np.zeros(n_nodes, dtype=np.bool_)
    order = np.empty(len(succ_from), dtype=np.int64)
    starts = [0]
    pos = 0
    for k in range(len(succ_from)):
        v = succ_from[k]
        if seen[v]:
            continue
        while not seen[v]:
            seen[v] = True
            order[pos] = v
            pos += 1
            v = nxt[v]
        starts.append(pos)
    return order, np.array(starts, dtype=np.int64)


def outline_loops(edges: np.ndarray, n: int) -> list[np.ndarray]:
    """Directed edges (each vertex with at most one successor) chained into loops of ids."""
    if len(edges) == 0:
        return []
    order, starts = _cycles(edges[:, 0].astype(np.int64), edges[:, 1].astype(np.int64), n)
    return [order[starts[k] : starts[k + 1]] for k in range(len(starts) - 1)]


def _shoelace(xy: np.ndarray) -> float:
    c = xy - xy.min(axis=0)
    return 0.5 * float(np.sum(c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1]))


def band_domain(rings: list[np.ndarray], lines: list[np.ndarray]) -> Domain:
    """A Domain from rings with the region on their left, and constraint polylines.

    Parameters
    ----------
    rings : list of (k, 2) float64
        Pairwise disjoint simple rings, oriented with the region on the left.
    lines : list of (j, 2) float64
        Constraint polylines inside the region.

    Raises
    ------
    AlgorithmError
        When the rings do not make a valid domain (a defect of the caller).
    """
    area = [_shoelace(r) for r in rings]
    outer = [k for k in range(len(rings)) if area[k] > 0]
    holes = [k for k in range(len(rings)) if area[k] < 0]
    owner: dict[int, int] = {}
    if len(outer) > 1 and holes:
        p0 = np.concatenate([rings[k] for k in outer])
        p1 = np.concatenate([np.roll(rings[k], -1, axis=0) for k in outer])
        seg_ring = np.concatenate([np.full(len(rings[k]), i) for i, k in enumerate(outer)])
        q = np.array([rings[k][0] for k in holes])
        rows = ray_parity(q, np.full(len(q), -1, dtype=np.int64), p0, p1, seg_ring, len(outer))
        for h_i, r_i in rows.tolist():
            prev = owner.get(h_i)
            if prev is None or area[outer[r_i]] < area[outer[prev]]:
                owner[h_i] = r_i
    else:
        owner = dict.fromkeys(range(len(holes)), 0)
    if not outer or len(owner) < len(holes):
        raise AlgorithmError("the gap's rings do not nest into polygons")
    polys = [[rings[k].tolist()] for k in outer]
    for i, k in enumerate(holes):
        polys[owner[i]].append(rings[k].tolist())
    geometry = {"type": "MultiPolygon", "coordinates": polys}
    try:
        return parse_domain(geometry, [line.tolist() for line in lines] or None)
    except InputError as exc:
        raise AlgorithmError(f"the gap between the kept cells and the boundary: {exc}") from None


def _subdivided(P: np.ndarray, h: float) -> np.ndarray:
    """A closed ring's vertices with each segment split into pieces of at most h."""
    Q = np.roll(P, -1, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(*(Q - P).T) / h * (1 - 1e-12)).astype(np.int64))
    s = np.repeat(np.arange(len(P)), n)
    k = np.arange(len(s)) - np.repeat(np.cumsum(n) - n, n)
    t = (k / n[s])[:, None]
    out = P[s] + t * (Q[s] - P[s])
    out[k == 0] = P[s[k == 0]]  # the input vertices exactly
    return out


def _subdivided_line(A: np.ndarray, B: np.ndarray, h: float) -> np.ndarray:
    n = max(1, int(np.ceil(np.hypot(*(B - A)) / h * (1 - 1e-12))))
    out = A + np.linspace(0.0, 1.0, n + 1)[:, None] * (B - A)
    out[0], out[-1] = A, B
    return out


def split_into_quads(points: np.ndarray, blocks: list[tuple[str, np.ndarray]]):
    """Quads into four and triangles into three quads (edge midpoints, cell centroids).

    Returns the new points (appended) and the quads. Midpoints are computed
    as ``(a + b) / 2`` from the sorted pair, so a neighbour's split of the
    same edge gives the same point.
    """
    edges, cent, cells = [], [], []
    for _, data in blocks:
        k = data.shape[1]
        e = np.stack([data, np.roll(data, -1, axis=1)], axis=2)  # (m, k, 2): edge c = (c, c+1)
        edges.append(e.reshape(-1, 2))
        cent.append(points[data].mean(axis=1))
        cells.append((data, k))
    e = np.sort(np.concatenate(edges), axis=1)
    ue, inv = np.unique(e, axis=0, return_inverse=True)
    mids = 0.5 * (points[ue[:, 0]] + points[ue[:, 1]])
    n = len(points)
    m_id = n + inv.ravel()
    c_base = n + len(ue)
    quads = []
    pos = 0
    c_off = 0
    for data, k in cells:
        m = len(data)
        mid = m_id[pos : pos + m * k].reshape(m, k)  # midpoint of edge (c, c+1)
        pos += m * k
        cid = c_base + c_off + np.arange(m)
        c_off += m
        for c in range(k):
            # corner c, midpoint of (c, c+1), centre, midpoint of (c-1, c)
            quads.append(np.column_stack([data[:, c], mid[:, c], cid, mid[:, (c - 1) % k]]))
    new_points = np.concatenate([points, mids, *cent])
    return new_points, np.concatenate(quads) if quads else np.zeros((0, 4), dtype=np.int64)


def fill_gap(
    dom: Domain,
    points: np.ndarray,
    kept: list[tuple[str, np.ndarray]],
    h: float,
    gap: str = "triangles",
    smooth: bool = False,
    progress=None,
):
    """Mesh the domain minus the kept cells, and merge the two (Figure 8.7 iii and iv).

    Parameters
    ----------
    dom : Domain
    points : (n, 2) float64
        Points of the kept cells.
    kept : list of (type, (m, k) int64)
        ``triangle`` / ``quad`` cells, counter-clockwise, strictly inside the
        domain, away from its boundary and constraints, pinch-free
        (:func:`drop_pinches`).
    h : float
        Size of the gap's mesh (boundary pieces and triangles).
    gap : {"triangles", "quads"}
        ``quads``: the gap's triangles combined and split by
        :func:`~meshcore.quads.combination.combine` with ``all_quad``, the
        kept cells split into quads too.
    smooth : bool
        ``quads`` only: optimize the gap's quads (operators and smoothing of
        interior vertices that never inverts a cell; the interface stays).

    Returns
    -------
    mesh : Mesh
        Cell sets ``pattern`` (the kept cells, or their quads) and ``gap``.
    stats : dict
        ``gap_triangles`` (the triangulation of the gap), ``gap_cells``,
        ``pattern_cells``, ``loops``.

    Raises
    ------
    AlgorithmError
        ``merge_failed``: the two meshes do not merge (the merge's own error, whose
        location is in its arguments, not in the caller's input, is in the message).
    """
    used = np.unique(np.concatenate([d.ravel() for _, d in kept]))
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    points = points[used]
    kept = [(t, remap[d]) for t, d in kept]
    n = len(points)
    blocks = [d for _, d in kept]
    edges, _, _, _ = _outline(blocks, n)
    loops = outline_loops(edges, n)
    rings = []
    for k in range(dom.ring_count):
        lo, hi = int(dom.ring_offsets[k]), int(dom.ring_offsets[k + 1])
        ring = dom.points[lo:hi]
        if dom.ring_reversed[k]:
            ring = ring[::-1]
        rings.append(_subdivided(ring, h))
    rings += [points[loop[::-1]] for loop in loops]
    lines = [_subdivided_line(dom.points[a], dom.points[b], h) for a, b in dom.constraints]
    gdom = band_domain(rings, lines)
    if progress is not None:
        progress(0.5, "meshing the gap")
    tri = triangulate(gdom, size=h, keep_boundary=True)
    gmesh = tri.mesh
    stats = {"loops": len(loops), "gap_triangles": len(gmesh.cells[0].data)}
    if gap == "quads":
        res = combine(gmesh, all_quad=True, optimize=smooth)
        gmesh = res.mesh
        kpts, kquads = split_into_quads(points, kept)
        kept_mesh = Mesh(
            kpts, (CellBlock("quad", kquads),), cell_sets={"pattern": [np.arange(len(kquads))]}
        )
    else:
        kept_mesh = Mesh(points, tuple(CellBlock(t, d) for t, d in kept))
        kept_mesh = Mesh(
            points,
            kept_mesh.cells,
            cell_sets={"pattern": [np.arange(len(b)) for b in kept_mesh.cells]},
        )
    gmesh = Mesh(
        gmesh.points, gmesh.cells, cell_sets={"gap": [np.arange(len(b)) for b in gmesh.cells]}
    )
    try:
        out = merged([kept_mesh, gmesh])
    except InputError as exc:  # located in merged's own arguments: not the caller's input
        raise AlgorithmError(
            "the kept cells and the mesh of the gap to the boundary do not merge into one "
            f"conforming mesh ({exc.message}); boundary features far below the cell size "
            "(a sliver spike, vertices nearly coincident) do this: remove them",
            code="merge_failed",
        ) from None
    stats["pattern_cells"] = int(sum(len(b) for b in kept_mesh.cells))
    stats["gap_cells"] = int(sum(len(b) for b in gmesh.cells))
    return out.mesh, stats
