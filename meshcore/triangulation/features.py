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
query); the comparisons are distances between segments in floating point, and
they and the rounds of cuts run in compiled loops (a small polygon's cuts cost
no numpy call per round).

References
----------
Methods text §9.1.4 (small balls of the pieces), §9.1.5 (boundary
discretization), Remark 8.10 (the size the pieces follow); J. Ruppert, "A
Delaunay refinement algorithm for quality 2-dimensional mesh generation"
(1995), local feature size.
"""

from __future__ import annotations

import math
from itertools import chain

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.geometry.constructions import point_segment_distance_2d

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


@njit(cache=True, inline="always")
def _end_distances(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y):
    """Distances from the two ends of segment a to segment b: with those from b's ends
    to a, the four whose least is the distance between two segments that do not cross."""
    return (
        point_segment_distance_2d(a0x, a0y, b0x, b0y, b1x, b1y),
        point_segment_distance_2d(a1x, a1y, b0x, b0y, b1x, b1y),
    )


@njit(cache=True)
def _near(X0, X1, length, seg_of, seg, i, j, beta):
    """Which pairs (i, j) of pieces lie on segments sharing no vertex, at a distance
    under ``length[i] / beta`` (the four end-to-piece distances, as they round)."""
    keep = np.zeros(i.shape[0], np.bool_)
    for r in range(i.shape[0]):
        p = i[r]
        q = j[r]
        u0 = seg[seg_of[p], 0]
        u1 = seg[seg_of[p], 1]
        v0 = seg[seg_of[q], 0]
        v1 = seg[seg_of[q], 1]
        if u0 == v0 or u0 == v1 or u1 == v0 or u1 == v1:
            continue
        a0x, a0y, a1x, a1y = X0[p, 0], X0[p, 1], X1[p, 0], X1[p, 1]
        b0x, b0y, b1x, b1y = X0[q, 0], X0[q, 1], X1[q, 0], X1[q, 1]
        d0, d1 = _end_distances(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y)
        e0, e1 = _end_distances(b0x, b0y, b1x, b1y, a0x, a0y, a1x, a1y)
        keep[r] = min(min(d0, d1), min(e0, e1)) * beta < length[p]
    return keep


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
    keep = _near(X0, X1, length, seg_of, seg, i, j, beta)
    i, j = i[keep], j[keep]
    order = np.argsort(i, kind="stable")
    return i[order], j[order]


@njit(cache=True)
def _grow(a, n):
    """``a`` with room for at least ``n`` items (its first items kept)."""
    if n <= a.shape[0]:
        return a
    out = np.empty(max(n, 2 * a.shape[0]), a.dtype)
    out[: a.shape[0]] = a
    return out


@njit(cache=True)
def _halvings(A, D, ps, t0, t1, cstart, ncand, pj, X0, X1, beta, resolution):
    """The cuts of the pieces with candidates (``ncand > 0``), round by round (see the
    module docstring): (segments, parameters, whether a feature lies within
    ``resolution``, in which case no cut is kept)."""
    root = np.flatnonzero(ncand > 0)
    nroot = root.shape[0]
    a = t0[root]
    b = t1[root]
    out_s = np.empty(16, np.int64)
    out_t = np.empty(16)
    no = 0
    made = 0.0
    for _ in range(MAX_HALVINGS):
        if nroot == 0:
            break
        n = np.ones(nroot)
        flat = np.zeros(nroot, np.bool_)
        halve = np.zeros(nroot, np.bool_)
        cuts = 0.0
        nh = 0
        for r in range(nroot):
            p = root[r]
            s = ps[p]
            ax, ay, dx, dy = A[s, 0], A[s, 1], D[s, 0], D[s, 1]
            q0x = ax + a[r] * dx
            q0y = ay + a[r] * dy
            q1x = ax + b[r] * dx
            q1y = ay + b[r] * dy
            lo = np.inf
            hi = np.inf
            for c in range(cstart[p], cstart[p] + ncand[p]):
                y0x, y0y, y1x, y1y = X0[pj[c], 0], X0[pj[c], 1], X1[pj[c], 0], X1[pj[c], 1]
                d0, d1 = _end_distances(q0x, q0y, q1x, q1y, y0x, y0y, y1x, y1y)
                e0, e1 = _end_distances(y0x, y0y, y1x, y1y, q0x, q0y, q1x, q1y)
                lo = min(lo, min(min(d0, d1), min(e0, e1)))
                hi = min(hi, max(d0, d1))
            if lo <= resolution:
                return out_s[:0], out_t[:0], True
            length = (b[r] - a[r]) * math.hypot(dx, dy)
            if hi <= 2.0 * lo:
                if length > CUT_FROM * beta * lo:
                    flat[r] = True
                    n[r] = np.ceil(length / (beta * lo))
                    cuts += n[r] - 1.0
            elif length > HALVE_FROM * beta * lo:
                halve[r] = True
                nh += 1
        made += cuts + nh
        if made > MAX_CUTS:
            break
        # flat pieces: n equal pieces at once; the others halved, both halves again
        # (first halves, then second halves)
        root2 = np.empty(2 * nh, np.int64)
        a2 = np.empty(2 * nh)
        b2 = np.empty(2 * nh)
        m2 = 0
        for r in range(nroot):
            s = ps[root[r]]
            if flat[r]:
                m = np.int64(n[r]) - 1
                out_s = _grow(out_s, no + m)
                out_t = _grow(out_t, no + m)
                for j in range(1, m + 1):
                    out_s[no] = s
                    out_t[no] = a[r] + j / n[r] * (b[r] - a[r])
                    no += 1
            elif halve[r]:
                mid = 0.5 * (a[r] + b[r])
                if mid > a[r] and mid < b[r]:
                    out_s = _grow(out_s, no + 1)
                    out_t = _grow(out_t, no + 1)
                    out_s[no] = s
                    out_t[no] = mid
                    no += 1
                    root2[m2] = root[r]
                    a2[m2] = a[r]
                    b2[m2] = mid
                    a2[nh + m2] = mid
                    b2[nh + m2] = b[r]
                    m2 += 1
        root2[m2 : 2 * m2] = root2[:m2]
        a2[m2 : 2 * m2] = a2[nh : nh + m2]
        b2[m2 : 2 * m2] = b2[nh : nh + m2]
        nroot = 2 * m2
        root, a, b = root2[:nroot], a2[:nroot], b2[:nroot]
    return out_s[:no], out_t[:no], False


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
    resolution = RESOLUTION * float(np.abs(P).max())
    cut = _halvings(A, D, ps, t0, t1, cstart, ncand, pj, X0, X1, beta, resolution)
    new_s, new_t, touching = cut
    if touching or len(new_s) == 0:
        return sid.astype(np.int64), t
    all_s = np.concatenate([sid.astype(np.int64), new_s])
    all_t = np.concatenate([t, new_t])
    order = np.lexsort((all_t, all_s))
    return all_s[order], all_t[order]
