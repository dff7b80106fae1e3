r"""Fewer irregular vertices in ``combine``'s all-quad meshes: a topological clean-up
of the pairing, before the split (§8.4.3, "the relaxation of the degree of the
internal vertices").

With ``all_quad`` every cell of the mixed mesh is split at its vertex
centroid and edge midpoints (Figure 8.13), so the valence of every final
vertex is known before the split:

* a coarse vertex keeps one final quad per coarse cell around it;
* an edge midpoint is held by two final quads per cell on either side
  (four inside, two on the boundary: always regular);
* a quad's centre has valence 4, a leftover triangle's centre valence 3.

The final mesh's *defect* ``sum |valence - ideal|`` (ideal 4 inside, a
boundary vertex's angle in right angles) is therefore
``sum over coarse vertices |cells - ideal| + leftover triangles``, a
function of the pairing alone. Each defect costs at least one unit of summed
quality (8.4) whatever the smoothing does: the three corners at a valence-3
vertex add up to 360 degrees, so ``sum (theta - 90) / 90`` over them is 1,
and the five of a valence-5 vertex give ``sum (90 - theta) / 90 = 1``. On
the disk of ``benchmarks/quads.py`` at size 0.1 the 38 irregular vertices
(21 of valence 3, 20 of them leftover centres) held the mean at 0.878 while
the regular quads averaged 0.95.

The matching (§8.4.4 and Edmonds' paths) minimizes the number of leftover
triangles among allowed pairs, not the defect. Here each leftover triangle
``T`` searches the alternating paths that start at it, ``T`` pairing with
a neighbour ``t1`` whose mate ``t2`` is freed, ``t2`` pairing on, and so on
up to ``depth`` flips (the "path of flips" of the topological clean-up
literature: Staten and Canann's edge swaps, here on the dual graph where a
flip is one alternating step). Each prefix ends in one of:

* the freed triangle stays a leftover (the triangle has moved: the valences
  of the four ends of the two removed edges changed by one each);
* the freed triangle pairs with another leftover triangle next to it, whose
  pair was refused by the flat-corner bound of ``all_quad`` (45 degrees) but
  passes the given wider one (``merge``): two valence-3 centres disappear,
  the two ends of their common edge lose one cell each.

The path of least defect is taken when it lowers the defect (a quality
tie-break: the summed weight of the pairs).

A boundary vertex holding more cells than its ideal (a straight boundary point
in three or four cells) is never reached from a leftover triangle when none is
near. Each such vertex's paired triangles ``t`` (mate ``s``) are therefore
searched from too: ``(t, s)`` is unpaired (both leftover, the ends of their
edge gaining a cell), the paths from ``t`` are searched as above, one ending by
pairing with ``s`` closing an alternating cycle, and the best is taken when the
defect counted from before the unpairing goes down; else the pair is restored.

Every pair formed is a strictly convex candidate of the matching (exact
:func:`~meshcore.geometry.predicates.orient2d`); the smoothing that follows
in ``optimize`` moves the vertices. One compiled loop over the leftover
triangles (a few per hundred on curved domains) and such vertices, each
search at most ``2 ** depth`` paths (the Python loop it replaces spent 28 of the 77 CPU s of
``combine`` on a 100k-vertex circle at size 0.05, same pairs).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.mesh import quality
from meshcore.mesh.topology import group_slots

__all__ = ["fewer_defects"]


@njit(cache=True)
def _edge_to(tri, nb, t, s):
    """The local edge of triangle ``t`` shared with its neighbour ``s``, and its two ends."""
    k = 0
    while nb[t, k] != s:
        k += 1
    return k, tri[t, k], tri[t, (k + 1) % 3]


@njit(cache=True)
def _delta(cnt, ideal, vs, signs, nch):
    """The change of ``sum |cnt - ideal|`` when vertex ``vs[i]`` gains ``signs[i]`` cells."""
    d = 0
    for i in range(nch):
        v = vs[i]
        first = True
        for j in range(i):
            if vs[j] == v:
                first = False
                break
        if not first:
            continue
        s = 0
        for j in range(i, nch):
            if vs[j] == v:
                s += signs[j]
        d += abs(cnt[v] + s - ideal[v]) - abs(cnt[v] - ideal[v])
    return d


@njit(cache=True)
def _path_changes(tri, nb, node_flip, node_parent, x, vs, signs):
    """The valence changes of the flips from the search's root to node ``x`` (each flip
    removes the edge between ``free`` and ``s`` and restores that between ``s`` and
    ``s2``); returns their count."""
    nch = 0
    while node_parent[x] >= 0:
        free, s, s2 = node_flip[x, 0], node_flip[x, 1], node_flip[x, 2]
        _, a, b = _edge_to(tri, nb, free, s)
        _, c, d = _edge_to(tri, nb, s, s2)
        vs[nch], vs[nch + 1], vs[nch + 2], vs[nch + 3] = a, b, c, d
        signs[nch], signs[nch + 1], signs[nch + 2], signs[nch + 3] = -1, -1, 1, 1
        nch += 4
        x = node_parent[x]
    return nch


@njit(cache=True)
def _search(tri, nb, w, w_merge, mate, cnt, ideal, start, depth, nodes):
    """The best path of alternating flips from the leftover triangle ``start``
    (module docstring): the depth-first search of the paths, last neighbour first,
    a candidate kept when (defect change, -weight change) is lexicographically
    smaller than the best so far. Returns (found, defect change, node of the path's
    end, partner or -1); the path is the chain of ``node_parent`` from that node."""
    node_free, node_parent, node_depth, node_dq, node_flip, stack = nodes
    vs = np.empty(4 * depth + 2, np.int64)
    signs = np.empty(4 * depth + 2, np.int64)
    seen = np.empty(2 * depth + 1, np.int64)
    found = False
    bd, bq, bnode, bpartner = 0, 0.0, -1, -1
    node_free[0], node_parent[0], node_depth[0], node_dq[0] = start, -1, 0, 0.0
    nn, ns = 1, 1
    stack[0] = 0
    while ns > 0:
        ns -= 1
        x = stack[ns]
        free, dq, dep = node_free[x], node_dq[x], node_depth[x]
        nch = _path_changes(tri, nb, node_flip, node_parent, x, vs, signs)
        if dep > 0:
            d = _delta(cnt, ideal, vs, signs, nch)
            if not found or d < bd or (d == bd and -dq < bq):
                found, bd, bq, bnode, bpartner = True, d, -dq, x, -1
        # the triangles of the path: the start and each flip's s and s2
        nseen = 0
        y = x
        while node_parent[y] >= 0:
            seen[nseen], seen[nseen + 1] = node_flip[y, 1], node_flip[y, 2]
            nseen += 2
            y = node_parent[y]
        seen[nseen] = start
        nseen += 1
        for k in range(3):
            s = nb[free, k]
            if s < 0:
                continue
            a, b = tri[free, k], tri[free, (k + 1) % 3]
            hit = False
            for j in range(nseen):
                if seen[j] == s:
                    hit = True
            if hit:
                continue
            if mate[s] < 0:
                if w_merge[free, k] >= 0:
                    vs[nch], vs[nch + 1] = a, b
                    signs[nch], signs[nch + 1] = -1, -1
                    d = _delta(cnt, ideal, vs, signs, nch + 2) - 2
                    q = -(dq + w_merge[free, k])
                    if not found or d < bd or (d == bd and q < bq):
                        found, bd, bq, bnode, bpartner = True, d, q, x, s
                continue
            if dep == depth or w[free, k] < 0:
                continue
            s2 = mate[s]
            ks, _, _ = _edge_to(tri, nb, s, s2)
            node_free[nn], node_parent[nn], node_depth[nn] = s2, x, dep + 1
            node_dq[nn] = dq + w[free, k] - w[s, ks]
            node_flip[nn, 0], node_flip[nn, 1], node_flip[nn, 2] = free, s, s2
            stack[ns] = nn
            ns += 1
            nn += 1
    return found, bd, bnode, bpartner


@njit(cache=True)
def _pair(tri, nb, mate, cnt, t, s, sign):
    _, a, b = _edge_to(tri, nb, t, s)
    cnt[a] -= sign
    cnt[b] -= sign
    if sign > 0:
        mate[t], mate[s] = s, t
    else:
        mate[t] = -1
        mate[s] = -1


@njit(cache=True)
def _apply(tri, nb, mate, cnt, node_parent, node_flip, path, start, x, partner):
    """Make the path of flips from ``start`` to node ``x`` (:func:`_search`), then pair its
    last freed triangle with ``partner`` (if >= 0). Returns the number of flips."""
    npath = 0
    while node_parent[x] >= 0:
        path[npath] = x
        npath += 1
        x = node_parent[x]
    last = start
    for i in range(npath - 1, -1, -1):  # the flips from the start on
        free, s, s2 = node_flip[path[i], 0], node_flip[path[i], 1], node_flip[path[i], 2]
        _pair(tri, nb, mate, cnt, s, s2, -1)
        _pair(tri, nb, mate, cnt, free, s, 1)
        last = s2
    if partner >= 0:
        _pair(tri, nb, mate, cnt, last, partner, 1)
    return npath


@njit(cache=True)
def _fewer_defects_kernel(tri, nb, w, w_merge, mate, cnt, ideal, roots, vptr, vtri, depth, rounds):
    """The rounds of :func:`fewer_defects` (compiled): each leftover triangle, in
    increasing order, takes its best path (:func:`_search`) when it lowers the
    defect; then each vertex of ``roots`` still holding more cells than its ideal
    (its triangles ``vtri[vptr[v]:vptr[v + 1]]``) has each of its paired triangles
    ``t`` unpaired from its mate ``s`` and searched from, ``s`` a leftover the path
    may end at (an alternating cycle), the best path taken when the defect counted
    from before the unpairing goes down, else the pair restored.
    Returns (merged, moved)."""
    cap = 1
    for _ in range(depth + 1):
        cap = 3 * cap + 1
    nodes = (
        np.empty(cap, np.int64),
        np.empty(cap, np.int64),
        np.empty(cap, np.int64),
        np.empty(cap),
        np.empty((cap, 3), np.int64),
        np.empty(cap, np.int64),
    )
    node_parent, node_flip = nodes[1], nodes[4]
    path = np.empty(depth + 1, np.int64)
    ends = np.empty(2, np.int64)
    ones = np.ones(2, np.int64)
    merged = moved = 0
    for _ in range(rounds):
        applied = 0
        for T in np.flatnonzero(mate < 0):
            if mate[T] >= 0:
                continue
            found, d, x, partner = _search(tri, nb, w, w_merge, mate, cnt, ideal, T, depth, nodes)
            if not found or d >= 0:
                continue
            npath = _apply(tri, nb, mate, cnt, node_parent, node_flip, path, T, x, partner)
            merged += int(partner >= 0)
            moved += int(npath > 0)
            applied += 1
        for v in roots:
            for j in range(vptr[v], vptr[v + 1]):
                if cnt[v] <= ideal[v]:
                    break
                t = vtri[j]
                s = mate[t]
                if s < 0:
                    continue
                _, ends[0], ends[1] = _edge_to(tri, nb, t, s)
                d0 = _delta(cnt, ideal, ends, ones, 2) + 2  # the two ends gain a cell, 2 leftovers
                _pair(tri, nb, mate, cnt, t, s, -1)
                found, d, x, partner = _search(
                    tri, nb, w, w_merge, mate, cnt, ideal, t, depth, nodes
                )
                if not found or d0 + d >= 0:
                    _pair(tri, nb, mate, cnt, t, s, 1)
                    continue
                _apply(tri, nb, mate, cnt, node_parent, node_flip, path, t, x, partner)
                merged += int(partner >= 0)
                moved += 1  # (t, s) unpaired: a re-paired vertex, flips or none
                applied += 1
        if not applied:
            break
    return merged, moved


def fewer_defects(P, tri, nb, w, w_merge, mate, depth: int = 4, rounds: int = 4) -> dict:
    """Re-pair the leftover triangles of a matching, and the triangles at boundary
    vertices holding more cells than their ideal, so that the all-quad split has
    fewer irregular vertices (module docstring); the defect never goes up.

    Parameters
    ----------
    P : (n, 2) float64
    tri : (m, 3) int64
        Counter-clockwise triangles.
    nb : (m, 3) int64
        The neighbour across edge ``(tri[t, k], tri[t, k + 1])``, -1 on the boundary.
    w : (m, 3) float64
        Weights of the allowed pairs (< 0: refused), the matching's.
    w_merge : (m, 3) float64
        Weights under which two leftover triangles may pair (a wider flat bound).
    mate : (m,) int64
        The pairing, changed in place (-1: leftover).
    depth : int
        Alternating flips per path at most.
    rounds : int
        Passes over the leftover triangles at most.

    Returns
    -------
    dict
        ``defect_before``, ``defect_after``, ``merged`` (leftover pairs made),
        ``moved`` (other paths applied: a moved leftover triangle or a re-paired
        boundary vertex).

    References
    ----------
    §8.4.3 (the valence criterion of the operators), Figure 8.13 (the split).
    """
    n, m = len(P), len(tri)
    cnt = np.bincount(tri.ravel(), minlength=n).astype(np.int64)
    t = np.flatnonzero((mate >= 0) & (np.arange(m) < mate))
    k = np.argmax(nb[t] == mate[t][:, None], axis=1)
    cnt -= np.bincount(tri[t, k], minlength=n) + np.bincount(tri[t, (k + 1) % 3], minlength=n)
    on_boundary = np.zeros(n, bool)
    tb, kb = np.nonzero(nb < 0)
    on_boundary[tri[tb, kb]] = True
    on_boundary[tri[tb, (kb + 1) % 3]] = True
    total = np.zeros(n)
    np.add.at(total, tri.ravel(), quality.triangle_angles(P, tri).ravel())
    ideal = np.where(on_boundary, np.maximum(np.rint(total / 90.0), 1), 4).astype(np.int64)
    used = np.zeros(n, bool)
    used[tri.ravel()] = True

    def defect() -> int:
        return int(np.abs(cnt - ideal)[used].sum() + np.count_nonzero(mate < 0))

    before = defect()
    roots = np.flatnonzero(on_boundary & (cnt > ideal))
    order, vptr = group_slots(tri.ravel(), n)  # each vertex's triangles
    vtri = order // 3
    merged, moved = _fewer_defects_kernel(
        tri, nb, w, w_merge, mate, cnt, ideal, roots, vptr, vtri, depth, rounds
    )
    return {
        "defect_before": before,
        "defect_after": defect(),
        "merged": merged,
        "moved": moved,
    }
