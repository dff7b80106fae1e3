"""Compiled checks of the paving rows (§8.5.1): exact front-front intersection tests.

Every sign is :func:`~meshcore.geometry.predicates.orient2d_scalar` (through
:func:`meshcore.partition.kernel.touch` and
:func:`meshcore.partition.kernel.orient`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.partition.kernel import orient, strictly_convex_rows, touch

__all__ = ["pairs_touch", "points_in_quads", "strictly_convex_rows"]


@njit(cache=True)
def pairs_touch(P, ea, eb, pairs):
    """(k,) bool: whether the pair (s, t) of segments shares a point other than a
    shared endpoint (or lies on one line overlapping). Segment s is (ea[s], eb[s])."""
    out = np.zeros(len(pairs), np.bool_)
    for r in range(len(pairs)):
        s = pairs[r, 0]
        t = pairs[r, 1]
        a = ea[s]
        b = eb[s]
        c = ea[t]
        d = eb[t]
        if a == c or a == d or b == c or b == d:
            # adjacent segments: they may only meet at the shared end
            if (a == c and b == d) or (a == d and b == c):
                out[r] = True
                continue
            if a == c:
                o, p, q = a, b, d
            elif a == d:
                o, p, q = a, b, c
            elif b == c:
                o, p, q = b, a, d
            else:
                o, p, q = b, a, c
            if orient(P, o, p, q) == 0:
                # collinear: overlapping when both leave o on the same side
                dx1 = P[p, 0] - P[o, 0]
                dy1 = P[p, 1] - P[o, 1]
                dx2 = P[q, 0] - P[o, 0]
                dy2 = P[q, 1] - P[o, 1]
                if dx1 * dx2 + dy1 * dy2 > 0:
                    out[r] = True
            continue
        if touch(P, a, b, c, d):
            out[r] = True
    return out


@njit(cache=True)
def points_in_quads(P, quads, pts, cand):
    """(k,) bool: whether point pts[cand[r, 1]] lies in the closed quad
    quads[cand[r, 0]] without being one of its corners (the quads are convex)."""
    out = np.zeros(len(cand), np.bool_)
    for r in range(len(cand)):
        q = cand[r, 0]
        p = pts[cand[r, 1]]
        corner = False
        for c in range(4):
            if quads[q, c] == p:
                corner = True
        if corner:
            continue
        inside = True
        for c in range(4):
            if orient(P, quads[q, c], quads[q, (c + 1) % 4], p) < 0:
                inside = False
                break
        out[r] = inside
    return out
