"""The two traversal selections of ``combine`` (:mod:`meshcore.quads.combination`,
step 2): the stack path of §8.4.2 and the frontal order of Remark 8.8, each one
compiled sequential kernel (numba) over the dual graph.

Both take the triangles' neighbours ``nb`` (m, 3) (-1 on the boundary) and the
candidates' weights ``w`` (m, 3) (negative: not allowed), and fill ``mate`` (m,)
with each combined triangle's partner; the order, the tie-breaking and the
three-quad pattern are described in :mod:`meshcore.quads.combination`.

References
----------
Methods text §8.4.2 (the stack path, Figure 8.12, Remark 8.5), Remark 8.8 (frontal).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["frontal_kernel", "stack_kernel"]


@njit(cache=True)
def _local_index(nb, t, s):
    for k in range(3):
        if nb[t, k] == s:
            return k
    return -1


@njit(cache=True)
def stack_kernel(nb, w, w3, starts, start_edge, mate, triples):
    """The stack path of §8.4.2; returns the number of three-quad patterns."""
    m = nb.shape[0]
    color = np.zeros(m, np.bool_)
    active = np.ones(m, np.bool_)
    father = np.full(m, -1, np.int64)
    came = np.zeros(m, np.int64)
    tried = np.zeros(m, np.int64)
    stack = np.empty(m, np.int64)
    ntr = 0
    for s0 in range(starts.shape[0]):
        st = starts[s0]
        if color[st]:
            continue
        color[st] = True
        came[st] = start_edge[s0]
        sp = 1
        stack[0] = st
        while sp > 0:
            K = stack[sp - 1]
            pushed = False
            while tried[K] < 3:
                k = (came[K] + 1 + tried[K]) % 3
                tried[K] += 1
                N = nb[K, k]
                if N >= 0 and not color[N] and w[K, k] >= 0:
                    color[N] = True
                    father[N] = K
                    came[N] = _local_index(nb, N, K)
                    stack[sp] = N
                    sp += 1
                    pushed = True
                    break
            if pushed:
                continue
            sp -= 1
            if not active[K]:
                continue
            nc = 0
            c0 = -1
            c1 = -1
            for k in range(3):
                N = nb[K, k]
                if N >= 0 and father[N] == K and active[N]:
                    if nc == 0:
                        c0 = k
                    else:
                        c1 = k
                    nc += 1
            F = father[K]
            kf = -1 if F < 0 else _local_index(nb, K, F)
            if nc == 0:
                continue
            if nc == 2 and F >= 0 and active[F] and w3[K]:
                triples[ntr, 0] = K
                for k in range(3):
                    triples[ntr, 1 + k] = nb[K, k]
                    active[nb[K, k]] = False
                active[K] = False
                ntr += 1
                continue
            kc = c0
            if nc == 2 and w[K, c1] > w[K, c0]:
                kc = c1
            if w[K, kc] >= 0:
                N = nb[K, kc]
            elif kf >= 0 and active[F] and w[K, kf] >= 0:
                N = F
            else:
                continue
            mate[K] = N
            mate[N] = K
            active[K] = False
            active[N] = False
    return ntr


@njit(cache=True)
def _enqueue_neighbours(nb, t, queued, queue, qt):
    """Queue the neighbours of triangle ``t`` not queued yet; the new queue tail."""
    for k in range(3):
        r = nb[t, k]
        if r >= 0 and not queued[r]:
            queued[r] = True
            queue[qt] = r
            qt += 1
    return qt


@njit(cache=True)
def frontal_kernel(nb, w, seeds, mate):
    """Remark 8.8: combine in breadth-first order from the boundary inward."""
    m = nb.shape[0]
    queued = np.zeros(m, np.bool_)
    queue = np.empty(m, np.int64)
    qh = 0
    qt = 0
    for i in range(seeds.shape[0]):
        t = seeds[i]
        if not queued[t]:
            queued[t] = True
            queue[qt] = t
            qt += 1
    nxt = 0
    pairs = 0
    while True:
        if qh == qt:  # a part with no boundary (a closed surface): seed it
            while nxt < m and queued[nxt]:
                nxt += 1
            if nxt == m:
                break
            queued[nxt] = True
            queue[qt] = nxt
            qt += 1
        t = queue[qh]
        qh += 1
        if mate[t] < 0:
            best = -1
            for k in range(3):
                s = nb[t, k]
                if s >= 0 and mate[s] < 0 and w[t, k] >= 0 and (best < 0 or w[t, k] > w[t, best]):
                    best = k
            if best >= 0:
                s = nb[t, best]
                mate[t] = s
                mate[s] = t
                pairs += 1
                qt = _enqueue_neighbours(nb, s, queued, queue, qt)
        qt = _enqueue_neighbours(nb, t, queued, queue, qt)
    return pairs
