"""Paving's fronts as chains of directed edges, and their closure (§8.5.1, §8.7.2).

Helpers of :mod:`meshcore.quads.advancing_front` (its module docstring,
steps 3 and 6, says what they are for): the fronts left when quads are cut
out of a region (:func:`_trace`, chain arithmetic), the polygons the fronts
make (:func:`_polygons`), and the closure of those polygons: the large
ones without holes whose corners allow it by a midpoint subdivision into
grids (:mod:`meshcore.quads.paving_templates`, one irregular vertex each),
the others by the recursive partition in its quad mode (:func:`_close`), with the local
rescues of the sub-polygons the partition hands back stuck: a ring of quads
around a shrunk copy (:func:`_ring`), the guaranteed route locally
(:func:`_coarse_split`), and, when both fail, a *cavity*: the stuck polygon
together with the quads around it (rows, strips, the partition's own) made
one polygon and closed again, up to ``_CAVITY_TRIES`` rings of quads wide;
when one is still stuck, the polygons one by one, a polygon still stuck by
its own coarse split (:func:`_close_each`).

Why the cells cover each polygon exactly once: every closure cell is
strictly convex and counter-clockwise (exact :func:`orient2d`), and the sum
of the cells' boundary chains is the polygon's (the partition splits
polygons by separators; a ring, a coarse split and a cavity are built so),
so the number of cells over a point is the polygon's winding number there:
one inside, none outside. This holds for weakly simple polygons too (a
bridge to a hole walked both ways).
"""

from __future__ import annotations

import numpy as np

from meshcore.errors import AlgorithmError
from meshcore.mesh.topology import edge_keys, isin_ints, unique_ints
from meshcore.partition import SizeMap, partition_polygon
from meshcore.partition.recursive import FALLBACK_SCALE
from meshcore.quads import paving_kernel as pk
from meshcore.quads.paving_templates import template
from meshcore.quads.splitting import _cell_edge_keys
from meshcore.quads.vertex_moves import _incidence

_MIN_Q = 0.1  # least quality (8.4) of a quad laid in a row or a closure
_RING_STEPS = (0.5, 0.35, 0.65)  # shares of the way to the centroid tried by _ring
_CAVITY_TRIES = 3  # rings of quads around a stuck polygon taken into its cavity at most


def _succ(a: np.ndarray) -> np.ndarray:
    """Each entry's successor along axis 0, cyclically (``np.roll(a, -1, axis=0)``
    without its overhead: the fronts are short and many)."""
    return np.concatenate((a[1:], a[:1]))


def _pred(a: np.ndarray) -> np.ndarray:
    """Each entry's predecessor along axis 0, cyclically (``np.roll(a, 1, axis=0)``)."""
    return np.concatenate((a[-1:], a[:-1]))


def _angles(P: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Interior angle (radians, domain on the left) at each node of front f."""
    prv, nxt = _pred(f), _succ(f)
    u = P[prv] - P[f]
    w = P[nxt] - P[f]
    t = np.arctan2(w[:, 0] * u[:, 1] - w[:, 1] * u[:, 0], np.einsum("ij,ij->i", w, u))
    return np.where(t <= 0, t + 2 * np.pi, t)


def _chains(fronts: list) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)``: the directed edges of every front, ``a`` the fronts' nodes in
    order (concatenated), ``b`` the next node of each along its front."""
    a = np.concatenate(fronts) if fronts else np.zeros(0, np.int64)
    lens = np.array([len(g) for g in fronts], np.int64)
    end = np.cumsum(lens)
    nxt = np.arange(1, len(a) + 1)
    nxt[end - 1] = end - lens
    return a, a[nxt]


def _trace(fronts: list, quads: np.ndarray, n: int) -> list | None:
    """The fronts left when the quads are cut out of the region inside ``fronts``.

    Chain arithmetic: the directed front edges plus the reversed quad edges,
    opposite pairs cancelling (a front of two segments, one edge and its
    reverse, closes itself this way). None when the result is not a set of
    simple even cycles of at least 4 nodes (a node with two outgoing edges,
    a doubled edge, an odd cycle).
    """
    ca, cb = _chains(fronts)
    fa = np.concatenate([ca, quads[:, [1, 2, 3, 0]].ravel()])
    fb = np.concatenate([cb, quads.ravel()])
    fwd = fa * n + fb
    back = fb * n + fa
    keys, cnt = unique_ints(fwd, counts=True)
    rk, rc = unique_ints(back, counts=True)
    net = cnt - np.where(isin_ints(keys, rk), rc[np.searchsorted(rk, keys).clip(0, len(rk) - 1)], 0)
    if (net > 1).any():
        return None
    keys = keys[net == 1]
    a, b = keys // n, keys % n  # a ascending
    k = len(a)
    if not k:
        return []
    succ = np.searchsorted(a, b).clip(0, k - 1)
    if (np.diff(a) == 0).any() or (a[succ] != b).any() or len(unique_ints(succ)) != k:
        return None  # a node with two outgoing edges, or a chain that is not closed
    # each cycle from its largest node, the cycles by their largest node, descending
    order, cuts = pk.cycles(succ)
    loops = np.split(a[order], cuts)
    if any(len(c) < 4 or len(c) % 2 for c in loops):
        return None
    return loops


def _polygons(P: np.ndarray, fronts: list):
    """(loops, ring_polygon) for the closure: each counter-clockwise front an outer
    ring, each clockwise one a hole of the smallest outer ring around it."""
    area = []
    for g in fronts:
        a, b = P[g], P[_succ(g)]
        area.append(float((a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum()) / 2)
    outer = [k for k, a in enumerate(area) if a > 0]
    loops: list[np.ndarray] = []
    ring_polygon: list[int] = []
    holes: dict[int, list[int]] = {k: [] for k in outer}
    for k, a in enumerate(area):
        if a > 0:
            continue
        x, y = P[fronts[k][0]]
        best = None
        for o in outer:
            R = P[fronts[o]]
            S = _succ(R)
            up = (R[:, 1] > y) != (S[:, 1] > y)
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = R[:, 0] + (y - R[:, 1]) * (S[:, 0] - R[:, 0]) / (S[:, 1] - R[:, 1])
            if np.count_nonzero(up & (xc > x)) % 2 and (best is None or area[o] < area[best]):
                best = o
        if best is None:
            raise AlgorithmError("a paving front is a hole of no front", code="front_lost")
        holes[best].append(k)
    for p, o in enumerate(outer):
        for k in (o, *holes[o]):
            loops.append(fronts[k])
            ring_polygon.append(p)
    return loops, np.asarray(ring_polygon, np.int64)


def _fit(P: np.ndarray, quads: np.ndarray) -> bool:
    """Every quad strictly convex (exact) and of quality (8.4) at least ``_MIN_Q``."""
    return bool(pk.convex_and_good(P, quads, _MIN_Q).all())


def _ring(P: np.ndarray, loop: np.ndarray, sizes: SizeMap, strategy: str):
    """A small stuck polygon closed by a ring of quads around a shrunk copy of it.

    Each vertex ``v`` gets an inner point on its way to the vertices' centroid
    (less far for flatter or reflex vertices, so the copy has no flat corner);
    the ring quads ``(v_i, v_i+1, c_i+1, c_i)`` must all be strictly convex
    (exact), and the copy, an even polygon, is closed by the partition (one
    quad when it has 4 sides); every quad of quality (8.4) at least
    ``_MIN_Q``. Returns ``(points, cells)`` or None.
    """
    n = len(loop)
    V = P[loop]
    g = V.mean(axis=0)
    bend = np.clip((_angles(P, loop) - np.pi / 2) / (np.pi / 2), -1.0, 1.0)
    ids = len(P) + np.arange(n)
    ring = np.column_stack([loop, _succ(loop), _succ(ids), ids])
    for base in _RING_STEPS:
        t = base - 0.25 * bend
        Q = np.concatenate([P, V + t[:, None] * (g - V)])
        if not _fit(Q, ring):
            continue
        if n == 4:
            if _fit(Q, ids[None, :]):
                return Q, np.concatenate([ring, ids[None, :]])
            continue
        Q2, cells, _ = partition_polygon(
            Q, [ids], np.zeros(1, np.int64), sizes, quad=True, strategy=strategy
        )
        if cells is not None and _fit(Q2, cells):
            return Q2, np.concatenate([ring, cells])
    return None


def _coarse_split(P: np.ndarray, loop: np.ndarray, sizes: SizeMap, strategy: str):
    """A stuck even polygon closed by the guaranteed route, locally (§8.4, Figure 8.13).

    Every other vertex makes a coarse polygon, triangulated by the partition
    (its triangle mode); each triangle is cut in three quads through its
    edges' "midpoints" and its centroid, the midpoint of a coarse boundary
    edge being the polygon vertex it skipped (so the polygon's edges are
    kept) and shared edges getting one new midpoint. Both choices of the
    coarse vertices are tried; kept only when every quad is strictly convex
    (exact) and of quality (8.4) at least ``_MIN_Q``. Returns ``(points,
    cells)`` or None.
    """
    n = len(loop)
    for parity in (0, 1):
        coarse = loop[parity::2]
        skipped = loop[1::2] if parity == 0 else _succ(loop[0::2])
        Q, tri, _ = partition_polygon(
            P, [coarse], np.zeros(1, np.int64), sizes, quad=False, strategy=strategy
        )
        if tri is None:
            continue
        N = len(Q)
        key = edge_keys(coarse, _succ(coarse), N)
        ekey = _cell_edge_keys(tri, N).ravel()
        ukey, inv = unique_ints(ekey, return_inverse=True)
        mid = np.full(len(ukey), -1, np.int64)
        on = isin_ints(ukey, key)
        mid[on] = skipped[np.argsort(key)][np.searchsorted(np.sort(key), ukey[on])]
        fresh = np.flatnonzero(~on)
        a, b = ukey[fresh] // N, ukey[fresh] % N
        mid[fresh] = N + np.arange(len(fresh))
        cen = N + len(fresh) + np.arange(len(tri))
        Q = np.concatenate([Q, (Q[a] + Q[b]) / 2, Q[tri].mean(axis=1)])
        em = mid[inv].reshape(-1, 3)
        cells = np.concatenate(
            [np.column_stack([tri[:, j], em[:, j], cen, em[:, (j - 1) % 3]]) for j in range(3)]
        )
        if len(coarse) * 2 == n and _fit(Q, cells):
            return Q, cells
    return None


def _close_one(P: np.ndarray, loop: np.ndarray, sizes: SizeMap, strategy: str):
    """One polygon closed locally: the partition, else :func:`_ring`, else
    :func:`_coarse_split`. Returns ``(points, cells, kind)`` (cells in the
    indices of ``P``, new points appended) or None."""
    used = unique_ints(loop)
    local = np.searchsorted(used, loop)
    Pk, ck, _ = partition_polygon(
        P[used], [local], np.zeros(1, np.int64), sizes, quad=True, strategy=strategy
    )
    kind = "partition"
    if ck is None:
        kind = "rings"
        res = _ring(P[used], local, sizes, strategy)
        if res is None:
            kind = "coarse_splits"
            res = _coarse_split(P[used], local, sizes, strategy)
        if res is None:
            return None
        Pk, ck = res
    glob = np.concatenate([used, len(P) + np.arange(len(Pk) - len(used))])
    return np.concatenate([P, Pk[len(used) :]]), glob[ck], kind


class _Pool:
    """The quads a cavity may take (rows, strips, the closure's own), in the order they
    came, each live or taken, with the rows at each point: a cavity looks only at the
    quads around its polygon (a search of every quad for each cavity cost the plate
    with 20 holes at 100k quads about as much as the partition's closures)."""

    _TAIL = 4096  # rows added since the rows at each point were listed, at most

    def __init__(self, quads: np.ndarray, n: int):
        self.quads = quads
        self.size = len(quads)
        self.live = np.ones(len(quads), bool)
        self._index(n)

    def _index(self, n: int) -> None:
        self.indexed = self.size
        self.ptr, self.rows = _incidence(self.quads[: self.size], np.ones(self.size, bool), n)

    def add(self, new: np.ndarray, n: int) -> None:
        end = self.size + len(new)
        if end > len(self.quads):  # room doubled
            grow = max(end, 2 * len(self.quads)) - len(self.quads)
            self.quads = np.concatenate([self.quads, np.zeros((grow, 4), np.int64)])
            self.live = np.concatenate([self.live, np.zeros(grow, bool)])
        self.quads[self.size : end] = new
        self.live[self.size : end] = True
        self.size = end
        if end - self.indexed > self._TAIL:
            self._index(n)

    def cavity(self, loop: np.ndarray, live: np.ndarray, n: int):
        """The stuck polygon ``loop`` grown by the ``live`` quads sharing an edge with
        it: ``(new loop, the rows taken)``, or None when the union is not one simple
        even cycle (chain arithmetic, :func:`_trace` on the reversed quads)."""
        v = loop[loop < len(self.ptr) - 1]
        lo, cnt = self.ptr[v], self.ptr[v + 1] - self.ptr[v]
        at = np.repeat(lo - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
        on = np.zeros(n, bool)
        on[loop] = True
        tail = self.quads[self.indexed : self.size]
        late = self.indexed + np.flatnonzero(on[tail].any(axis=1))
        rows = unique_ints(np.concatenate([self.rows[at], late]))
        rows = rows[live[rows]]  # the live quads at its points
        q = self.quads[rows]
        key = edge_keys(loop, _succ(loop), n)
        qk = _cell_edge_keys(q, n)
        take = rows[isin_ints(qk, key).any(axis=1)]
        if not len(take):
            return None
        grown = _trace([loop], self.quads[take][:, ::-1], n)
        if grown is None or len(grown) != 1:
            return None
        return grown[0], take


def _templates(P: np.ndarray, loops: list, ring_polygon: np.ndarray):
    """The polygons without holes that :func:`~meshcore.quads.paving_templates.template`
    meshes: ``(points, [their quads], the loops left, their polygons renumbered)``."""
    rings = np.bincount(ring_polygon)
    made, left = [], []
    for k, g in enumerate(loops):
        res = None
        if rings[ring_polygon[k]] == 1:
            res = template(P, g, np.degrees(_angles(P, g)))
        if res is None:
            left.append(k)
            continue
        pts, quads = res
        P = np.concatenate([P, pts])
        made.append(quads)
    _, polygon = np.unique(ring_polygon[left], return_inverse=True)
    return P, made, [loops[k] for k in left], polygon.astype(np.int64)


def _close(
    P: np.ndarray,
    fronts: list,
    sizes: SizeMap,
    strategy: str,
    around: np.ndarray,
    local_route: bool = False,
):
    """The quad closure of the fronts: ``(points, cells, stats, gone)``, cells None if stuck.

    :func:`_close_all` on every polygon at once; when that is stuck and
    ``local_route``, :func:`_close_each`: each polygon on its own, the ones
    still stuck by the guaranteed route locally.
    """
    res = _close_all(P, fronts, sizes, strategy, around)
    if res[1] is not None or not local_route:
        return res
    return _close_each(P, fronts, sizes, strategy, around)


def _close_each(P: np.ndarray, fronts: list, sizes: SizeMap, strategy: str, around: np.ndarray):
    """The closure polygon by polygon: ``(points, cells, stats, gone)`` as :func:`_close`.

    Each polygon (an outer front and its holes) is closed by :func:`_close_all`
    on its own (its cavities take only quads no earlier polygon took); one
    that is still stuck and has no hole is closed by the guaranteed route
    locally (:func:`_coarse_split` of the whole polygon, its coarse
    triangles at ``FALLBACK_SCALE`` times the size so that the quads come out
    near the size, as the global route's do; ``stats["polygon_splits"]``).
    The stuck pieces the partition leaves are mostly slivers between two
    separators from nearly the same point (a tip of a few degrees: no quad
    of quality ``_MIN_Q`` fits there, and the cavities around them meet
    other stuck pieces); before this, one such piece took every row back
    (the plate with 20 holes at 10k quads kept 3,128 of its 7,547 row quads).
    Cells None when a polygon is stuck both ways.
    """
    loops, ring_polygon = _polygons(P, fronts)
    alive = np.ones(len(around), bool)
    cells: list[np.ndarray] = []
    stats: dict = {"polygon_splits": 0}
    coarse = SizeMap(FALLBACK_SCALE * sizes.H, sizes.grid)
    for p in range(int(ring_polygon.max()) + 1):
        mine = [g for g, r in zip(loops, ring_polygon, strict=True) if r == p]
        rows = np.flatnonzero(alive)
        P2, new, st, gone = _close_all(P, mine, sizes, strategy, around[rows])
        if new is None:
            if len(mine) > 1:
                return P, None, {}, np.zeros(len(around), bool)
            used = unique_ints(mine[0])
            res = _coarse_split(P[used], np.searchsorted(used, mine[0]), coarse, strategy)
            if res is None:
                return P, None, {}, np.zeros(len(around), bool)
            Pk, ck = res
            glob = np.concatenate([used, len(P) + np.arange(len(Pk) - len(used))])
            P2, new, st, gone = np.concatenate([P, Pk[len(used) :]]), glob[ck], {}, None
            stats["polygon_splits"] += 1
        else:
            alive[rows[gone]] = False
        P = P2
        cells.append(new)
        for k, v in st.items():
            if k == "depth":
                stats[k] = max(stats.get(k, 0), v)
            elif isinstance(v, dict):
                stats[k] = {c: stats.get(k, {}).get(c, 0) + x for c, x in v.items()}
            elif isinstance(v, int):
                stats[k] = stats.get(k, 0) + v
    return P, np.concatenate(cells), stats, ~alive


def _close_all(P: np.ndarray, fronts: list, sizes: SizeMap, strategy: str, around: np.ndarray):
    """The quad closure of the fronts: ``(points, cells, stats, gone)``, cells None if stuck.

    The polygons without holes that a template fits are meshed by it
    (:func:`_templates`, ``stats["templates"]``); the partition
    (:func:`meshcore.partition.partition_polygon`) on every other
    polygon at once; it hands back the sub-polygons it is stuck on (cut out
    of a polygon with holes too), each closed by :func:`_ring`
    (``stats["rings"]``), or else by :func:`_coarse_split`
    (``stats["coarse_splits"]``), or else as a cavity (``stats["cavities"]``):
    the quads sharing an edge with it (of ``around``, the quads laid
    already, or of the closure) taken out and the union closed by the
    partition, a ring or a coarse split, one more ring of quads at a time.
    A polygon closed by a ring is rather closed as a cavity when the
    partition closes one (a ring's valence-3 corners left the least sines
    of the plate and the gear at 100k quads, 0.68 and 0.66, after the clean-up).
    ``gone`` (bool, one per row of ``around``) marks the quads taken out.
    """
    loops, ring_polygon = _polygons(P, fronts)
    gone = np.zeros(len(around), bool)
    P, made, loops, ring_polygon = _templates(P, loops, ring_polygon)
    cells, cstats = np.zeros((0, 4), np.int64), {"stuck": []}
    if loops:
        P, cells, cstats = partition_polygon(
            P, loops, ring_polygon, sizes, quad=True, strategy=strategy, leave_stuck=True
        )
        if cells is None:
            return P, None, {}, gone
    pool = _Pool(np.concatenate([around, *made, cells]), len(P))
    count = {"templates": len(made), "rings": 0, "coarse_splits": 0, "cavities": 0}
    for loop in cstats.pop("stuck"):
        res = _close_one(P, loop, sizes, strategy)
        grown = 0
        while res is None and grown < _CAVITY_TRIES:
            grown += 1
            cav = pool.cavity(loop, pool.live, len(P))
            if cav is None:
                break
            loop, take = cav
            pool.live[take] = False
            res = _close_one(P, loop, sizes, strategy)
        if res is not None and res[2] == "rings":
            # a ring leaves valence-3 corners around its copy (the least sines of the
            # mesh after the clean-up): rather the polygon grown by the quads around it
            # (up to _CAVITY_TRIES rings), when the partition closes that
            live, wide = pool.live.copy(), loop
            for _ in range(_CAVITY_TRIES):
                cav = pool.cavity(wide, live, len(P))
                if cav is None:
                    break
                wide, take = cav
                live[take] = False
                alt = _close_one(P, wide, sizes, strategy)
                if alt is not None and alt[2] == "partition":
                    pool.live, res, grown = live, alt, 1
                    break
        if res is None:
            return P, None, {}, gone
        if grown:
            count["cavities"] += 1
        elif res[2] != "partition":
            count[res[2]] += 1
        P, new, _ = res
        pool.add(new, len(P))
    flat, live = pool.quads[: pool.size], pool.live[: pool.size]
    gone = ~live[: len(around)]
    return P, flat[len(around) :][live[len(around) :]], {**cstats, **count}, gone
