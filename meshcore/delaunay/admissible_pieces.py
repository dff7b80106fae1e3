"""The pieces of the admissible-boundary splits and their compiled searches (§9.1).

:class:`_Pieces` holds the boundary segments cut into pieces (chains of
subsegments per input segment, their protecting circles, the split points)
together with the one growing triangulation the splits insert into
(:class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay`); the compiled
functions here search that triangulation for the edges inside a disc, and,
on a grid, the pieces near each vertex to protect (:func:`_grid_reach`).
The loop that splits the pieces is
:func:`meshcore.delaunay.admissible_loop._split_loop`, run by
:mod:`meshcore.delaunay.admissible`; the names stay private to the package
but :func:`located_in_domain` (the errors of the splits located in a
domain), which that module exports.

References
----------
Methods text §9.1 (Delaunay-admissible boundaries in R^2: the ball of a
segment, the point of maximal angle, splitting at its projection).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from meshcore.delaunay.kernel2d import IncrementalDelaunay, _nxt, _prv
from meshcore.domain.planar import Domain
from meshcore.errors import InputError
from meshcore.geometry.constructions import point_segment_distance_2d
from meshcore.geometry.ordering import radix_sort
from meshcore.mesh.topology import edge_keys, group_slots

#: A projection closer than this fraction of ``|EP|`` to the nearer endpoint
#: ``E`` (``P`` the encroaching point) is too close ...
NEAR_END_TRIGGER = 0.125
#: ... and is replaced by the point at this fraction of ``|EP|`` from ``E``.
NEAR_END_FRACTION = 0.5
#: Split points move away from the nearer end by this fraction of their
#: distance to it (see "Ties of the projection" above).
NUDGE = 2.0**-20
#: Split points of two segments that meet this close (times the largest
#: coordinate magnitude) to an end of one of them: that end is within float64
#: rounding of the other segment (:meth:`_Pieces.touching`).
TOUCH = 2.0**-40

__all__: list[str] = []


@njit(cache=True, inline="always")
def _near_segment(pts, u, v, cx, cy, r2):
    """Float test, padded by the caller: segment uv comes within sqrt(r2) of (cx, cy)."""
    ux = pts[u, 0] - cx
    uy = pts[u, 1] - cy
    dx = pts[v, 0] - pts[u, 0]
    dy = pts[v, 1] - pts[u, 1]
    ll = dx * dx + dy * dy
    s = 0.0
    if ll > 0.0:
        s = min(1.0, max(0.0, -(ux * dx + uy * dy) / ll))
    fx = ux + s * dx
    fy = uy + s * dy
    return fx * fx + fy * fy <= r2


@njit(cache=True, inline="always")
def _push(stack, sp, r):
    """``r`` put at ``stack[sp]``, the int64 ``stack`` doubled when full:
    the stack (or queue) and its new length."""
    if sp == stack.shape[0]:
        stack = np.concatenate((stack, np.empty(sp, np.int64)))
    stack[sp] = r
    return stack, sp + 1


@njit(cache=True)
def _disc_edges(pts, V, A, vt, verts, radius, tstamp, counter):
    """Edges that come within ``radius[i]`` (padded) of vertex ``verts[i]``
    and do not end at it: the edges of the triangles meeting that disc (a
    search from the vertex's triangles). Returns (query, u, w) slot triples."""
    queue = np.empty(64, np.int64)
    qs = np.empty(64, np.int64)
    us = np.empty(64, np.int64)
    ws = np.empty(64, np.int64)
    m = 0
    stamp = counter[0]
    for i in range(verts.shape[0]):
        stamp += 1
        x = verts[i]
        cx = pts[x, 0]
        cy = pts[x, 1]
        r2 = (radius[i] * (1.0 + 1e-6)) ** 2
        t = vt[x]
        tstamp[t] = stamp
        queue[0] = t
        head = 0
        tail = 1
        while head < tail:
            t = queue[head]
            head += 1
            for j in range(3):
                kk = 3 * t + j
                u = V[_nxt(kk)]
                w = V[_prv(kk)]
                if not _near_segment(pts, u, w, cx, cy, r2):
                    continue
                if u != x and w != x:
                    if m == qs.shape[0]:
                        qs = np.concatenate((qs, np.empty(m, np.int64)))
                        us = np.concatenate((us, np.empty(m, np.int64)))
                        ws = np.concatenate((ws, np.empty(m, np.int64)))
                    qs[m] = i
                    us[m] = u
                    ws[m] = w
                    m += 1
                t2 = A[kk] // 3
                if tstamp[t2] == stamp or V[A[kk]] < 0:
                    continue
                tstamp[t2] = stamp
                queue, tail = _push(queue, tail, t2)
    counter[0] = stamp
    return qs[:m], us[:m], ws[:m]


@njit(cache=True)
def _grid_reach(xy, a, b, rows, verts, reach, radius, cell):
    """``reach`` (one per vertex ``verts[i]``) lowered to the distance from
    the vertex to the nearest piece ``rows[j]`` (ends ``a``, ``b``, points
    ``xy``) not incident to it, where that is closer; ``radius`` (at least
    ``reach``) bounds the search. Each vertex is filed in the cells of side
    ``cell`` that its disc's bounding box meets; each piece meets the
    vertices filed in the cells it crosses, column by column (its span in
    each column of cells, padded by a millionth of a cell: the cell of its
    nearest point to the vertex is among them), so every piece within
    ``radius`` is measured, each pair once; a farther one would not lower
    ``reach``. The distance is :func:`point_segment_distance`'s, to the
    same rounding."""
    k = verts.shape[0]
    X = np.empty((k, 2))
    for i in range(k):
        X[i, 0] = xy[verts[i], 0]
        X[i, 1] = xy[verts[i], 1]
    out = reach.copy()
    x0 = (X[:, 0] - radius).min()
    y0 = (X[:, 1] - radius).min()
    nx = int(((X[:, 0] + radius).max() - x0) / cell) + 1
    ny = int(((X[:, 1] + radius).max() - y0) / cell) + 1
    start = np.zeros(nx * ny + 1, np.int64)
    lx = ((X[:, 0] - radius - x0) / cell).astype(np.int64)
    hx = np.minimum(((X[:, 0] + radius - x0) / cell).astype(np.int64), nx - 1)
    ly = ((X[:, 1] - radius - y0) / cell).astype(np.int64)
    hy = np.minimum(((X[:, 1] + radius - y0) / cell).astype(np.int64), ny - 1)
    for i in range(k):
        for ix in range(lx[i], hx[i] + 1):
            for iy in range(ly[i], hy[i] + 1):
                start[ix * ny + iy + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(start[-1], np.int64)
    for i in range(k):
        for ix in range(lx[i], hx[i] + 1):
            for iy in range(ly[i], hy[i] + 1):
                members[fill[ix * ny + iy]] = i
                fill[ix * ny + iy] += 1
    seen = np.full(k, -1, np.int64)
    pad = 1e-6
    for j in range(rows.shape[0]):
        pa = a[rows[j]]
        pb = b[rows[j]]
        ux = xy[pa, 0]
        uy = xy[pa, 1]
        vx = xy[pb, 0]
        vy = xy[pb, 1]
        dx = vx - ux
        dy = vy - uy
        xa = min(ux, vx)
        xb = max(ux, vx)
        ya = min(uy, vy)
        yb = max(uy, vy)
        c0 = max(int(np.floor((xa - x0) / cell - pad)), 0)
        c1 = min(int(np.floor((xb - x0) / cell + pad)), nx - 1)
        for ix in range(c0, c1 + 1):
            lo = ya
            hi = yb
            if dx != 0.0:  # the piece's span of y over this column
                xl = max(xa, x0 + (ix - pad) * cell)
                xh = min(xb, x0 + (ix + 1 + pad) * cell)
                y1 = uy + (xl - ux) * (dy / dx)
                y2 = uy + (xh - ux) * (dy / dx)
                lo = max(ya, min(y1, y2))
                hi = min(yb, max(y1, y2))
            r0 = max(int(np.floor((lo - y0) / cell - pad)), 0)
            r1 = min(int(np.floor((hi - y0) / cell + pad)), ny - 1)
            for iy in range(r0, r1 + 1):
                c = ix * ny + iy
                for e in range(start[c], start[c + 1]):
                    i = members[e]
                    if seen[i] == j:
                        continue
                    seen[i] = j
                    if verts[i] == pa or verts[i] == pb:
                        continue
                    d = point_segment_distance_2d(X[i, 0], X[i, 1], ux, uy, vx, vy)
                    if d < out[i]:
                        out[i] = d
    return out


@njit(cache=True, inline="always")
def _ball_radius(xy, u, v, grow, pad):
    """The radius a ball query of segment ``uv`` searches: its half-length
    enlarged, ``half * grow + pad`` (``admissible._enlargement``)."""
    return 0.5 * np.hypot(xy[v, 0] - xy[u, 0], xy[v, 1] - xy[u, 1]) * grow + pad


@njit(cache=True)
def _ball_radii(xy, a, b, grow, pad):
    """:func:`_ball_radius` of each segment ``(a[i], b[i])``."""
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        out[i] = _ball_radius(xy, a[i], b[i], grow, pad)
    return out


def _near_segment_message(point: str, segment: str) -> str:
    """The message of ``point_near_segment``, the point and segment named."""
    return (
        f"{point} lies within float64 rounding of {segment} (closer than float64 resolves "
        "there: a split point between them rounds onto an existing point); segments must "
        "stay apart by more than rounding"
    )


def _unresolvable(xy: np.ndarray, segment: int, point: int) -> None:
    """Raise for input point ``point`` lying within float64 rounding of input
    segment ``segment`` (valid in floating point, not resolvable: a split
    point between them rounds onto the point or onto an end of the piece)."""
    msg = _near_segment_message(f"point {point} {xy[point].tolist()}", f"segment {segment}")
    code = "point_near_segment"
    raise InputError(
        msg,
        code=code,
        errors=[
            {"loc": ["segments", segment], "msg": msg, "type": code},
            {"loc": ["points", point], "msg": msg, "type": code},
        ],
    )


def located_in_domain(
    exc: InputError,
    domain: Domain,
    segments: np.ndarray,
    rows: np.ndarray | None = None,
    point_segment: np.ndarray | None = None,
) -> InputError:
    """``exc`` of :func:`admissible_segments` located in the domain (§9.1.5).

    ``segments`` are the domain's segments then constraints; a point the
    error names is located at its vertex, a segment at its first vertex
    (:meth:`Domain.vertex_loc`). When :func:`admissible_segments` ran on
    pieces of them (the triangulator's subsegments), ``rows`` gives each
    piece's segment and ``point_segment`` the segment each point beyond
    the domain's lies on: such a point is located at that segment. The
    message of ``point_near_segment`` then names the point and the segment
    by their rings and vertices (:meth:`Domain.vertex_name`).
    """
    errors = []
    names = {}
    for e in exc.errors:
        path = list(e["loc"])
        if len(path) == 2 and path[0] in ("points", "segments"):
            kind, i = path[0], int(path[1])
            if kind == "points" and i >= len(domain.points) and point_segment is not None:
                path[0], i = "segments", int(point_segment[i])
            elif kind == "segments" and rows is not None:
                i = int(rows[i])
            at = path[0]
            v = i if at == "points" else int(segments[i, 0])
            if v < len(domain.points):
                path = list(domain.vertex_loc(v))
                names[kind] = _domain_name(domain, segments, kind, at, i)
        errors.append({**e, "loc": path})
    message = exc.message
    if exc.code == "point_near_segment" and len(names) == 2:
        message = _near_segment_message(names["points"], names["segments"])
        errors = [{**e, "msg": message} for e in errors]
    return InputError(message, code=exc.code, errors=errors)


def _domain_name(domain: Domain, segments: np.ndarray, kind: str, at: str, i: int) -> str:
    """A point or segment of :func:`located_in_domain` named in the domain:
    an input point (``kind`` "points", located there: ``at`` "points") by
    its vertex, a segment or a point added on one (located at segment ``i``)
    by the segment's vertices."""
    if kind == "points" and at == "points":
        return f"{domain.vertex_name(i)} {domain.points[i].tolist()}"
    a, b = (domain.vertex_name(int(u)) for u in segments[i])
    name = f"the segment from {a} to {b}"
    return name if kind == "segments" else "a point added on " + name


@dataclass
class _State:
    P: np.ndarray
    S: np.ndarray
    source: np.ndarray
    seg_circle: np.ndarray
    acute: np.ndarray  # (m, 2) the end is in an acute cluster (of the input)
    done: np.ndarray  # (m, 2): the end is protected (an apex subsegment)
    radius: np.ndarray  # (n,) protection radius per vertex, NaN if none yet
    near: np.ndarray  # (m, 2) projection splits made near that end of the piece
    n0: int  # input points (the first rows of P)


@njit(cache=True)
def _chain_order(head, nxt, m):
    """Piece ids chain by chain (input segment order), each from its first end."""
    out = np.empty(m, np.int64)
    k = 0
    for s in range(head.shape[0]):
        r = head[s]
        while r >= 0:
            out[k] = r
            k += 1
            r = nxt[r]
    return out


@njit(cache=True)
def _in_chain_order(base, n, m, head, nxt, piece, point):
    """The pieces in chain order and the points added (``base, ..., n - 1``)
    numbered by the position of the piece they start (:meth:`_Pieces.to_state`):
    ``(xy, radius)`` of the points and ``(ends, src, circ, acute, done, near)``
    of the pieces, new arrays."""
    a, b, src, circ, acute, done, near = piece
    xy, radius, right = point
    order = _chain_order(head, nxt, m)
    pos = np.empty(m, np.int64)
    for i in range(m):
        pos[order[i]] = i
    k = n - base
    key = np.empty(k, np.int64)
    for i in range(k):
        key[i] = pos[right[base + i]]
    # (one linear-time sort of a unique key)
    new = radix_sort(key, np.arange(base, n))[1]
    label = np.arange(n)
    xy_out = np.empty((n, 2))
    radius_out = np.empty(n)
    xy_out[:base] = xy[:base]
    radius_out[:base] = radius[:base]
    for i in range(k):
        label[new[i]] = base + i
        xy_out[base + i, 0] = xy[new[i], 0]
        xy_out[base + i, 1] = xy[new[i], 1]
        radius_out[base + i] = radius[new[i]]
    ends = np.empty((m, 2), np.int64)
    src_out = np.empty(m, src.dtype)
    circ_out = np.empty(m, circ.dtype)
    acute_out = np.empty((m, 2), acute.dtype)
    done_out = np.empty((m, 2), done.dtype)
    near_out = np.empty((m, 2), near.dtype)
    for i in range(m):
        r = order[i]
        ends[i, 0] = label[a[r]]
        ends[i, 1] = label[b[r]]
        src_out[i] = src[r]
        circ_out[i] = circ[r]
        for s in range(2):
            acute_out[i, s] = acute[r, s]
            done_out[i, s] = done[r, s]
            near_out[i, s] = near[r, s]
    return (xy_out, radius_out), (ends, src_out, circ_out, acute_out, done_out, near_out)


def _grown(arr: np.ndarray, size: int) -> np.ndarray:
    """``arr`` in a longer array (the rows beyond it are written before
    they are read: the splitting loop fills every new piece and point)."""
    out = np.empty((size,) + arr.shape[1:], dtype=arr.dtype)
    out[: len(arr)] = arr
    return out


class _Pieces:
    """The segments during the splits, by piece id, in growable arrays.

    A split keeps the piece's id for its first part and gives each new
    point the id of the piece that starts there, so a split costs time in
    the pieces it makes and checks, not in all of them; :meth:`to_state`
    puts the pieces back in chain order and numbers the added points along
    the chains, so the output does not depend on this bookkeeping.
    """

    _ROW = ("a", "b", "nxt", "src", "circ", "acute", "done", "near")
    _POINT = ("xy", "radius", "left", "right", "beside")

    def __init__(self, st: _State, dt: IncrementalDelaunay) -> None:
        S, m, n = st.S, len(st.S), len(st.P)
        self.dt, self.n0, self.base, self.m, self.n = dt, st.n0, n, m, n
        self.a, self.b = S[:, 0].copy(), S[:, 1].copy()
        self.src = st.source.copy()
        self.circ = st.seg_circle.copy()
        self.acute, self.done, self.near = st.acute.copy(), st.done.copy(), st.near.copy()
        last = np.ones(m, dtype=bool)
        last[:-1] = self.src[1:] != self.src[:-1]
        self.nxt = np.where(last, -1, np.arange(1, m + 1))
        m0 = int(self.src[-1]) + 1 if m else 0
        self.head = np.full(m0, -1, dtype=np.int64)
        self.head[self.src[::-1]] = np.arange(m)[::-1]
        self.tail = np.full(m0, -1, dtype=np.int64)
        self.tail[self.src[last]] = np.flatnonzero(last)
        self.xy, self.radius = st.P.copy(), st.radius.copy()
        self.left = np.full(n, -1, dtype=np.int64)
        self.right = np.full(n, -1, dtype=np.int64)
        self.left[S[:, 1]] = np.arange(m)
        self.right[S[:, 0]] = np.arange(m)
        # The points before and after each added point along its chain
        # (those of input points are not read).
        self.beside = np.full((n, 2), -1, dtype=np.int64)
        self.beside[S[:, 1], 0] = S[:, 0]
        self.beside[S[:, 0], 1] = S[:, 1]
        # Chain ends at the input points: (chain, side) per point, CSR.
        ends = np.concatenate([S[self.head, 0], S[self.tail, 1]])
        chain = np.concatenate([np.arange(m0), np.arange(m0)])
        side = np.repeat([0, 1], m0)
        order, self.end_start = group_slots(ends, n)
        self.end_chain, self.end_side = chain[order], side[order]
        keys = edge_keys(S[self.head, 0], S[self.tail, 1], st.n0)
        self.input_chain = np.argsort(keys)
        self.input_keys = keys[self.input_chain]
        # Marks of the compiled searches.
        self.tstamp = np.zeros(0, np.int64)
        self.vstamp = np.zeros(0, np.int64)
        self.counter = np.zeros(1, np.int64)

    # Views of the live rows, as the errors and protections read them.
    @property
    def P(self) -> np.ndarray:
        return self.xy[: self.n]

    @property
    def S(self) -> np.ndarray:
        return np.column_stack([self.a[: self.m], self.b[: self.m]])

    @property
    def source(self) -> np.ndarray:
        return self.src[: self.m]

    @property
    def seg_circle(self) -> np.ndarray:
        return self.circ[: self.m]

    def reserve(self, rows: int, points: int) -> None:
        """Room for this many more pieces and points (doubling)."""
        if self.m + rows > len(self.a):
            size = max(self.m + rows, 2 * len(self.a))
            for name in self._ROW:
                setattr(self, name, _grown(getattr(self, name), size))
        if self.n + points > len(self.xy):
            size = max(self.n + points, 2 * len(self.xy))
            for name in self._POINT:
                setattr(self, name, _grown(getattr(self, name), size))

    def stamps(self):
        """The compiled searches' marks ``(tstamp, vstamp, counter)``, as long
        as the triangulation's triangles and points."""
        pts, V = self.dt.arrays()[:2]
        if len(self.tstamp) < len(V) // 3 or len(self.vstamp) < len(pts):
            self.tstamp = np.zeros(len(V) // 3, np.int64)
            self.vstamp = np.zeros(len(pts), np.int64)
            self.counter[0] = 0
        return self.tstamp, self.vstamp, self.counter

    def touching(self, s1: int, s2: int, y: int) -> None:
        """Raise ``point_near_segment`` when the split points of input
        segments ``s1`` and ``s2`` met at added point ``y`` next to an end
        ``E`` of one of them (within :data:`TOUCH` times the largest
        coordinate magnitude): ``E`` lies within float64 rounding of the
        other segment, and the splits between them reached float64
        resolution (a valid polygon in floating point whose vertex is on
        another side in exact rationals). Segments that cross meet away
        from their ends and are left to the caller's AlgorithmError."""
        if s1 == s2:
            return
        chains = np.array([s1, s2])
        ends = np.concatenate([self.a[self.head[chains]], self.b[self.tail[chains]]])
        d = np.hypot(*(self.xy[ends] - self.xy[y]).T)
        k = int(np.argmin(d))
        if d[k] <= TOUCH * float(np.abs(self.xy[: self.n]).max()):
            _unresolvable(self.xy, s2 if k % 2 == 0 else s1, int(ends[k]))

    def edge_pieces_near(self, verts, radius):
        """(query, piece) pairs: pieces that are edges of the triangulation,
        come within ``radius[i]`` (padded) of ``verts[i]`` and do not end there."""
        pts, V, A, vt, order, slot = self.dt.arrays()
        tstamp, _, counter = self.stamps()
        q, u, w = _disc_edges(pts, V, A, vt, slot[verts], radius * self.dt.scale, tstamp, counter)
        u, w = order[u], order[w]
        # Candidate pieces: those at an added end, and the unsplit input
        # segment joining two input points.
        cand = [self.left[u], self.right[u], self.left[w], self.right[w]]
        both = (u < self.n0) & (w < self.n0)
        s = self._input_segment(u[both], w[both])
        row = np.full(len(u), -1, dtype=np.int64)
        row[np.flatnonzero(both)[s >= 0]] = self.head[s[s >= 0]]
        cand.append(row)
        qq = np.tile(q, len(cand))
        uu, ww = np.tile(u, len(cand)), np.tile(w, len(cand))
        rows = np.concatenate(cand)
        ok = rows >= 0
        qq, uu, ww, rows = qq[ok], uu[ok], ww[ok], rows[ok]
        ra, rb = self.a[rows], self.b[rows]
        match = ((ra == uu) & (rb == ww)) | ((ra == ww) & (rb == uu))
        return qq[match], rows[match]

    def end_pieces(self, verts):
        """The pieces at input points ``verts`` (the first or last piece of
        each chain that ends there): their ends (k, 2) and acute flags (k, 2)."""
        lo, hi = self.end_start[verts], self.end_start[verts + 1]
        counts = hi - lo
        idx = np.repeat(lo - (np.cumsum(counts) - counts), counts) + np.arange(counts.sum())
        chain, side = self.end_chain[idx], self.end_side[idx]
        rows = np.where(side == 0, self.head[chain], self.tail[chain])
        return np.column_stack([self.a[rows], self.b[rows]]), self.acute[rows]

    def _input_segment(self, u, w) -> np.ndarray:
        """The chain (input segment) joining input points u and w, or -1."""
        keys = edge_keys(u, w, self.n0)
        pos = np.minimum(np.searchsorted(self.input_keys, keys), len(self.input_keys) - 1)
        return np.where(self.input_keys[pos] == keys, self.input_chain[pos], -1)

    def to_state(self, st: _State) -> None:
        """Back to chain order; the points added here numbered along the chains."""
        (st.P, st.radius), (st.S, st.source, st.seg_circle, st.acute, st.done, st.near) = (
            _in_chain_order(
                self.base, self.n, self.m, self.head, self.nxt,
                (self.a, self.b, self.src, self.circ, self.acute, self.done, self.near),
                (self.xy, self.radius, self.right),
            )
        )  # fmt: skip
