"""An editable store of simplices with per-vertex corner lists (§8.3.2, §8.3.4).

The compiled local-modification loops (the optimization method of §8.3 in
:mod:`meshcore.optimize`, the sliver removal of :mod:`meshcore.tets.improve`)
edit a mesh topology (Definition 8.1) cell by cell. Their shared state:

* ``T``: rows of cells (triangles ``(mcap, 3)`` or tetrahedra ``(mcap, 4)``
  int64), ``alive`` (uint8) flags a live row, dead rows are listed in
  ``freeT`` for reuse;
* per vertex a doubly linked list of its *corners*: slot ``per * t + j`` is
  corner ``j`` of row ``t`` (``per`` the width of ``T``), ``head[v]`` the
  first slot of vertex ``v``, ``nxt``/``prv`` the links. The ball of a
  vertex is a walk of its list; adding or removing a cell costs its width;
* ``cnt`` (int64): points used, rows used, free rows, and a stamp that the
  loops increment to mark sets without clearing arrays (``N_PTS``,
  ``N_ROWS``, ``N_FREE``, ``STAMP``).

A tetrahedron ``(a, b, c, d)`` is positive when ``det[b - a, c - a, d - a]
> 0`` (:func:`positive`, exact); its faces :data:`FACE` are then outward
and :data:`EDGES` are its six edges. The corner lists, :func:`remove_cell`
and :func:`build` serve triangles as well; the rest is for tetrahedra.

Choices the text leaves open: a face is known by the integer key
:func:`face_key` of its sorted vertices (base ``n`` above every vertex
number); the candidate new points around a tetrahedron of
:func:`star_point` and the star cavity :func:`star_cavity` that makes every
tetrahedron of Op(G, δ𝒮) positive.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates3d import orient3d_scalar

#: ``cnt`` entries: points used, rows used, free rows, stamp.
N_PTS, N_ROWS, N_FREE, STAMP = range(4)
#: Largest set of tetrahedra :func:`gather` and :func:`star_cavity` collect.
SMAX = 512
#: Faces of a tetrahedron row, outward for a positive tetrahedron.
FACE = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], np.int64)
#: The six edges of a tetrahedron row.
EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], np.int64)
#: Candidate points G of :func:`star_point` around one tetrahedron.
STARS = 17
#: Offsets of the face candidates of :func:`star_point`, in mean edge lengths.
STAR_OFFSETS = (0.05, 0.3, 0.6)


class CellStore:
    """The arrays of a compiled loop: cell rows, corner lists, free rows, spare points.

    Parameters
    ----------
    P : (n, d) float64
        Points (copied; ``spare_points`` zero rows follow for insertions).
    cells : (m, 3) or (m, 4) int64
        The initial cells (rows ``0..m-1``).
    fixed : (n,) bool or uint8
        Points that may not move or vanish.
    spare_points : int
        Rows of points reserved for insertions (``cnt[N_PTS]`` counts the used
        ones).
    spare_rows : int, optional
        Rows allocated after the cells (default ``m + 256``: twice as many rows
        plus 256).

    The arrays (``P``, ``fixed``, ``cnt``, ``T``, ``alive``, ``head``,
    ``nxt``, ``prv``, ``free``) are passed to the compiled loops, which edit
    them in place; :meth:`grow_rows` and :meth:`grow_points` make room when a
    loop reports it is out of rows or points, keeping the live cells in order.
    """

    def __init__(self, P, cells, fixed, spare_points: int = 0, spare_rows: int | None = None):
        n = len(P)
        self.P = np.zeros((n + spare_points, P.shape[1]))
        self.P[:n] = P
        self.fixed = np.zeros(n + spare_points, np.uint8)
        self.fixed[:n] = fixed
        self.cnt = np.array([n, 0, 0, 0], np.int64)
        self.T = None
        self._rows(cells, len(cells) + (len(cells) + 256 if spare_rows is None else spare_rows))

    def _rows(self, cells: np.ndarray, mcap: int) -> None:
        """``cells`` (a copy) in rows ``0..m-1`` of ``mcap`` rows, linked; the row arrays
        reused in place when they already have ``mcap`` rows, else the old ones dropped
        before the new are made (no two sets alive at once)."""
        m, per = cells.shape
        if self.T is not None and self.T.shape[0] == mcap:
            self.T[m:] = 0
            self.alive[:] = 0
            self.nxt.fill(-1)
            self.prv.fill(-1)
            self.free[:] = 0
        else:
            self.T = self.alive = self.nxt = self.prv = self.free = None
            self.T = np.zeros((mcap, per), np.int64)
            self.alive = np.zeros(mcap, np.uint8)
            self.nxt = np.full(per * mcap, -1, np.int64)
            self.prv = np.full(per * mcap, -1, np.int64)
            self.free = np.zeros(mcap, np.int64)
        self.T[:m] = cells
        self.alive[:m] = 1
        self.head = np.full(len(self.P), -1, np.int64)
        self.cnt[N_ROWS] = m
        self.cnt[N_FREE] = 0
        build(self.T, m, len(self.P), self.head, self.nxt, self.prv)

    def grow_rows(self, extra: int = 0) -> None:
        """Twice the rows (and ``extra`` more), the live cells kept in order."""
        self._rows(self.cells(), 2 * self.T.shape[0] + extra)

    def grow_points(self, spare: int) -> None:
        """``spare`` unused point rows after the used ones, the live cells kept in order."""
        n = int(self.cnt[N_PTS])
        P, fixed = self.P[:n].copy(), self.fixed[:n].copy()
        self.P = np.zeros((n + spare, P.shape[1]))
        self.P[:n] = P
        self.fixed = np.zeros(n + spare, np.uint8)
        self.fixed[:n] = fixed
        self._rows(self.cells(), self.T.shape[0])

    def cells(self) -> np.ndarray:
        """The live cells, in row order (a copy)."""
        rows = int(self.cnt[N_ROWS])
        return self.T[:rows][self.alive[:rows].astype(bool)]  # a mask: a copy already

    def points(self) -> np.ndarray:
        """The used points (a view)."""
        return self.P[: int(self.cnt[N_PTS])]


@njit(cache=True)
def link_corner(head, nxt, prv, s, v):
    """Slot ``s`` put first in the corner list of vertex ``v``."""
    nxt[s] = head[v]
    prv[s] = -1
    if head[v] >= 0:
        prv[head[v]] = s
    head[v] = s


@njit(cache=True)
def unlink_corner(head, nxt, prv, s, v):
    """Slot ``s`` taken out of the corner list of vertex ``v``."""
    if prv[s] >= 0:
        nxt[prv[s]] = nxt[s]
    else:
        head[v] = nxt[s]
    if nxt[s] >= 0:
        prv[nxt[s]] = prv[s]


@njit(cache=True)
def remove_cell(T, alive, head, nxt, prv, freeT, cnt, t):
    """Row t freed: its corners unlinked (triangles or tetrahedra, by ``T``'s width)."""
    per = T.shape[1]
    for j in range(per):
        unlink_corner(head, nxt, prv, per * t + j, T[t, j])
    alive[t] = 0
    freeT[cnt[N_FREE]] = t
    cnt[N_FREE] += 1


@njit(cache=True)
def build(T, m, n, head, nxt, prv):
    """Corner lists of the first ``m`` rows of ``T`` over ``n`` vertices (slot ``per * t + j``).

    Triangles or tetrahedra: ``per`` is ``T``'s width.
    """
    head[:n] = -1
    per = T.shape[1]
    for t in range(m):
        for j in range(per):
            link_corner(head, nxt, prv, per * t + j, T[t, j])


@njit(cache=True, inline="always")  # inlined: no compiled copy per literal ``need``
def room(T, cnt, need):
    """True when ``need`` more rows fit (free rows plus rows never used)."""
    return cnt[N_FREE] + T.shape[0] - cnt[N_ROWS] >= need


@njit(cache=True)
def take_row(alive, freeT, cnt):
    """A row for a new cell, marked alive: the last freed one, or the next unused one.

    The caller checks :func:`room` first, writes the cell in the row and links it
    (:func:`link_row`).
    """
    if cnt[N_FREE] > 0:
        cnt[N_FREE] -= 1
        t = freeT[cnt[N_FREE]]
    else:
        t = cnt[N_ROWS]
        cnt[N_ROWS] += 1
    alive[t] = 1
    return t


@njit(cache=True)
def link_row(T, head, nxt, prv, t):
    """The corners of row t put in their vertices' lists (triangles or tetrahedra)."""
    per = T.shape[1]
    for j in range(per):
        link_corner(head, nxt, prv, per * t + j, T[t, j])


@njit(cache=True)
def add_tet(T, alive, head, nxt, prv, freeT, cnt, a, b, c, d):
    """Tetrahedron (a, b, c, d) in a new row (:func:`take_row`), linked; its row."""
    t = take_row(alive, freeT, cnt)
    T[t, 0], T[t, 1], T[t, 2], T[t, 3] = a, b, c, d
    link_row(T, head, nxt, prv, t)
    return t


@njit(cache=True, inline="always")
def face_cross(P, a, b, c):
    """(P[b] - P[a]) x (P[c] - P[a]), float: twice the area of face (a, b, c) times its unit
    normal, on the side from which (a, b, c) turns counter-clockwise."""
    ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    return uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx


@njit(cache=True, inline="always")
def positive(P, a, b, c, d):
    """True when tet (a, b, c, d) has a positive volume det[b-a, c-a, d-a] (exact orient3d)."""
    return (
        orient3d_scalar(
            P[a, 0],
            P[a, 1],
            P[a, 2],
            P[b, 0],
            P[b, 1],
            P[b, 2],
            P[c, 0],
            P[c, 1],
            P[c, 2],
            P[d, 0],
            P[d, 1],
            P[d, 2],
        )
        < 0
    )


@njit(cache=True, inline="always")
def det_edges(P, a, b, c, d):
    """(6 V signed, the sum of the squared edges) of tet (a, b, c, d), in floats."""
    ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    wx, wy, wz = P[d, 0] - P[a, 0], P[d, 1] - P[a, 1], P[d, 2] - P[a, 2]
    det = ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)
    s = ux * ux + uy * uy + uz * uz + vx * vx + vy * vy + vz * vz + wx * wx + wy * wy + wz * wz
    s += (vx - ux) ** 2 + (vy - uy) ** 2 + (vz - uz) ** 2
    s += (wx - ux) ** 2 + (wy - uy) ** 2 + (wz - uz) ** 2
    s += (wx - vx) ** 2 + (wy - vy) ** 2 + (wz - vz) ** 2
    return det, s


@njit(cache=True, inline="always")
def solid(P, a, b, c, d, flat):
    """Tet (a, b, c, d) positive by the exact orient3d and not flat to the placement:
    6 V > ``flat`` times the sum of its squared edges (``meshcore.optimize.coupez.flatness``;
    ``flat`` 0: :func:`positive`)."""
    if not positive(P, a, b, c, d):
        return False
    if flat <= 0.0:
        return True
    det, s = det_edges(P, a, b, c, d)
    return det > flat * s


@njit(cache=True, inline="always")
def holds(T, t, v):
    """True when row t has vertex v."""
    return T[t, 0] == v or T[t, 1] == v or T[t, 2] == v or T[t, 3] == v


@njit(cache=True)
def gather(head, nxt, v, w, T, st, tmark, stamp, k):
    """Append the tets of v's ball (holding w too when w >= 0: the shell of edge (v, w)) not
    yet marked ``stamp`` in ``tmark`` to st[:k], marking them; the new count, -1 past SMAX."""
    s = head[v]
    while s >= 0:
        t = s // 4
        if tmark[t] != stamp and (w < 0 or holds(T, t, w)):
            if k >= SMAX:
                return -1
            tmark[t] = stamp
            st[k] = t
            k += 1
        s = nxt[s]
    return k


@njit(cache=True)
def face_key(a, b, c, n):
    """The key of face {a, b, c} (any order), vertices below ``n``: equal faces, equal keys."""
    lo = min(a, min(b, c))
    hi = max(a, max(b, c))
    mid = a + b + c - lo - hi
    return (lo * n + mid) * n + hi


@njit(cache=True)
def boundary(T, st, k, n, bf):
    """δ𝒮 of 𝒮 = st[:k]: its faces held once within it, outward, in bf; their count, or -1
    when a face is held three times or more (``n`` above every vertex number)."""
    keys = np.empty(4 * k, np.int64)
    for i in range(k):
        t = st[i]
        for j in range(4):
            f = FACE[j]
            keys[4 * i + j] = face_key(T[t, f[0]], T[t, f[1]], T[t, f[2]], n)
    order = np.argsort(keys)
    nb = 0
    i = 0
    while i < 4 * k:
        j = i
        while j + 1 < 4 * k and keys[order[j + 1]] == keys[order[i]]:
            j += 1
        if j - i >= 2:
            return -1
        if j == i:
            s = order[i]
            t = st[s // 4]
            f = FACE[s % 4]
            bf[nb, 0], bf[nb, 1], bf[nb, 2] = T[t, f[0]], T[t, f[1]], T[t, f[2]]
            nb += 1
        i = j + 1
    return nb


@njit(cache=True)
def across(T, head, nxt, u, j):
    """The tet across face j of tet u, or -1 (a boundary face)."""
    f = FACE[j]
    a, b, c = T[u, f[0]], T[u, f[1]], T[u, f[2]]
    s = head[a]
    while s >= 0:
        x = s // 4
        if x != u and holds(T, x, b) and holds(T, x, c):
            return x
        s = nxt[s]
    return -1


@njit(cache=True)
def star_point(P, T, head, nxt, t, c, g):
    """Write in row g the c-th candidate G around tet t; False when there is none.

    c < 12: the centroid of face c % 4 moved off it to the side from which the
    face is positive, by 0.05, 0.3 or 0.6 (c // 4 = 0, 1, 2) of the tet's mean
    edge length (a flat tet has one side up, one down: G above or below it);
    c < 16: the centroid of the positive tet across face c - 12; 16: the
    centroid of t.
    """
    if 12 <= c < 16:
        u = across(T, head, nxt, t, c - 12)
        if u < 0 or not positive(P, T[u, 0], T[u, 1], T[u, 2], T[u, 3]):
            return False
        t = u
    if c >= 12:
        for x in range(3):
            P[g, x] = 0.25 * (P[T[t, 0], x] + P[T[t, 1], x] + P[T[t, 2], x] + P[T[t, 3], x])
        return True
    h = 0.0
    for e in range(6):
        a, b = T[t, EDGES[e, 0]], T[t, EDGES[e, 1]]
        h += math.sqrt(
            (P[a, 0] - P[b, 0]) ** 2 + (P[a, 1] - P[b, 1]) ** 2 + (P[a, 2] - P[b, 2]) ** 2
        )
    f = FACE[c % 4]
    a, b, d = T[t, f[0]], T[t, f[1]], T[t, f[2]]
    # (G, a, b, d) is positive for G on the side of -(b - a) x (d - a)
    n0, n1, n2 = face_cross(P, a, b, d)
    n0, n1, n2 = -n0, -n1, -n2
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if nn == 0.0:
        return False
    step = STAR_OFFSETS[c // 4] * h / 6.0 / nn
    P[g, 0] = (P[a, 0] + P[b, 0] + P[d, 0]) / 3.0 + step * n0
    P[g, 1] = (P[a, 1] + P[b, 1] + P[d, 1]) / 3.0 + step * n1
    P[g, 2] = (P[a, 2] + P[b, 2] + P[d, 2]) / 3.0 + step * n2
    return True


@njit(cache=True)
def star_cavity(P, T, head, nxt, t, g, st, tmark, stamp, flat=0.0):
    """The star cavity of point g around tet t in st; its size, or -1.

    From 𝒮 = {t}, every tet across a face of δ𝒮 that g does not see
    positively (:func:`solid`: exact orient3d, not flat to ``flat``) joins 𝒮,
    breadth first, so that on return every tet of Op(g, δ𝒮) is positive. g
    may be a vertex of the mesh: the faces holding it make no tet (Op skips
    them). -1 when such a face is a boundary face (g is not inside there) or
    𝒮 would exceed ``SMAX`` tets.
    """
    st[0] = t
    tmark[t] = stamp
    k = 1
    i = 0
    while i < k:
        u = st[i]
        for j in range(4):
            w = across(T, head, nxt, u, j)
            if w >= 0 and tmark[w] == stamp:
                continue
            f = FACE[j]
            x, y, z = T[u, f[0]], T[u, f[1]], T[u, f[2]]
            if x == g or y == g or z == g or solid(P, g, x, y, z, flat):
                continue
            if w < 0 or k >= SMAX:
                return -1
            tmark[w] = stamp
            st[k] = w
            k += 1
        i += 1
    return k
