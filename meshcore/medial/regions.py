"""Region-level changes to a medial-axis partition for its quads (§9.7.1, §9.7.2).

The text leaves the partition free ("numerous variations can be used in order to
optimize such a partition"); two of its regions' shapes make poor quads, and are
changed here:

* a *spike* (an input corner under :data:`KITE_ANGLE`) inside a larger region: its
  tip became the corner of one coarse quad as long as the spike, whose transfinite
  fill repeated the tip's angle along its diagonal. :func:`spike_chords` cuts it off
  by a chord, so that it is a triangle region of its own (subdivided as a small kite
  at the tip and two strips along its sides, :mod:`meshcore.medial.fill`);
* a boundary point met by many cuts: each region meeting there puts a coarse
  quad at the point, so that reflex corners of 280-290 degrees were held by 6-7
  quads, and a straight point of a gear's tooth gap by 4 (45 degrees each).
  :func:`reflex_merged` keeps about one region per :data:`REFLEX_SHARE` degrees at a
  reflex input corner and one per :data:`BOUNDARY_SHARE` degrees elsewhere.

:func:`input_index` and :func:`input_fans` find the input vertices among a mesh's
points and count their quads (the optimization of the fill keeps them).

References
----------
Methods text §9.7.1 (domain partitioning), §9.7.2 (quad mesh construction).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from meshcore.geometry.predicates import orient2d
from meshcore.medial.axis import MedialAxis
from meshcore.mesh.topology import inverse_permutation

__all__ = [
    "BOUNDARY_SHARE",
    "KITE_ANGLE",
    "MERGE_BEND",
    "MERGE_CORNER",
    "REFLEX_SHARE",
    "input_fans",
    "input_index",
    "reflex_merged",
    "small_merged",
    "spike_chords",
    "turns",
]

_BOUNDARY, _AXIS, _CUT = 0, 1, 2

#: An input corner under this angle (degrees) is a spike: cut off into a triangle
#: region of its own (:func:`spike_chords`), subdivided as a small coarse quad at the
#: tip (a kite) and two strips along its sides
#: (:data:`meshcore.medial.fill.KITE_SIDE`). The midpoint subdivision's kite
#: there has corners (alpha, 90, 180 - alpha, 90), over 135 degrees, and its fill
#: repeats the angle alpha along its diagonal.
KITE_ANGLE = 45.0
#: :func:`spike_chords` cuts a spike at its base (between the reflex input corners
#: nearest its tip) only where that chord is at most this times its distance to the tip.
THIN_BASE = 0.25
#: At a reflex input corner, one region (one coarse quad) per this many degrees of its
#: angle: the others' cuts there are removed (:func:`reflex_merged`).
REFLEX_SHARE = 135.0
#: At any other boundary sample, one region per this many degrees: four regions at a
#: straight boundary point of a gear's tooth gap gave its quads 45 degrees there.
BOUNDARY_SHARE = 60.0
#: :func:`small_merged` keeps a merged region's corners at the merged chain's ends
#: under this angle (degrees): a reflex region corner folds its coarse quads.
MERGE_CORNER = 170.0
#: :func:`small_merged`: an axis node that is no longer a corner lies on a side bent
#: by at most this (degrees) in every region around it.
MERGE_BEND = 30.0


def turns(ax: MedialAxis) -> np.ndarray:
    """Turning angle (radians, positive to the left) of the boundary at each sample."""
    a = ax.samples - ax.samples[inverse_permutation(ax.succ)]
    b = ax.samples[ax.succ] - ax.samples
    return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1))


def at_input_vertex(ax: MedialAxis) -> np.ndarray:
    """(p,) bool: the boundary samples that are input vertices (between two input
    segments)."""
    src = ax.segment_source
    return src[inverse_permutation(ax.succ)] != src


def _chord_inside(P: np.ndarray, verts: np.ndarray, i: int, j: int) -> bool:
    """Whether the chord from cycle vertex ``i`` to ``j`` of a counter-clockwise
    cycle leaves both ends into the region and touches no cycle edge but at its
    ends (exact :func:`~meshcore.geometry.predicates.orient2d`)."""
    n = len(verts)
    a, b = P[verts[i]], P[verts[j]]
    for k, t in ((i, b), (j, a)):  # strictly inside the interior angle at each end
        prv, v, nxt = P[verts[k - 1]], P[verts[k]], P[verts[(k + 1) % n]]
        turn = orient2d(prv, v, nxt)
        s1, s2 = orient2d(v, nxt, t), orient2d(prv, v, t)
        if not ((s1 > 0 and s2 > 0) if turn >= 0 else (s1 > 0 or s2 > 0)):
            return False
    e = np.arange(n)
    e = e[(e != i) & (e != j) & ((e + 1) % n != i) & ((e + 1) % n != j)]
    c, d = P[verts[e]], P[verts[(e + 1) % n]]
    A, B = np.broadcast_to(a, c.shape), np.broadcast_to(b, c.shape)
    o1, o2 = orient2d(A, B, c).astype(np.int64), orient2d(A, B, d).astype(np.int64)
    o3, o4 = orient2d(c, d, A).astype(np.int64), orient2d(c, d, B).astype(np.int64)
    apart = (o1 * o2 > 0) | (o3 * o4 > 0)  # collinear pieces count as touching
    return bool(apart.all())


def spike_chords(points, cycles, corners, kinds, turn):
    """The regions with every input spike cut off (:data:`KITE_ANGLE`): a region
    vertex that is not one of its corners, where the boundary turns by more than
    ``180 - KITE_ANGLE`` degrees, is cut off by the chord between the region corners
    before and after it (the two samples the node's circle touches at the spike's
    base), when the chord lies inside and leaves another corner on the far side; else
    (those corners on either side of the spike's body: the chord crosses it) by the
    chord between the reflex input corners (turning by more than 1 degree) nearest the
    tip on each side, its base, when that one lies inside and the spike is thin there
    (the chord at most :data:`THIN_BASE` times its distance to the tip: about 14
    degrees; issue star 22 at size 0.1, a 4-degree spike: least quality 0.31 -> 0.43;
    without the bound, other stars' partitions were cut across wider bodies, and stars
    20 at 0.1 and 9 at 0.15 fell from 0.53 and 0.58 to 0.44 and 0.45). The
    spike then is a triangle region of its own, its tip one of its corners, subdivided
    as a kite at the tip and two strips along its sides; cut with the rest, the tip's
    coarse quad was as long as the spike and its fill repeated the tip's angle along
    its diagonal.
    Returns the cycles, corner flags, edge kinds and the chords (vertex pairs)."""
    spike = turn > math.pi - math.radians(KITE_ANGLE)
    reflex = turn < -math.radians(1.0)  # a reflex input corner (not a rounding turn)
    p = len(turn)
    todo = list(zip(cycles, corners, kinds, strict=True))
    out, chords = [], []
    while todo:
        verts, corner, kind = todo.pop()
        n = len(verts)
        tips = np.flatnonzero((verts < p) & ~corner)
        tips = tips[spike[verts[tips]]]
        at = np.flatnonzero(corner)
        at_reflex = (verts < p) & reflex[np.minimum(verts, p - 1)]
        cut = None
        for t in tips:  # a loop over a region's spikes (a few)
            k = np.searchsorted(at, t)
            i, j = int(at[k - 1]), int(at[k % len(at)])  # corners before and after
            if len(at) >= 3 and _chord_inside(points, verts, i, j):
                cut = (i, j, int(t))
                break
            # else from the spike's base: the reflex samples nearest the tip on each side
            before = (t - np.arange(1, (t - i) % n)) % n  # t - 1 ... i + 1
            after = (t + np.arange(1, (j - t) % n)) % n  # t + 1 ... j - 1
            before, after = before[at_reflex[before]], after[at_reflex[after]]
            i2 = int(before[0]) if len(before) else i
            j2 = int(after[0]) if len(after) else j
            a, b, tip = points[verts[i2]], points[verts[j2]], points[verts[t]]
            thin = np.hypot(*(b - a)) <= THIN_BASE * np.hypot(*((a + b) / 2 - tip))
            if thin and (i2, j2) != (i, j) and len(at) + (i2 != i) + (j2 != j) >= 3:
                if _chord_inside(points, verts, i2, j2):
                    cut = (i2, j2, int(t))
                    break
        if cut is None:
            out.append((verts, corner, kind))
            continue
        i, j, t = cut
        near = np.roll(np.arange(n), -i)[: (j - i) % n + 1]  # i ... tip ... j
        far = np.roll(np.arange(n), -j)[: (i - j) % n + 1]  # j ... i
        for part in (near, far):
            flag = corner[part]
            flag[[0, -1]] = True  # the chord's ends
            flag[part == t] = True  # the tip: a corner of the spike's region
            todo.append((verts[part], flag, np.append(kind[part[:-1]], np.int8(_CUT))))
        chords.append((int(verts[i]), int(verts[j])))
    cycles, corners, kinds = zip(*out, strict=True) if out else ((), (), ())
    return list(cycles), list(corners), list(kinds), chords


def reflex_merged(ax: MedialAxis, pts: np.ndarray, cycles, corners, kinds, share: float | None):
    """Regions merged at boundary points that too many of them meet: a reflex input
    corner of angle theta keeps ``ceil(theta / REFLEX_SHARE) - 1`` of its cuts from
    axis nodes, any other boundary sample ``ceil(theta / share) - 1`` (none when
    ``share`` is None; :data:`BOUNDARY_SHARE` where the count allows) (those
    leaving the most even angles between them); the two regions on each side of
    another are merged, when every region keeps three corners or more and the merged
    cycle is simple. Each region meeting there puts a coarse quad at the point: on
    32 random stars, corners of 281 and 291 degrees were held by 6 and 7 quads (41
    degrees each: least quality 0.36 there); on gears of 6, 10 and 12 teeth at size
    0.1, straight points of the tooth gaps by 4 (least 0.44-0.50 there; none under
    0.5 with 3). Returns the cycles, corner flags, edge kinds and the removed cuts
    (vertex pairs)."""
    p = len(ax.samples)
    turn = turns(ax)
    cycles, corners, kinds = list(cycles), list(corners), list(kinds)
    und = {}  # undirected edge -> how many cycles use it
    for c in cycles:
        for a, b in zip(c, np.roll(c, -1), strict=True):
            und[(min(a, b), max(a, b))] = und.get((min(a, b), max(a, b)), 0) + 1
    degree = np.zeros(len(pts), np.int64)
    for a, b in und:
        degree[a] += 1
        degree[b] += 1
    reflex = at_input_vertex(ax) & (turn < 0)
    ends: dict[int, list[int]] = {}  # per sample, the cuts from axis nodes (not the chords)
    for (a, b), n in und.items():
        if n == 2 and min(a, b) < p <= max(a, b):
            ends.setdefault(int(min(a, b)), []).append(int(max(a, b)))
    removed = []
    for v in sorted(ends):  # a loop over the samples that cuts reach
        theta = math.pi - turn[v]
        out = pts[ax.succ[v]] - pts[v]
        cut_ends = ends[v]
        if not reflex[v] and share is None:
            continue
        keep = math.ceil(math.degrees(theta) / (REFLEX_SHARE if reflex[v] else share) - 1e-9) - 1
        if len(cut_ends) <= keep:
            continue
        d = pts[cut_ends] - pts[v]
        phi = np.mod(np.arctan2(out[0] * d[:, 1] - out[1] * d[:, 0], d @ out), 2 * np.pi)
        best = None
        for kept in itertools.combinations(range(len(cut_ends)), keep):
            stops = np.concatenate([[0.0], np.sort(phi[list(kept)]), [theta]])
            gap = float(np.diff(stops).max())
            if best is None or gap < best[0]:
                best = (gap, set(kept))
        for i in np.argsort(phi).tolist():
            if i in best[1]:
                continue
            merged = _merged_at(cycles, corners, kinds, degree, v, cut_ends[i])
            if merged is not None:
                cycles, corners, kinds = merged
                removed.append((v, cut_ends[i]))
    return cycles, corners, kinds, removed


def _merged_at(cycles, corners, kinds, degree, v: int, w: int):
    """The cycles with the two on either side of the edge ``v - w`` merged (None when
    the merged cycle is not simple or a region would keep fewer than three corners);
    ``degree`` is lowered at ``v`` and ``w`` when it is done."""
    side = {}
    for r, c in enumerate(cycles):
        at = np.flatnonzero(c == v)
        if at.size and c[(at[0] + 1) % len(c)] == w:
            side["a"] = (r, int(at[0]))  # v -> w in region r
        elif at.size and c[at[0] - 1] == w:
            side["b"] = (r, int(at[0]))  # w -> v in region r
    if len(side) < 2 or side["a"][0] == side["b"][0]:
        return None
    (ra, ia), (rb, ib) = side["a"], side["b"]
    A, B = cycles[ra], cycles[rb]
    sa = np.roll(np.arange(len(A)), -(ia + 1))  # w ... v along A
    sb = np.roll(np.arange(len(B)), -ib)  # v ... w along B
    verts = np.concatenate([A[sa], B[sb][1:-1]])
    if len(np.unique(verts)) < len(verts):
        return None
    kind = np.concatenate([kinds[ra][sa[:-1]], kinds[rb][sb[:-1]]])
    flag = np.concatenate([corners[ra][sa], corners[rb][sb][1:-1]])
    deg = degree.copy()
    deg[[v, w]] -= 1
    low = [x for x in (v, w) if deg[x] < 3]
    new_cycles, new_corners, new_kinds = [], [], []
    for r, (c, f, k) in enumerate(zip(cycles, corners, kinds, strict=True)):
        if r in (ra, rb):
            continue
        new_cycles.append(c)
        new_corners.append(f & ~np.isin(c, low))
        new_kinds.append(k)
    new_cycles.append(verts)
    new_corners.append(flag & ~np.isin(verts, low))
    new_kinds.append(kind)
    if min(int(f.sum()) for f in new_corners) < 3:
        return None
    degree[[v, w]] -= 1
    return new_cycles, new_corners, new_kinds


def input_index(P: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    """(n,) int: the input vertex each point ``P`` is (exact coordinate match), -1 for
    the others: the input corners of a quad mesh, fixed in its optimization (§9.7.2)."""
    m = len(inputs)
    both = np.concatenate([np.asarray(inputs, np.float64).reshape(-1, 2), P])
    order = np.lexsort(both.T[::-1])  # x, then y: equal points next to each other
    key = both[order]
    group = np.concatenate([[0], np.cumsum((key[1:] != key[:-1]).any(axis=1))])
    k = np.full(group[-1] + 1 if len(group) else 0, -1, np.int64)
    np.maximum.at(k, group[order < m], order[order < m])  # (equal inputs: the last)
    at = np.empty(len(P), np.int64)
    at[order[order >= m] - m] = k[group[order >= m]]
    return at


def input_fans(P: np.ndarray, Q: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    """(len(inputs),) int: how many quads ``Q`` over ``P`` hold each input vertex (a
    reflex corner's quads, §9.7.2: an optimization must not take one away)."""
    at = input_index(P, inputs)[Q.ravel()]
    return np.bincount(at[at >= 0], minlength=len(inputs))


def _chain_merged(A, fa, ka, B, fb, kb):
    """The cycle of regions ``A`` and ``B`` (counter-clockwise vertex cycles, corner flags
    ``fa``, ``fb``, edge kinds ``ka``, ``kb``) joined across the edges they share, when
    those are one chain: the merged cycle, its corner flags (the chain's ends keep
    theirs) and kinds, or None (shared edges in several chains, none, or a merged cycle
    that passes a vertex twice)."""
    na, nb = len(A), len(B)
    ea = {(int(A[i]), int(A[(i + 1) % na])): i for i in range(na)}
    shared = np.array([(int(B[(i + 1) % nb]), int(B[i])) in ea for i in range(nb)])
    if not shared.any() or shared.all():
        return None
    runs = np.flatnonzero(shared & ~np.roll(shared, 1))  # first shared edge of each run in B
    if len(runs) != 1:
        return None
    m = int(shared.sum())
    s = int(runs[0])  # B's chain: vertices s ... s + m (B's edges s ... s + m - 1)
    # in A the chain runs from B[s + m] back to B[s]: A from B[s] on to B[s + m] (its
    # unshared edges), then B from B[s + m] on to B[s]
    ia = (ea[(int(B[(s + 1) % nb]), int(B[s]))] + 1) % na
    ra = np.roll(np.arange(na), -ia)[: na - m + 1]
    rb = np.roll(np.arange(nb), -((s + m) % nb))[: nb - m + 1]
    verts = np.concatenate([A[ra], B[rb][1:-1]])
    if len(np.unique(verts)) < len(verts):
        return None
    flag = np.concatenate([fa[ra], fb[rb][1:-1]])
    kind = np.concatenate([ka[ra[:-1]], kb[rb[:-1]]])
    return verts, flag, kind


def _angle_at(points, verts, i) -> float:
    """Interior angle (degrees) of the counter-clockwise cycle ``verts`` at its vertex ``i``."""
    a, v, b = points[verts[i - 1]], points[verts[i]], points[verts[(i + 1) % len(verts)]]
    d1, d2 = b - v, a - v
    return math.degrees(math.atan2(d1[0] * d2[1] - d1[1] * d2[0], float(d1 @ d2)) % (2 * math.pi))


def _merged_pair(points, p, reg, degree, r, o):
    """Regions ``r`` and ``o`` of ``reg`` (id -> cycle, corner flags, kinds) merged
    (:func:`_chain_merged`): the merged cycle, corner flags, kinds and the ids of the
    points no longer corners anywhere (fewer than three edges left), or None when the merge is
    refused (:func:`small_merged`)."""
    got = _chain_merged(*reg[r], *reg[o])
    if got is None:
        return None
    verts, flag, kind = got
    ends = np.flatnonzero(np.isin(verts, reg[r][0]) & np.isin(verts, reg[o][0])).tolist()
    low = np.array([verts[i] for i in ends if degree[verts[i]] - 1 < 3], np.int64)
    flag = flag & ~np.isin(verts, low)  # (low: the vertices no longer corners anywhere)
    if int(flag.sum()) < 3:
        return None
    for i in ends:
        angle = _angle_at(points, verts, i)
        if flag[i] and angle > MERGE_CORNER:
            return None
        if not flag[i] and verts[i] >= p and abs(angle - 180.0) > MERGE_BEND:
            return None
    for x, (c, f, _) in reg.items() if len(low) else ():
        gone = np.isin(c, low)
        if x in (r, o) or not gone.any():
            continue
        if int((f & ~gone).sum()) < 3:
            return None
        for i in np.flatnonzero(gone & (c >= p)):
            if abs(_angle_at(points, c, int(i)) - 180.0) > MERGE_BEND:
                return None
    return verts, flag, kind, low


def small_merged(points, p: int, cycles, corners, kinds, size: float, area: float, most: float):
    """Regions merged in pairs across the chain of axis edges and cuts they share until
    their sides (each one coarse quad of the midpoint subdivision, §8.5.3) are at most
    ``most`` x ``area`` / ``size**2``: the region of most sides per area first, with
    the neighbour whose merged region has the fewest sides per area. A merge is made
    when the merged region is simple and keeps three corners or more, its corners at
    the chain's ends (where three or more edges still meet) are under
    :data:`MERGE_CORNER` degrees, and an axis node no longer a corner lies on a side
    bent by at most :data:`MERGE_BEND` degrees in every region around it. (``p``: the
    first ``p`` points are boundary samples.) The text's partition is free ("numerous
    variations can be used", §9.7.1); regions about as small as ``size`` bound the
    count from below: a random star of 60 vertices at size 0.15 had 95 regions and 333
    sides for area / size**2 = 140. Returns the cycles, corner flags, edge kinds and
    how many merges were made."""
    reg = dict(enumerate(zip(cycles, corners, kinds, strict=True)))  # id -> region
    budget = most * area / size / size  # size**2 overflows past 1e154
    degree = np.zeros(len(points), np.int64)
    und = {(min(a, b), max(a, b)) for c in cycles for a, b in _edges(c)}
    for a, b in und:
        degree[a] += 1
        degree[b] += 1
    ring_area = {r: _ring_area(points[c]) for r, (c, _, _) in reg.items()}
    edges = {r: _edges(c) for r, (c, _, _) in reg.items()}
    edge_region = {e: r for r, es in edges.items() for e in es}  # directed edge -> region
    count = {r: int(f.sum()) for r, (_, f, _) in reg.items()}  # each region's sides
    key = {r: -count[r] / ring_area[r] for r in reg}  # most sides per area first
    sides = sum(count.values())
    refused: set[tuple[int, int]] = set()  # pairs of region ids
    merges = 0
    while sides > budget:
        best = None
        for r in sorted(reg, key=key.__getitem__):  # a loop over the regions
            near = {edge_region[(b, a)] for a, b in edges[r] if (b, a) in edge_region}
            for o in sorted(near - {r}):
                if (min(r, o), max(r, o)) in refused:
                    continue
                got = _merged_pair(points, p, reg, degree, r, o)
                if got is None:
                    refused.add((min(r, o), max(r, o)))
                    continue
                score = int(got[1].sum()) / (ring_area[r] + ring_area[o])
                if best is None or score < best[0]:
                    best = (score, r, o, got)
            if best is not None:
                break
        if best is None:
            break
        _, r, o, (verts, flag, kind, low) = best
        shared = np.intersect1d(reg[r][0], reg[o][0])
        # the chain's inner vertices lose both edges, its ends one
        degree[shared] -= np.where(np.isin(shared, verts), 1, 2)
        for x in (r, o):
            reg.pop(x)
            sides -= count.pop(x)
            del key[x]
            for e in edges.pop(x):
                del edge_region[e]
        for x, (c, f, k) in reg.items() if len(low) else ():
            gone = np.isin(c, low)
            if gone.any():
                reg[x] = (c, f & ~gone, k)
                sides -= count[x]
                count[x] = int(reg[x][1].sum())
                key[x] = -count[x] / ring_area[x]
                sides += count[x]
        new = max(ring_area) + 1
        reg[new] = (verts, flag, kind)
        ring_area[new] = ring_area.pop(r) + ring_area.pop(o)
        count[new] = int(flag.sum())
        key[new] = -count[new] / ring_area[new]
        sides += count[new]
        edges[new] = _edges(verts)
        edge_region.update(dict.fromkeys(edges[new], new))
        merges += 1
    cycles, corners, kinds = zip(*reg.values(), strict=True) if reg else ((), (), ())
    return list(cycles), list(corners), list(kinds), merges


def _edges(c: np.ndarray) -> list[tuple[int, int]]:
    """The directed edges of a vertex cycle."""
    return list(zip(c.tolist(), np.roll(c, -1).tolist(), strict=True))


def _ring_area(xy: np.ndarray) -> float:
    """The signed area of a ring, from coordinates relative to its first vertex (the
    absolute ones lost a spike of area 2e-5 at an offset of 1e6 to cancellation)."""
    x, y = xy[:, 0] - xy[0, 0], xy[:, 1] - xy[0, 1]
    return 0.5 * math.fsum(x * np.roll(y, -1) - np.roll(x, -1) * y)
