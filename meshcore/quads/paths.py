"""The traversal selections of ``combine`` (:mod:`meshcore.quads.combination`,
step 2): the best-first heap of §8.4.4 (with its binary heap, shared by the
matching's augmenting search), the stack path of §8.4.2 and the frontal order of
Remark 8.8, each one compiled sequential kernel (numba) over the dual graph, and
the 4-cycle swaps that end the matching (``swap_kernel``).

Each takes the triangles' neighbours ``nb`` (m, 3) (-1 on the boundary) and the
candidates' weights ``w`` (m, 3) (negative: not allowed), and fills ``mate`` (m,)
with each combined triangle's partner; the order, the tie-breaking and the
three-quad pattern are described in :mod:`meshcore.quads.combination`.

References
----------
Methods text §8.4.2 (the stack path, Figure 8.12, Remark 8.5), Remark 8.8 (frontal).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["frontal_kernel", "heap_kernel", "stack_kernel", "swap_kernel"]


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


@njit(cache=True)
def _push(hk, hv, n, key, val):
    i = n
    hk[i] = key
    hv[i] = val
    while i > 0:
        p = (i - 1) // 2
        if hk[p] > hk[i] or (hk[p] == hk[i] and hv[p] < hv[i]):
            break
        hk[p], hk[i] = hk[i], hk[p]
        hv[p], hv[i] = hv[i], hv[p]
        i = p
    return n + 1


@njit(cache=True)
def _pop(hk, hv, n):
    n -= 1
    hk[0] = hk[n]
    hv[0] = hv[n]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= n:
            break
        b = a + 1
        c = a
        if b < n and (hk[b] > hk[a] or (hk[b] == hk[a] and hv[b] < hv[a])):
            c = b
        if hk[i] > hk[c] or (hk[i] == hk[c] and hv[i] < hv[c]):
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        i = c
    return n


@njit(cache=True)
def _last_option(nb, w, mate, r):
    for i in range(3):
        u = nb[r, i]
        if u >= 0 and mate[u] < 0 and w[r, i] >= 0:
            return i
    return -1


@njit(cache=True)
def heap_kernel(nb, w, order, mate, urgent):
    """Best-first pairs (§8.4.4): candidate ``h = 3 t + k`` (triangle ``t`` with its
    neighbour ``nb[t, k]``) taken in ``order`` (int64 candidate ids, best first), each
    pair made when both triangles are still unpaired; with ``urgent``, a triangle left
    with one allowed candidate (``w`` >= 0) is paired first, by that candidate's
    weight. Fills ``mate`` (m,) int64 (-1 where unpaired) so that ``mate[mate[t]] ==
    t`` and every pair is an allowed candidate; returns the number of pairs."""
    m = nb.shape[0]
    cnt = np.zeros(m, np.int64)
    for t in range(m):
        for k in range(3):
            if nb[t, k] >= 0 and w[t, k] >= 0:
                cnt[t] += 1
    hk = np.empty(m + 1)
    hv = np.empty(m + 1, np.int64)
    hn = np.int64(0)  # not a literal: one compiled _push / _pop
    for t in range(m):
        if urgent and cnt[t] == 1:
            i = _last_option(nb, w, mate, t)
            hn = _push(hk, hv, hn, w[t, i], 3 * t + i)
    pos = 0
    pairs = 0
    while True:
        if hn > 0:
            h = hv[0]
            hn = _pop(hk, hv, hn)
        elif pos < order.shape[0]:
            h = order[pos]
            pos += 1
        else:
            break
        t = h // 3
        s = nb[t, h % 3]
        if mate[t] >= 0 or mate[s] >= 0:
            continue
        mate[t] = s
        mate[s] = t
        pairs += 1
        for x in (t, s):
            for j in range(3):
                r = nb[x, j]
                if r < 0 or mate[r] >= 0 or w[x, j] < 0:
                    continue
                cnt[r] -= 1
                if urgent and cnt[r] == 1 and hn < m:
                    i = _last_option(nb, w, mate, r)
                    if i >= 0:
                        hn = _push(hk, hv, hn, w[r, i], 3 * r + i)
    return pairs


@njit(cache=True)
def _weight(nb, w, a, b):
    for k in range(3):
        if nb[a, k] == b:
            return w[a, k]
    return -1.0


@njit(cache=True)
def swap_kernel(nb, w, mate, gain, sweeps):
    """Swap pairs (a, b), (c, d) for (a, c), (b, d) when the summed quality rises."""
    m = nb.shape[0]
    swaps = 0
    for _ in range(sweeps):
        changed = 0
        for a in range(m):
            b = mate[a]
            if b < 0:
                continue
            wab = _weight(nb, w, a, b)
            best = gain
            bc = -1
            bd = -1
            for k in range(3):
                c = nb[a, k]
                if c < 0 or c == b or w[a, k] < 0:
                    continue
                d = mate[c]
                if d < 0 or d == a or d == b:
                    continue
                wbd = _weight(nb, w, b, d)
                if wbd < 0:
                    continue
                g = w[a, k] + wbd - wab - _weight(nb, w, c, d)
                if g > best:
                    best = g
                    bc = c
                    bd = d
            if bc >= 0:
                mate[a] = bc
                mate[bc] = a
                mate[b] = bd
                mate[bd] = b
                changed += 1
        swaps += changed
        if changed == 0:
            break
    return swaps
