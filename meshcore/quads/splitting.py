"""The all-quad split of a mixed mesh (§8.4.2, §8.4.4, Figure 8.13): ``split_all``.

Every edge gets its midpoint, every quad becomes four quads around its centroid and
every triangle three. On a domain's thin parts (a spike one pair of triangles wide)
that makes two quads across a strip whose width is already under the size, and four
quads where one would do: issue 20's spiky stars came out at 2.6-2.8 times area /
size² at size 0.1, nine tenths of their quads within two sizes of an input vertex.
So the caller may name *ladder* quads (:func:`ladders`: two opposite edges on the
boundary, the other two, the *rungs*, inside). A rung between two ladder quads gets
no midpoint, and a ladder quad's sides get one only where its rungs need them to
keep an even count:

* no rung split (inside a run of ladder quads): the quad is kept, one quad across;
* one rung split (the end of a run): the longer side split too, three quads around
  the centroid (the two split edges meet at a corner: the triangle's split of
  Figure 8.13 with one side whole);
* both rungs split (a ladder quad alone): four quads, as any quad.

Every other edge and cell is split as before, so a mesh with no ladder quads is split
exactly as without them (the same points and quads).
"""

from __future__ import annotations

import numpy as np

from meshcore.geometry.predicates import orient2d
from meshcore.mesh import quality
from meshcore.mesh.topology import edge_keys, isin_ints, unique_ints

__all__ = ["ladders", "merged_ladders", "split_all"]

#: A merged ladder quad keeps at least this quality (8.4), or that of the worse of the
#: two quads it replaces.
MERGE_QUALITY = 0.5


def ladders(quads: np.ndarray, boundary: np.ndarray, n: int) -> np.ndarray:
    """(q,) bool: the quads whose edges 0 and 2, or 1 and 3, are ``boundary`` edges
    (``(s, 2)`` point pairs, either order; ``n`` points) and whose other two are not:
    quads spanning a strip one quad wide (§8.4.2, §8.4.4)."""
    q = np.asarray(quads, np.int64).reshape(-1, 4)
    b = np.asarray(boundary, np.int64).reshape(-1, 2)
    on = isin_ints(_cell_edge_keys(q, n), _cell_edge_keys(b, n)[:, 0])
    even, odd = on[:, 0] & on[:, 2], on[:, 1] & on[:, 3]
    return (even & ~on[:, 1] & ~on[:, 3]) | (odd & ~on[:, 0] & ~on[:, 2])


def merged_ladders(points, quads, triangles, boundary, n_input: int, longest: float, metric=None):
    """Consecutive ladder quads (:func:`ladders`) of a mixed mesh merged two by two by
    removing their common rung: its two ends (boundary points, not input vertices: on
    one input segment, held by those two quads only) go, the sides become one edge each.
    A merge is made where the merged quad is strictly convex (exact
    :func:`~meshcore.geometry.predicates.orient2d` at its four corners), its sides are
    at most ``longest`` (the triangulation's size) and its quality (8.4) at least
    ``MERGE_QUALITY`` or that of the worse of the two; the shortest merged quads first.
    Along a spike the triangulation's pieces shrink with its width towards the tip; the
    merges lay one quad per ``longest`` of its length instead.

    Returns
    -------
    (points, quads, triangles, boundary, metric)
        The points left (the input vertices first, in order; ``metric`` likewise, or
        None) and the cells and boundary edges renumbered. The domain is the same: the
        points removed lie on input segments and every merged quad is strictly convex.

    References
    ----------
    §8.4.2 (twice size), §8.4.3 (the operators that remove a node).
    """
    P = np.asarray(points)
    Q = np.asarray(quads, np.int64).reshape(-1, 4).copy()
    n = len(P)
    w = np.flatnonzero(ladders(Q, boundary, n))
    k = _cell_edge_keys(Q[w], n).ravel()
    order = np.argsort(k, kind="stable")
    k = k[order]
    pair = np.flatnonzero(k[1:] == k[:-1])  # a rung of two ladder quads
    if not len(pair):
        return points, quads, triangles, boundary, metric
    a_slot, b_slot = order[pair], order[pair + 1]
    qa, ia = w[a_slot // 4], a_slot % 4
    qb, ib = w[b_slot // 4], b_slot % 4
    ends = np.column_stack([Q[qa, ia], Q[qa, (ia + 1) % 4]])
    ok = (ends >= n_input).all(axis=1)
    qa, ia, qb, ib = qa[ok], ia[ok], qb[ok], ib[ok]
    span = np.linalg.norm(P[Q[qa]] - P[np.roll(Q[qa], -1, axis=1)], axis=-1).sum(axis=1)
    span += np.linalg.norm(P[Q[qb]] - P[np.roll(Q[qb], -1, axis=1)], axis=-1).sum(axis=1)
    owner = np.arange(len(Q))  # a merged quad's row: the first of its quads
    gone = np.zeros(len(Q), bool)
    removed = []
    base = quality.quad_quality(P, Q)
    for r in np.argsort(span, kind="stable"):
        a, b = owner[qa[r]], owner[qb[r]]
        x, y = Q[qa[r], ia[r]], Q[qa[r], (ia[r] + 1) % 4]
        i = np.flatnonzero((Q[a] == x) & (np.roll(Q[a], -1) == y))
        j = np.flatnonzero((Q[b] == y) & (np.roll(Q[b], -1) == x))
        if a == b or not len(i) or not len(j):
            continue
        i, j = int(i[0]), int(j[0])
        new = np.array([Q[a][(i + 2) % 4], Q[a][(i + 3) % 4], Q[b][(j + 2) % 4], Q[b][(j + 3) % 4]])
        c = P[new]
        if not (orient2d(np.roll(c, 1, axis=0), c, np.roll(c, -1, axis=0)) > 0).all():
            continue
        if np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1).max() > longest:
            continue
        q = float(quality.quad_quality(P, new[None])[0])
        if q < min(MERGE_QUALITY, base[a], base[b]):
            continue
        Q[a], base[a] = new, q
        gone[b] = True
        owner[owner == b] = a
        removed += [x, y]
    if not removed:
        return points, quads, triangles, boundary, metric
    keep = np.ones(n, bool)
    keep[removed] = False
    new_id = np.cumsum(keep) - 1
    Q = Q[~gone]
    nxt = np.roll(Q, -1, axis=1)
    # the boundary edges again: the edges of one cell, each as its cell runs it
    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    ek = np.concatenate([_cell_edge_keys(Q, n).ravel(), _cell_edge_keys(tri, n).ravel()])
    _, inv, cnt = unique_ints(ek, return_inverse=True, counts=True)
    single = cnt[inv] == 1
    on = single[: Q.size].reshape(Q.shape)
    b = np.column_stack([Q[on], nxt[on]])
    bt = np.column_stack([tri.ravel(), np.roll(tri, -1, axis=1).ravel()])[single[Q.size :]]
    b = np.concatenate([b, bt])
    out_metric = None if metric is None or np.ndim(metric) != 3 else np.asarray(metric)[keep]
    return P[keep], new_id[Q], new_id[tri], new_id[b], out_metric


def split_all(
    points: np.ndarray,
    quads: np.ndarray,
    triangles: np.ndarray,
    metric=None,
    segments=None,
    whole=None,
):
    """Every quad into four quads and every triangle into three (Figure 8.13), ladder
    quads (``whole``) kept or split into three where their neighbours allow (module
    docstring).

    Parameters
    ----------
    points : (n, d) float64
    quads : (q, 4) int
    triangles : (t, 3) int
    metric : (n, d, d) float64, optional
        Extended to the new points (the mean of the points they are made from).
    segments : (s, 2) int, optional
        Edges of the cells (a boundary) to follow through the split.
    whole : (q,) bool, optional
        Ladder quads (:func:`ladders`: their sides are edges of no other cell).

    Returns
    -------
    points : (n + e' + c, d) float64
        The input points, then one midpoint per split edge (all ``e`` edges without
        ``whole``), then one centroid per quad split into four or three and per triangle.
    quads : (q', 4) int64
        Counter-clockwise when the input cells are; conforming. Without ``whole``:
        ``4 q + 3 t`` quads.
    metric : (n + e' + c, d, d) float64 or None
    segments : (s', 2) int64 or None
        Each given edge ``(a, b)`` as ``(a, m)`` and ``(m, b)``, ``m`` its midpoint,
        or as itself where it is not split.

    References
    ----------
    §8.4.2 (twice size), §8.4.4 and Figure 8.13.
    """
    n = len(points)
    cells = [
        np.asarray(quads, np.int64).reshape(-1, 4),
        np.asarray(triangles, np.int64).reshape(-1, 3),
    ]
    key = np.concatenate([_cell_edge_keys(c, n).ravel() for c in cells])
    uniq, inv = unique_ints(key, return_inverse=True)
    e0, e1 = uniq // n, uniq % n
    nq, nt = len(cells[0]), len(cells[1])
    qe = inv[: 4 * nq].reshape(nq, 4)
    split = np.ones(len(uniq), bool)
    pattern = np.ones((nq, 4), bool)  # the quads' split edges
    if whole is not None and np.any(whole):
        per_edge = np.bincount(inv, minlength=len(uniq))  # cells on each edge
        split, pattern = _ladder_split(points, cells[0], qe, np.asarray(whole, bool), per_edge)
    mid_of = np.full(len(uniq), -1, np.int64)
    mid_of[split] = n + np.arange(np.count_nonzero(split))
    nm = int(np.count_nonzero(split))
    four = pattern.all(axis=1)
    three = pattern.sum(axis=1) == 2
    three &= pattern[:, 0] != pattern[:, 2]  # two adjacent split edges
    centred = np.flatnonzero(four | three)
    cbase = n + nm
    centre_of = np.full(nq, -1, np.int64)
    centre_of[centred] = cbase + np.arange(len(centred))
    mids = 0.5 * (points[e0[split]] + points[e1[split]])
    d = points.shape[1]
    cq = points[cells[0][centred]].mean(axis=1) if len(centred) else np.zeros((0, d))
    ct = points[cells[1]].mean(axis=1) if nt else np.zeros((0, d))
    newp = np.concatenate([points, mids, cq, ct])
    out = []
    q4 = np.flatnonzero(four)
    if len(q4):
        c, em, centre = cells[0][q4], mid_of[qe[q4]], centre_of[q4]
        for i in range(4):
            out.append(np.column_stack([c[:, i], em[:, i], centre, em[:, i - 1]]))
    if nt:
        c, em = cells[1], mid_of[inv[4 * nq :].reshape(nt, 3)]
        centre = cbase + len(centred) + np.arange(nt)
        for i in range(3):
            out.append(np.column_stack([c[:, i], em[:, i], centre, em[:, i - 1]]))
    out.extend(_ladder_quads(cells[0], qe, pattern, mid_of, centre_of, three))
    newq = np.concatenate(out) if out else np.zeros((0, 4), np.int64)
    newm = None
    if metric is not None and np.ndim(metric) == 3:
        metric = np.asarray(metric)
        mm = 0.5 * (metric[e0[split]] + metric[e1[split]])
        rest = metric.shape[1:]
        mq = metric[cells[0][centred]].mean(axis=1) if len(centred) else np.zeros((0, *rest))
        mt = metric[cells[1]].mean(axis=1) if nt else np.zeros((0, *rest))
        newm = np.concatenate([metric, mm, mq, mt])
    if segments is None:
        return newp, newq, newm
    seg = np.asarray(segments, np.int64).reshape(-1, 2)
    mid = mid_of[np.searchsorted(uniq, _cell_edge_keys(seg, n)[:, 0])]
    cut = mid >= 0
    newseg = np.concatenate(
        [
            np.column_stack([seg[cut, 0], mid[cut]]),
            np.column_stack([mid[cut], seg[cut, 1]]),
            seg[~cut],
        ]
    )
    return newp, newq, newm, newseg


def _cell_edge_keys(cells: np.ndarray, n: int) -> np.ndarray:
    """(c, k) int64: the key ``min * n + max`` of each edge ``(i, i + 1)`` of ``(c, k)``
    cells of ``n`` points (an edge's key whichever way a cell runs it)."""
    return edge_keys(cells, np.roll(cells, -1, axis=1), n)


def _ladder_split(points, quads, qe, whole, per_edge):
    """Which edges are split ((e,) bool) and which edges of each quad ((q, 4) bool) where
    the ``whole`` quads are ladders (module docstring; ``per_edge``: the cells on each)."""
    ne = len(per_edge)
    ladder_edge = np.bincount(qe[whole].ravel(), minlength=ne)
    split = np.ones(ne, bool)
    split[(per_edge == 2) & (ladder_edge == 2)] = False  # a rung between two ladder quads
    w = np.flatnonzero(whole)
    side = per_edge[qe[w]] == 1  # (k, 4): its sides (edges of no other cell)
    rungs = np.where(side, 0, split[qe[w]]).sum(axis=1)
    cut = np.zeros_like(side)
    cut[rungs == 2] = side[rungs == 2]
    one = np.flatnonzero(rungs == 1)
    if len(one):  # the longer side split, the first of equal ones
        c = quads[w[one]]
        length = np.linalg.norm(points[np.roll(c, -1, axis=1)] - points[c], axis=-1)
        length = np.where(side[one], length, -1.0)
        cut[one, np.argmax(length, axis=1)] = True
    sides = qe[w][side]
    split[sides] = cut[side]
    return split, split[qe]


def _ladder_quads(quads, qe, pattern, mid_of, centre_of, three):
    """The quads of the ladder quads kept (no split edge) or split into three (two
    adjacent split edges), counter-clockwise as the quad."""
    out = []
    kept = ~pattern.any(axis=1)
    if kept.any():
        out.append(quads[kept])
    t = np.flatnonzero(three)
    if len(t):
        # rotate each so that its split edges are 3 and 0, meeting at its corner 0
        start = np.argmax(pattern[t] & np.roll(pattern[t], 1, axis=1), axis=1)
        idx = (start[:, None] + np.arange(4)) % 4
        c = np.take_along_axis(quads[t], idx, axis=1)
        em = mid_of[np.take_along_axis(qe[t], idx, axis=1)]
        o = centre_of[t]
        out.append(np.column_stack([c[:, 0], em[:, 0], o, em[:, 3]]))
        out.append(np.column_stack([em[:, 0], c[:, 1], c[:, 2], o]))
        out.append(np.column_stack([o, c[:, 2], c[:, 3], em[:, 3]]))
    return out
