"""Boundary pieces no longer than the local feature size, in bulk.

Delaunay refinement splits an input segment where a point of another part of
the boundary falls in the small (diametral) ball of one of its pieces
(§9.1.4), one split at a time: along a strip of width ``w`` and length ``L``
cut into pieces of the size ``h``, about ``log2(h / w)`` rounds of splits
bring the pieces down to ``w``, each split a cavity and a queue entry. Here
the pieces are cut *before* the triangulation, to the distance ``d`` from
each piece to the nearest input segment not sharing a vertex with its own
(Ruppert's local feature size, the incident segments left to refinement's
concentric shells): only where refinement would need many rounds of splits.

* Where the distance barely varies along the piece (the largest distance at
  its ends is at most twice ``d``: the distance to a segment is convex along
  a line, so it is largest at an end) and the piece is longer than
  ``CUT_FROM * beta * d``, it is cut at once into ``ceil(length / (beta d))``
  equal pieces: a strip's side in one step.
* Where the distance varies and the piece is longer than ``HALVE_FROM * beta
  * d``, it is halved and both halves looked at again: pieces grade
  geometrically towards a near feature (a hole ``1e-12`` from the outer ring
  costs about 40 halvings of a few pieces, not ``h / 1e-12`` pieces), and
  refinement's encroachment splits the last steps only where they are needed.

Cutting every piece down to ``beta * d`` (as this module first did) made 1.5 to
2 times the triangles the angle bound needs on random stars (the 50-vertex
star of ``benchmarks/triangulate.py --small``: 771 triangles, 402 without the
cuts, Triangle 309): near a spike's tip refinement splits only the pieces its
points encroach upon, not every piece within ``beta`` times its distance.

Each piece is compared with the pieces of the first cut (by the size) that
lie within ``length / (CUT_FROM * beta)`` of it, found once in a k-d tree of their
midpoints (one tree per power of eight of their lengths, each query widened
by half the tree's longest piece, so that a long piece does not widen every
query); the comparisons are exact distances
between segments, in floating point.

References
----------
Methods text §9.1.4 (small balls of the pieces), §9.1.5 (boundary
discretization), Remark 8.10 (the size the pieces follow); J. Ruppert, "A
Delaunay refinement algorithm for quality 2-dimensional mesh generation"
(1995), local feature size.
"""

from __future__ import annotations

from itertools import chain

import numpy as np
from scipy.spatial import cKDTree

from meshcore.geometry.constructions import point_segment_distance

__all__ = ["feature_cuts"]

#: Rounds of halving at most (a piece is halved at most this many times).
MAX_HALVINGS = 60
#: Cut points made here at most; past it the cutting stops and refinement goes
#: on from the pieces as they are (with its own runaway budget).
MAX_CUTS = 1 << 24
#: A feature nearer than this times the largest coordinate magnitude is within
#: rounding of the piece (a vertex on a segment up to rounding): then nothing is
#: cut here, and the admissible boundary names the vertex and the segment as
#: given.
RESOLUTION = 2.0**-40
#: A flat piece is cut only when longer than this times ``beta * d`` (shorter
#: ones are left to refinement, which splits them only where encroached).
CUT_FROM = 2.0
#: A piece whose distance varies is halved only while longer than this times
#: ``beta * d``: the near-touching features refinement would take tens of rounds
#: (or a runaway of shells) to reach.
HALVE_FROM = 64.0


def _segment_distance(a0, a1, b0, b1) -> np.ndarray:
    """Distance between segments ``(a0, a1)`` and ``(b0, b1)`` (rows) that do not cross."""
    return np.minimum(
        np.minimum(point_segment_distance(a0, b0, b1)[0], point_segment_distance(a1, b0, b1)[0]),
        np.minimum(point_segment_distance(b0, a0, a1)[0], point_segment_distance(b1, a0, a1)[0]),
    )


def _near_pairs(X0, X1, seg_of, seg, beta):
    """Pairs (i, j) of pieces of segments sharing no vertex with ``dist(i, j) < len(i) / beta``."""
    mid = 0.5 * (X0 + X1)
    length = np.hypot(*(X1 - X0).T)
    level = (np.frexp(length)[1] - 1) // 3  # lengths in [8**level, 8**(level + 1))
    out_i, out_j = [], []
    for lv in np.unique(level):
        js = np.flatnonzero(level == lv)
        reach = length * (1.0 / beta + 0.5) + 0.5 * length[js].max()
        hits = cKDTree(mid[js]).query_ball_point(mid, reach)
        cnt = np.fromiter(map(len, hits), np.int64, len(hits))
        if cnt.sum() == 0:
            continue
        out_i.append(np.repeat(np.arange(len(mid)), cnt))
        out_j.append(js[np.fromiter(chain.from_iterable(hits), np.int64, cnt.sum())])
    if not out_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    i = np.concatenate(out_i)
    j = np.concatenate(out_j)
    si, sj = seg[seg_of[i]], seg[seg_of[j]]
    apart = (
        (si[:, 0] != sj[:, 0])
        & (si[:, 0] != sj[:, 1])
        & (si[:, 1] != sj[:, 0])
        & (si[:, 1] != sj[:, 1])
    )
    i, j = i[apart], j[apart]
    near = _segment_distance(X0[i], X1[i], X0[j], X1[j]) * beta < length[i]
    i, j = i[near], j[near]
    order = np.argsort(i, kind="stable")
    return i[order], j[order]


def feature_cuts(P: np.ndarray, seg: np.ndarray, sid: np.ndarray, t: np.ndarray, beta: float):
    """Cut the pieces of the input segments further, to ``beta`` times their feature size.

    Parameters
    ----------
    P : (n, 2) float
        Input points.
    seg : (k, 2) int
        Input segments (boundary and constraints).
    sid, t : (q,) int, (q,) float
        The cut points so far: segment and parameter (0 at the segment's
        first vertex, 1 at its second), ordered by segment then parameter.
    beta : float
        A piece at distance ``d`` from the nearest segment sharing no vertex
        with its own ends at most ``beta * d`` long.

    Returns
    -------
    sid, t : (r,) int64, (r,) float
        Every cut point (those given among them), ordered by segment then
        parameter.

    References
    ----------
    Methods text §9.1.4, §9.1.5 (module docstring).
    """
    k = len(seg)
    cnt = np.bincount(sid, minlength=k) + 1  # pieces per segment
    ps = np.repeat(np.arange(k), cnt)
    first = np.cumsum(cnt) - cnt
    pos = np.arange(len(ps)) - np.repeat(first, cnt)
    # piece p of segment s runs from cut p - 1 (or 0) to cut p (or 1); the cuts of
    # segment s start at first[s] - s in t
    t0 = np.zeros(len(ps))
    t1 = np.ones(len(ps))
    inner = pos > 0
    t0[inner] = t[first[ps[inner]] - ps[inner] + pos[inner] - 1]
    last = pos < cnt[ps] - 1
    t1[last] = t[first[ps[last]] - ps[last] + pos[last]]
    A = P[seg[:, 0]]
    D = P[seg[:, 1]] - A
    X0 = A[ps] + t0[:, None] * D[ps]
    X1 = A[ps] + t1[:, None] * D[ps]
    pi, pj = _near_pairs(X0, X1, ps, seg, CUT_FROM * beta)  # nothing farther is cut
    if len(pi) == 0:
        return sid.astype(np.int64), t
    # candidates of each first piece, as a CSR table
    ncand = np.bincount(pi, minlength=len(ps))
    cstart = np.cumsum(ncand) - ncand
    Y0, Y1 = X0[pj], X1[pj]
    out_s, out_t = [np.zeros(0, np.int64)], [np.zeros(0)]  # the cuts made
    made = 0
    resolution = RESOLUTION * float(np.abs(P).max())
    root = np.flatnonzero(ncand > 0)
    a, b = t0[root], t1[root]
    for _ in range(MAX_HALVINGS):
        if len(root) == 0:
            break
        s = ps[root]
        nc = ncand[root]
        rows = np.repeat(np.arange(len(root)), nc)
        c = np.repeat(cstart[root] - np.cumsum(nc) + nc, nc) + np.arange(nc.sum())
        q0 = A[s][rows] + a[rows, None] * D[s][rows]
        q1 = A[s][rows] + b[rows, None] * D[s][rows]
        # the distance between the pieces (as _segment_distance) and the largest at the
        # piece's ends, from the same four point-segment distances
        y0, y1 = Y0[c], Y1[c]
        d0 = point_segment_distance(q0, y0, y1)[0]
        d1 = point_segment_distance(q1, y0, y1)[0]
        e = np.minimum(point_segment_distance(y0, q0, q1)[0], point_segment_distance(y1, q0, q1)[0])
        dmin = np.full(len(root), np.inf)
        np.minimum.at(dmin, rows, np.minimum(np.minimum(d0, d1), e))
        dmax = np.full(len(root), np.inf)
        np.minimum.at(dmax, rows, np.maximum(d0, d1))
        length = (b - a) * np.hypot(*D[s].T)
        if (dmin <= resolution).any():
            return sid.astype(np.int64), t
        even = dmax <= 2.0 * dmin
        flat = even & (length > CUT_FROM * beta * dmin)
        n = np.where(flat, np.ceil(length / (beta * np.where(flat, dmin, 1.0))), 1.0)
        fr = np.flatnonzero(flat)
        hr = np.flatnonzero(~even & (length > HALVE_FROM * beta * dmin))
        made += float((n[fr] - 1).sum()) + len(hr)
        if made > MAX_CUTS:
            break
        # flat pieces: n equal pieces at once
        m = n[fr].astype(np.int64) - 1
        j = np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m) + 1
        u = np.repeat(a[fr], m) + j / np.repeat(n[fr], m) * np.repeat(b[fr] - a[fr], m)
        out_s.append(np.repeat(s[fr], m))
        out_t.append(u)
        # the others: halved, both halves again
        mid = 0.5 * (a[hr] + b[hr])
        keep = (mid > a[hr]) & (mid < b[hr])
        hr, mid = hr[keep], mid[keep]
        out_s.append(s[hr])
        out_t.append(mid)
        root = np.concatenate([root[hr], root[hr]])
        a, b = np.concatenate([a[hr], mid]), np.concatenate([mid, b[hr]])
    new_s = np.concatenate(out_s)
    if len(new_s) == 0:
        return sid.astype(np.int64), t
    all_s = np.concatenate([sid.astype(np.int64), new_s])
    all_t = np.concatenate([t, np.concatenate(out_t)])
    order = np.lexsort((all_t, all_s))
    return all_s[order], all_t[order]
