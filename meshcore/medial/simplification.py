r"""Geometry simplification with the medial axis (§9.7.4, Remark 9.15).

"The medial axis and the corresponding radii indicate the size of a given
detail as compared with its neighborhood" (§9.7.4). :func:`simplify`
removes the holes and the boundary details whose size is under
``threshold`` times the local radius of the axis, and returns the simplified
domain with the list of what it removed.

The local radius
----------------
:func:`meshcore.medial.axis.medial_axis` gives the empty Delaunay triangulation
of the domain on its boundary samples; each triangle's circle is a maximal
circle of the domain (its axis node, radius the node's distance to the
boundary; pruned nodes keep their circumradius). A boundary sample's radius
is the mean radius of the circles through it (the triangles incident to it),
a piece's radius the mean of its two samples', and an input edge's radius
``R_e`` the length-weighted mean over its pieces. "The average radius of the
maximal circles that touch" a chain of edges is then the length-weighted
mean of ``R_e`` over it.

Holes
-----
"Visiting the medial axis, one detects the possible holes": each hole is
surrounded by one loop of the axis (``stats["axis_loops"]`` counts the
independent loops: one per hole). The maximal circles of that loop are the
ones touching the hole, so the hole's local radius is the mean ``R_e`` over
its ring. Its size is its perimeter over pi (the diameter for a circle; it
needs no extremal search and never exceeds the perimeter's worth of detail).
A hole with ``size / local radius < threshold`` is removed: its ring is
dropped (what collapsing its edges to a point, §9.7.4, ends with).

Boundary details
----------------
A detail is a run ``I`` of consecutive ring vertices ``i .. j`` (at most
:attr:`Tolerances.max_feature_vertices`) between kept vertices ``a`` (before
``i``) and ``b`` (after ``j``), replaced by a shorter path from ``a`` to
``b``. Turning angles are signed so that convex corners (as seen from the
domain) are positive.

``notch``, ``protrusion``
    The run turns by at least :attr:`Tolerances.detail_turning` (90°) in
    absolute value over ``I``. It is replaced by the chord ``ab``: a notch
    (the region between run and chord lies outside the domain) is filled, a
    protrusion (inside) is cut off.
``fillet``
    The run turns one way only (a convex or a concave round, or a chamfer),
    by at least :attr:`Tolerances.fillet_turning` (30°), no vertex by more
    than :attr:`Tolerances.fillet_share` (3/4) of that, ``|I| >= 2``, and the
    lines of its first and last edges ``a i`` and ``j b`` meet at a point
    ``X`` ahead of both: the run is replaced by the corner ``X``.
``step``
    One edge ``i j`` whose ends turn by at least :attr:`Tolerances.step_turning`
    (45°) in opposite directions: it is collapsed to its midpoint, which
    tilts the two sides it joined.

The *size* of a detail is the diameter of the vertices it changes (``a``,
``I``, ``b`` for a chord; ``I`` and ``X`` for a fillet; the step's length).
Its *local radius* is the mean ``R_e`` over its edges and over the two sides
it interrupts. A side is the boundary next to the detail up to where the
boundary has turned by :attr:`Tolerances.side_turning` (10°): a straight
edge, sampled or not, is one side; a sampled curve makes short sides. A
detail must interrupt sides at least :attr:`Tolerances.context` (2) times
as long as its size: this is what tells a detail from a piece of a sampled
curve (a 64-gon hole has no details, a notch in a sampled edge is one). A
detail is removed when ``size / local radius < threshold``.

Details are chosen greedily: notches and protrusions, then fillets, then
steps. Notches and protrusions go by smaller ratio first (so a notch in a
sampled edge is cut at its own corners, not at the samples beyond; a corner
of a notch alone fails the side test, its sides being the notch's walls);
fillets by larger turning first (the whole rounding, not its middle part),
then smaller ratio (not the collinear samples beyond it). A detail is
skipped when it changes a vertex that a chosen one keeps or changes. Each
new segment is checked against the boundary (GEOS STR-tree): one crossing
or touching another segment anywhere but at its own ends skips the detail.
The result is validated by :func:`meshcore.domain.planar.parse_domain`; should the
details together make an invalid domain (two new segments crossing, a cut
protrusion holding a hole), they are added one at a time, each kept only
when the domain stays valid.

Choices
-------
* :data:`DEFAULT_THRESHOLD` = 0.5: a detail under half the radius of the
  maximal circles around it is under a quarter of the local thickness
  ``2 R``, the smallest element size a mesh of the region (quads across the
  thickness, §9.7.2) would resolve. On a 10 x 4 plate: a hole of radius 0.1
  (ratio 0.2) and a 0.2 x 0.2 notch (0.4) go, a hole of radius 1 (2.3) stays.
* One pass: a detail revealed by another's removal is not looked for again
  (call :func:`simplify` again).
* Remark 9.15: whether a detail "influences the solution" is the caller's
  call; ``threshold`` is the only knob, ``threshold = 0`` removes nothing.
* Interior constraint segments of the domain are not carried over (the
  medial axis ignores them too).

References
----------
Methods text §9.7.4 (geometry simplification), Remark 9.15, §9.4 (the axis);
C. G. Armstrong, D. J. Robinson, R. M. McKeag, T. S. Li, S. J. Bridgett,
R. J. Donaghy, C. A. McGleenan, "Medials for meshing and more" (1995).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from meshcore.domain.planar import Domain, parse_domain
from meshcore.errors import InputError, MeshcoreError
from meshcore.limits import DEFAULT_THRESHOLD
from meshcore.medial.axis import medial_axis

__all__ = ["DEFAULT_THRESHOLD", "Simplification", "TOLERANCES", "Tolerances", "simplify"]

Progress = Callable[[float, str], None] | None


_KIND_ORDER = {"notch": 0, "protrusion": 0, "fillet": 1, "step": 2}


@dataclass(frozen=True)
class Tolerances:
    """The angles and ratios that tell a detail from the rest of a boundary.

    Attributes
    ----------
    detail_turning : float
        Degrees: least absolute turning over the run of a notch or protrusion.
    fillet_turning : float
        Degrees: least turning (one way) over the run of a fillet.
    step_turning : float
        Degrees: least turning at each end of a step, in opposite directions.
    side_turning : float
        Degrees: a side runs on until the boundary has turned by this much.
    context : float
        A detail interrupts sides at least this many times its size.
    fillet_share : float
        No vertex of a fillet turns by more than this fraction of the
        fillet's turning (a run whose turning sits at one vertex is a
        corner with samples beside it, not a rounding; a chamfer's two
        vertices share it equally).
    max_feature_vertices : int
        Longest run of vertices one detail may replace.
    parallel : float
        Lines of a fillet closer to parallel than this (sine of their angle)
        have no corner.
    """

    detail_turning: float = 90.0
    fillet_turning: float = 30.0
    step_turning: float = 45.0
    side_turning: float = 10.0
    context: float = 2.0
    fillet_share: float = 0.75
    max_feature_vertices: int = 32
    parallel: float = 1e-9


TOLERANCES = Tolerances()


@dataclass(frozen=True, eq=False)
class Simplification:
    """A simplified domain and what was removed (result of :func:`simplify`).

    Attributes
    ----------
    domain : dict
        GeoJSON geometry of the simplified domain, normalized (closed rings,
        outer counter-clockwise, holes clockwise), the same type as the input.
    removed : list of dict
        One entry per removed feature: ``kind`` (``"hole"``, ``"notch"``,
        ``"protrusion"``, ``"step"``, ``"fillet"``), ``ring`` (index in the
        input domain's ring order), ``vertices`` (the input vertex ids of that
        ring the feature replaced: ``[first, last]``, cyclically, ``first >
        last`` when the run wraps past vertex 0; every vertex for a hole),
        ``size``, ``local_radius``, ``ratio`` (``size / local_radius``),
        ``area`` (the change of the domain's area: positive when filled).
    stats : dict
        ``threshold``, ``h`` (the axis's sampling step), ``axis_nodes``,
        ``axis_loops``, ``holes_removed``, ``details_removed``, ``candidates``,
        ``skipped`` (details refused by the validity checks), ``area_before``,
        ``area_after``.
    """

    domain: dict
    removed: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)


@dataclass
class _Rings:
    """Per-vertex ring data in input order, all rings concatenated."""

    P: np.ndarray  # (N, 2) vertices
    off: np.ndarray  # (R + 1,) ring offsets
    ring: np.ndarray  # (N,) ring of each vertex
    pos: np.ndarray  # (N,) position in its ring
    size: np.ndarray  # (N,) length of its ring
    length: np.ndarray  # (N,) length of edge v -> v + 1
    radius: np.ndarray  # (N,) local radius of edge v -> v + 1
    turn: np.ndarray  # (N,) signed turning at v, radians, convex > 0
    sigma: np.ndarray  # (N,) +1 when the domain is left of the input order

    def at(self, v: np.ndarray, step) -> np.ndarray:
        """Global id of the vertex ``step`` positions after ``v`` on its ring."""
        return self.off[self.ring[v]] + (self.pos[v] + step) % self.size[v]


# ---------------------------------------------------------------------------
# The local radius
# ---------------------------------------------------------------------------


def _triangle_radius(ax) -> np.ndarray:
    """(t,) float64: radius of each triangle's maximal circle."""
    P, T = ax.samples, ax.triangles
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    la = np.hypot(*(b - c).T)
    lb = np.hypot(*(c - a).T)
    lc = np.hypot(*(a - b).T)
    u, w = b - a, c - a
    area2 = np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        circ = la * lb * lc / (2.0 * area2)
    node = getattr(ax, "triangle_node", None)
    if node is not None and len(node) == len(T):
        has = node >= 0
        circ[has] = ax.radius[node[has]]
    return np.where(np.isfinite(circ), circ, 0.0)


def _edge_radius(ax, m: int) -> np.ndarray:
    """(m,) float64: length-weighted mean radius of the circles touching each input edge."""
    rt = _triangle_radius(ax)
    ns = len(ax.samples)
    T = ax.triangles.ravel()
    total = np.bincount(T, weights=np.repeat(rt, 3), minlength=ns)
    count = np.bincount(T, minlength=ns)
    rs = total / np.maximum(count, 1)
    S = ax.segments
    piece = np.hypot(*(ax.samples[S[:, 1]] - ax.samples[S[:, 0]]).T)
    src = ax.segment_source
    num = np.bincount(src, weights=piece * 0.5 * (rs[S[:, 0]] + rs[S[:, 1]]), minlength=m)
    den = np.bincount(src, weights=piece, minlength=m)
    return num / np.maximum(den, np.finfo(float).tiny)


def _axis_loops(ax) -> int:
    n, E = len(ax.nodes), ax.edges
    if n == 0:
        return 0
    g = coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    comps, _ = connected_components(g, directed=False)
    return int(len(np.unique(np.sort(E, axis=1), axis=0)) - n + comps)


def _rings(domain: Domain, edge_radius: np.ndarray) -> _Rings:
    N = domain.boundary_point_count
    P = domain.points[:N]
    off = domain.ring_offsets.astype(np.int64)
    ring = domain.segment_ring
    pos = np.arange(N) - off[ring]
    size = np.diff(off)[ring]
    nxt = off[ring] + (pos + 1) % size
    prv = off[ring] + (pos - 1) % size
    d_out = P[nxt] - P
    d_in = P - P[prv]
    length = np.hypot(*d_out.T)
    sigma = np.where(domain.ring_reversed[ring], -1.0, 1.0)
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    dot = np.einsum("ij,ij->i", d_in, d_out)
    turn = sigma * np.arctan2(cross, dot)
    return _Rings(P, off, ring, pos, size, length, edge_radius[:N], turn, sigma)


def _cyclic_cumsum(values: np.ndarray, rg: _Rings) -> np.ndarray:
    """Per ring, the cumulative sums over three turns of the ring (for wrap-around ranges)."""
    out = np.empty(3 * len(values) + len(rg.off) - 1)
    for k in range(len(rg.off) - 1):  # one pass per ring
        lo, hi = rg.off[k], rg.off[k + 1]
        s = 3 * lo + k
        out[s : s + 3 * (hi - lo) + 1] = np.concatenate(
            [[0.0], np.cumsum(np.tile(values[lo:hi], 3))]
        )
    return out


def _range_sum(cum: np.ndarray, rg: _Rings, v: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Sum of ``values`` over ``count`` consecutive positions starting at vertex ``v``."""
    k = rg.ring[v]
    base = 3 * rg.off[k] + k
    start = rg.pos[v] + rg.size[v]  # middle turn, so that going back is fine
    return cum[base + start + count] - cum[base + start]


def _sides(rg: _Rings, budget: float):
    """The sides ending at each vertex (backward) and starting there (forward).

    A side runs on through vertices whose cumulative absolute turning stays
    within ``budget``, for at most ``size - 1`` edges. Returns ``(back_len,
    back_count, fwd_len, fwd_count)``, (N,) each: lengths and edge counts.
    """
    N = len(rg.P)
    back, back_n = np.empty(N), np.empty(N, dtype=np.int64)
    fwd, fwd_n = np.empty(N), np.empty(N, dtype=np.int64)
    for k in range(len(rg.off) - 1):  # one pass per ring
        lo, hi = rg.off[k], rg.off[k + 1]
        n = hi - lo
        A = np.concatenate([[0.0], np.cumsum(np.tile(np.abs(rg.turn[lo:hi]), 3))])
        C = np.concatenate([[0.0], np.cumsum(np.tile(rg.length[lo:hi], 3))])
        v = np.arange(n) + n
        # forward: edges v .. v + t while the turns at v + 1 .. v + t sum to <= budget
        t = np.searchsorted(A, A[v + 1] + budget, side="right") - (v + 2)
        t = np.clip(t, 0, n - 2)
        fwd[lo:hi] = C[v + t + 1] - C[v]
        fwd_n[lo:hi] = t + 1
        # backward: edges v - 1 - s .. v - 1 while the turns at v - s .. v - 1 sum to <= budget
        s = v - np.searchsorted(A, A[v] - budget, side="left")
        s = np.clip(s, 0, n - 2)
        back[lo:hi] = C[v] - C[v - 1 - s]
        back_n[lo:hi] = s + 1
    return back, back_n, fwd, fwd_n


# ---------------------------------------------------------------------------
# Candidates
# ---------------------------------------------------------------------------


def _diameter(points: np.ndarray) -> float:
    d = points[:, None, :] - points[None, :, :]
    return float(np.sqrt((d * d).sum(axis=2).max()))


def _corner(pa, pi, pj, pb, tol: Tolerances):
    """Corner X where line a->i meets line b->j, ahead of i and of j; None if none."""
    u = pi - pa
    w = pj - pb
    den = u[0] * w[1] - u[1] * w[0]
    nu, nw = math.hypot(*u), math.hypot(*w)
    if nu == 0 or nw == 0 or abs(den) <= tol.parallel * nu * nw:
        return None
    r = pb - pa
    s = (r[0] * w[1] - r[1] * w[0]) / den
    t = (r[0] * u[1] - r[1] * u[0]) / den
    if s < 1 or t < 1:
        return None
    return pi + (s - 1.0) * u if s - 1.0 <= t - 1.0 else pj + (t - 1.0) * w


def _candidates(rg: _Rings, threshold: float, tol: Tolerances) -> list[dict]:
    """Every detail under the threshold, before the greedy choice.

    One vectorized pass per run length ``k``; the few runs that pass the
    cheap tests (turning, a lower bound of the size) are measured exactly.
    """
    N = len(rg.P)
    if N == 0 or threshold <= 0:
        return []
    back, back_n, fwd, fwd_n = _sides(rg, math.radians(tol.side_turning))
    cum_l = _cyclic_cumsum(rg.length, rg)
    cum_lr = _cyclic_cumsum(rg.length * rg.radius, rg)
    detail = math.radians(tol.detail_turning)
    fillet = math.radians(tol.fillet_turning)
    step = math.radians(tol.step_turning)
    v0 = np.arange(N)
    a = rg.at(v0, -1)
    out: list[dict] = []
    abs_turn = np.zeros(N)
    net = np.zeros(N)
    tmin = np.full(N, np.inf)
    tmax = np.full(N, -np.inf)
    lo_xy = np.minimum(rg.P, rg.P[a])
    hi_xy = np.maximum(rg.P, rg.P[a])
    for k in range(1, tol.max_feature_vertices + 1):  # one pass per run length
        j = rg.at(v0, k - 1)
        b = rg.at(v0, k)
        abs_turn += np.abs(rg.turn[j])
        net += rg.turn[j]
        tmin = np.minimum(tmin, rg.turn[j])
        tmax = np.maximum(tmax, rg.turn[j])
        lo_xy = np.minimum(lo_xy, rg.P[j])
        hi_xy = np.maximum(hi_xy, rg.P[j])
        ok_ring = rg.size - k >= 3
        kinds = []
        # chord: the sides end at a and start at b; the run's k + 1 edges lie between
        chord = ok_ring & (abs_turn >= detail)
        kinds.append(("chord", chord, a, b, k + 1))
        if k >= 2:
            # fillet, step: the run's first and last edges are part of the sides
            # one way, and no one vertex carrying most of it (that is a corner)
            one_way = ((tmin > 0) | (tmax < 0)) & (np.abs(net) >= fillet)
            one_way &= np.maximum(-tmin, tmax) <= tol.fillet_share * np.abs(net)
            kinds.append(("fillet", ok_ring & one_way, v0, j, k - 1))
        if k == 2:
            ti, tj = rg.turn[v0], rg.turn[j]
            opposite = (np.minimum(np.abs(ti), np.abs(tj)) >= step) & (ti * tj < 0)
            kinds.append(("step", ok_ring & opposite, v0, j, 1))
        for kind, mask, s_end, s_start, inner in kinds:
            sel = np.flatnonzero(mask)
            if not len(sel):
                continue
            e, f = s_end[sel], s_start[sel]
            side_a, side_b = back[e], fwd[f]
            # the local radius over the contiguous edges: back side, run, forward side
            count = np.minimum(back_n[e] + inner + fwd_n[f], rg.size[sel])
            first = rg.at(e, -back_n[e])
            rad = _range_sum(cum_lr, rg, first, count) / _range_sum(cum_l, rg, first, count)
            # lower bounds of the size: the box diagonal / sqrt 2 (chord), the run's span
            if kind == "chord":
                pb = rg.P[b[sel]]
                lower = np.hypot(*(np.maximum(hi_xy[sel], pb) - np.minimum(lo_xy[sel], pb)).T)
                lower /= math.sqrt(2)
            else:
                lower = np.hypot(*(rg.P[j[sel]] - rg.P[sel]).T)
            keep = (lower < threshold * rad) & (np.minimum(side_a, side_b) >= tol.context * lower)
            keep &= np.minimum(side_a, side_b) > 0
            for idx in np.flatnonzero(keep):
                v = int(sel[idx])
                cand = _measure(rg, kind, v, k, float(rad[idx]), tol)
                if cand is None:
                    continue
                if min(float(side_a[idx]), float(side_b[idx])) < tol.context * cand["size"]:
                    continue
                if cand["ratio"] < threshold:
                    out.append(cand)
    return out


def _measure(rg: _Rings, kind: str, i: int, k: int, rad: float, tol: Tolerances) -> dict | None:
    """Size, replacement and area change of one candidate run (``k`` vertices from ``i``)."""
    run = rg.at(np.full(k, i), np.arange(k))
    a = int(rg.at(np.array([i]), -1)[0])
    b = int(rg.at(np.array([i]), k)[0])
    pa, pb = rg.P[a], rg.P[b]
    old = np.vstack([pa, rg.P[run], pb])
    if kind == "chord":
        new = np.vstack([pa, pb])
        size = _diameter(old)
    elif kind == "fillet":
        X = _corner(pa, rg.P[run[0]], rg.P[run[-1]], pb, tol)
        if X is None:
            return None
        new = np.vstack([pa, X, pb])
        size = _diameter(np.vstack([rg.P[run], X]))
    else:
        m = 0.5 * (rg.P[run[0]] + rg.P[run[1]])
        new = np.vstack([pa, m, pb])
        size = float(np.hypot(*(rg.P[run[1]] - rg.P[run[0]])))
    # signed area of old path then new path backwards; > 0: region on the domain side
    loop = np.vstack([old, new[-2:0:-1]]) if len(new) > 2 else old
    x, y = loop[:, 0], loop[:, 1]
    signed = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) * float(rg.sigma[i])
    if kind == "chord":
        if signed == 0:
            return None
        kind = "protrusion" if signed > 0 else "notch"
    if rad <= 0:
        return None
    return {
        "kind": kind,
        "ring": int(rg.ring[i]),
        "first": int(i),
        "run": run,
        "a": a,
        "b": b,
        "new": new,
        "size": size,
        "local_radius": rad,
        "ratio": size / rad,
        "area": -signed,
        "turning": abs(float(rg.turn[run].sum())),
    }


# ---------------------------------------------------------------------------
# Choice, checks and the new rings
# ---------------------------------------------------------------------------


def _choose(cands: list[dict], N: int) -> list[dict]:
    """Greedy in the module docstring's order; no shared changed vertex."""

    def key(c):
        # fillets: the whole rounding (largest turning) first, then the tightest run
        turning = round(c["turning"], 9) if c["kind"] == "fillet" else 0.0
        return (_KIND_ORDER[c["kind"]], -turning, c["ratio"], c["first"])

    cands = sorted(cands, key=key)
    locked = np.zeros(N, dtype=bool)
    changed = np.zeros(N, dtype=bool)
    chosen = []
    for c in cands:  # sequential by nature: each choice constrains the next
        run, ends = c["run"], [c["a"], c["b"]]
        if changed[run].any() or changed[ends].any() or locked[run].any():
            continue
        changed[run] = True
        locked[run] = True
        locked[ends] = True
        chosen.append(c)
    return chosen


def _crossing_free(chosen: list[dict], rg: _Rings, dropped_rings: set) -> list[bool]:
    """Whether each detail's new segments avoid every other boundary segment."""
    if not chosen:
        return []
    N = len(rg.P)
    nxt = rg.at(np.arange(N), 1)
    tree = shapely.STRtree(shapely.linestrings(np.stack([rg.P, rg.P[nxt]], axis=1)))
    lines, owner = [], []
    for f, c in enumerate(chosen):
        for p, q in zip(c["new"][:-1], c["new"][1:], strict=True):
            lines.append((p, q))
            owner.append(f)
    geoms = shapely.linestrings(np.array(lines))
    owner = np.array(owner)
    hit_line, hit_seg = tree.query(geoms, predicate="intersects")
    ok = np.ones(len(chosen), dtype=bool)
    for li, s in zip(hit_line.tolist(), hit_seg.tolist(), strict=True):
        c = chosen[owner[li]]
        if int(rg.ring[s]) in dropped_rings:
            continue
        edges = set(rg.at(np.array([c["a"]]), np.arange(len(c["run"]) + 1)).tolist())
        if s in edges:
            continue  # an edge the detail replaces
        p, q = lines[li]
        shared = [x for x in (rg.P[s], rg.P[nxt[s]]) if (x == p).all() or (x == q).all()]
        if shared:
            inter = shapely.intersection(geoms[li], shapely.linestrings([rg.P[s], rg.P[nxt[s]]]))
            if inter.geom_type == "Point" and (np.asarray(inter.coords[0]) == shared[0]).all():
                continue
        ok[owner[li]] = False
    return ok.tolist()


def _geometry(domain: Domain, rg: _Rings, chosen: list[dict], dropped_rings: set) -> dict:
    """The GeoJSON of the domain with ``chosen`` applied and ``dropped_rings`` removed."""
    N = len(rg.P)
    keep = np.ones(N, dtype=bool)
    extra_key, extra_pt = [], []
    for c in chosen:
        keep[c["run"]] = False
        for p in c["new"][1:-1]:
            extra_key.append(c["first"])
            extra_pt.append(p)
    keys = np.concatenate([rg.pos.astype(float), np.array(extra_key, dtype=float)])
    ring = np.concatenate([rg.ring, rg.ring[np.array(extra_key, dtype=np.int64)]])
    if extra_key:  # a fillet or a step adds one point, where its run began
        keys[N:] = rg.pos[np.array(extra_key)] - 0.5
    pts = np.vstack([rg.P, np.array(extra_pt).reshape(-1, 2)])
    live = np.concatenate([keep, np.ones(len(extra_key), dtype=bool)])
    order = np.lexsort((keys, ring))
    order = order[live[order]]
    cuts = np.searchsorted(ring[order], np.arange(domain.ring_count + 1))
    polys: list[list] = []
    for k in range(domain.ring_count):  # one pass per ring
        rows = order[cuts[k] : cuts[k + 1]]
        if not domain.ring_is_hole[k]:
            polys.append([pts[rows].tolist()])
        elif k not in dropped_rings:
            polys[-1].append(pts[rows].tolist())
    if domain.multi:
        return {"type": "MultiPolygon", "coordinates": polys}
    return {"type": "Polygon", "coordinates": polys[0]}


def _check_inputs(domain, threshold, h):
    if not isinstance(domain, Domain):
        raise InputError(
            "domain must be a Domain (see meshcore.domain.planar.parse_domain)",
            loc=("domain",),
            code="bad_type",
        )
    try:
        t = float(threshold)
    except (TypeError, ValueError):
        t = math.nan
    if isinstance(threshold, bool) or not (math.isfinite(t) and t >= 0):
        raise InputError(
            f"threshold must be a finite number >= 0, got {threshold!r}",
            loc=("threshold",),
            code="bad_value",
        )
    if h is not None:
        try:
            hv = float(h)
        except (TypeError, ValueError):
            hv = math.nan
        if isinstance(h, bool) or not (math.isfinite(hv) and hv > 0):
            raise InputError(
                f"h must be a finite number > 0, got {h!r}", loc=("h",), code="bad_value"
            )
        h = hv
    return t, h


def _report(c: dict, rg: _Rings) -> dict:
    off = int(rg.off[c["ring"]])
    return {
        "kind": c["kind"],
        "ring": c["ring"],
        "vertices": [int(c["run"][0]) - off, int(c["run"][-1]) - off],
        "size": float(c["size"]),
        "local_radius": float(c["local_radius"]),
        "ratio": float(c["ratio"]),
        "area": float(c["area"]),
    }


# ---------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------


def simplify(
    domain: Domain,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    h: float | None = None,
    progress: Progress = None,
    tolerances: Tolerances = TOLERANCES,
) -> Simplification:
    """Remove the holes and boundary details that are small against the local axis radius.

    Parameters
    ----------
    domain : Domain
        From :func:`meshcore.domain.planar.parse_domain`.
    threshold : float
        Features with ``size / local radius < threshold`` are removed (module
        docstring); 0 removes nothing. Default :data:`DEFAULT_THRESHOLD`.
    h : float, optional
        Boundary sampling step of the medial axis (default: that of
        :func:`meshcore.medial.axis.medial_axis`).
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.
    tolerances : Tolerances

    Returns
    -------
    Simplification

    Raises
    ------
    InputError
        ``bad_type`` (``("domain",)``), ``bad_value`` (``("threshold",)``,
        ``("h",)``), and those of :func:`meshcore.medial.axis.medial_axis` for ``h``.
    AlgorithmError
        As :func:`meshcore.medial.axis.medial_axis`.

    References
    ----------
    Methods text §9.7.4 (geometry simplification), Remark 9.15.
    """
    threshold, h = _check_inputs(domain, threshold, h)
    if progress is not None:
        progress(0.0, "medial axis")
    ax = medial_axis(domain, h=h)
    if progress is not None:
        progress(0.5, "local radii and features")
    m = domain.boundary_point_count
    rg = _rings(domain, _edge_radius(ax, m))

    removed: list[dict] = []
    dropped: set = set()
    for k in np.flatnonzero(domain.ring_is_hole).tolist():  # one entry per hole
        lo, hi = int(rg.off[k]), int(rg.off[k + 1])
        L = rg.length[lo:hi]
        perimeter = float(L.sum())
        rad = float((L * rg.radius[lo:hi]).sum() / perimeter)
        size = perimeter / math.pi
        if rad > 0 and size / rad < threshold:
            dropped.add(k)
            x, y = rg.P[lo:hi, 0], rg.P[lo:hi, 1]
            area = abs(0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
            removed.append(
                {
                    "kind": "hole",
                    "ring": k,
                    "vertices": list(range(hi - lo)),
                    "size": size,
                    "local_radius": rad,
                    "ratio": size / rad,
                    "area": area,
                }
            )

    cands = [c for c in _candidates(rg, threshold, tolerances) if c["ring"] not in dropped]
    chosen = _choose(cands, len(rg.P))
    if progress is not None:
        progress(0.7, f"checking {len(chosen)} details")
    ok = _crossing_free(chosen, rg, dropped)
    skipped = sum(1 for x in ok if not x)
    chosen = [c for c, good in zip(chosen, ok, strict=True) if good]
    try:
        result = parse_domain(_geometry(domain, rg, chosen, dropped))
    except MeshcoreError:
        # Sequential fallback: each detail kept only if the domain stays valid.
        kept: list[dict] = []
        result = parse_domain(_geometry(domain, rg, [], dropped))
        for c in chosen:
            try:
                result = parse_domain(_geometry(domain, rg, [*kept, c], dropped))
                kept.append(c)
            except MeshcoreError:
                skipped += 1
        chosen = kept
    removed.extend(_report(c, rg) for c in chosen)
    stats = {
        "threshold": threshold,
        "h": float(ax.h),
        "axis_nodes": int(len(ax.nodes)),
        "axis_loops": _axis_loops(ax),
        "holes_removed": len(dropped),
        "details_removed": len(chosen),
        "candidates": len(cands),
        "skipped": skipped,
        "area_before": domain.area,
        "area_after": result.area,
    }
    if progress is not None:
        progress(1.0, "done")
    return Simplification(domain=result.as_geojson(), removed=removed, stats=stats)
