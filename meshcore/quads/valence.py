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
tie-break: the summed weight of the pairs). Every pair formed is a strictly
convex candidate of the matching (exact
:func:`~meshcore.geometry.predicates.orient2d`); the smoothing that follows
in ``optimize`` moves the vertices. A plain Python loop over the leftover
triangles (a few per hundred on curved domains), each search at most
``2 ** depth`` paths.
"""

from __future__ import annotations

import numpy as np

from meshcore.mesh import quality

__all__ = ["fewer_defects"]


def _removed_edge(tri, nb, t, s):
    k = int(np.flatnonzero(nb[t] == s)[0])
    return int(tri[t, k]), int(tri[t, (k + 1) % 3])


def fewer_defects(P, tri, nb, w, w_merge, mate, depth: int = 4, rounds: int = 4) -> dict:
    """Re-pair the leftover triangles of a matching so that the all-quad split has
    fewer irregular vertices (module docstring).

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
        ``moved`` (paths applied).

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
    merged = moved = 0

    def delta(changes) -> int:
        d = 0
        touched: dict[int, int] = {}
        for v, s in changes:
            touched[v] = touched.get(v, 0) + s
        for v, s in touched.items():
            d += abs(cnt[v] + s - ideal[v]) - abs(cnt[v] - ideal[v])
        return d

    def search(start):
        """The best path of alternating flips from the leftover triangle ``start``:
        (defect change, -weight change, flips, partner or -1)."""
        best = None
        stack = [(start, [], [], 0.0, {start})]
        while stack:
            free, flips, changes, dq, seen = stack.pop()
            if flips:
                cand = (delta(changes), -dq, flips, -1)
                if best is None or cand[:2] < best[:2]:
                    best = cand
            for k in range(3):
                s = int(nb[free, k])
                if s < 0:
                    continue
                a, b = int(tri[free, k]), int(tri[free, (k + 1) % 3])
                if s in seen:
                    continue
                if mate[s] < 0:
                    if w_merge[free, k] >= 0:
                        ch = [*changes, (a, -1), (b, -1)]
                        cand = (delta(ch) - 2, -(dq + w_merge[free, k]), flips, s)
                        if best is None or cand[:2] < best[:2]:
                            best = cand
                    continue
                if len(flips) == depth or w[free, k] < 0:
                    continue
                s2 = int(mate[s])
                c, d = _removed_edge(tri, nb, s, s2)
                ks = int(np.flatnonzero(nb[s] == s2)[0])
                stack.append(
                    (
                        s2,
                        [*flips, (free, s, s2)],
                        [*changes, (a, -1), (b, -1), (c, 1), (d, 1)],
                        dq + w[free, k] - w[s, ks],
                        seen | {s, s2},
                    )
                )
        return best

    def pair(t, s, sign):
        a, b = _removed_edge(tri, nb, t, s)
        cnt[a] -= sign
        cnt[b] -= sign
        if sign > 0:
            mate[t], mate[s] = s, t
        else:
            mate[t] = mate[s] = -1

    def apply(start, flips, partner):
        for free, s, s2 in flips:
            pair(s, s2, -1)
            pair(free, s, 1)
        if partner >= 0:
            pair(flips[-1][2] if flips else start, partner, 1)

    for _ in range(rounds):
        applied = 0
        for T in np.flatnonzero(mate < 0).tolist():
            if mate[T] >= 0:
                continue
            best = search(T)
            if best is None or best[0] >= 0:
                continue
            apply(T, best[2], best[3])
            merged += best[3] >= 0
            moved += len(best[2]) > 0
            applied += 1
        if not applied:
            break
    return {
        "defect_before": before,
        "defect_after": defect(),
        "merged": merged,
        "moved": moved,
    }
