"""Paving's large closure polygons by midpoint subdivision into grids (§8.5.1, §8.7.2).

A helper of :mod:`meshcore.quads.paving_fronts`: a closure polygon without
holes of at least ``_LEAST`` nodes whose corners (interior angle below
``_CORNER`` degrees) cut it in ``k`` sides of ``n_1 .. n_k`` segments is
meshed as ``k`` structured patches meeting at one centre (the midpoint
subdivision of Tam and Armstrong): side ``i`` is split at a node ``m_i``,
each ``m_i`` joined to the centre by a straight *spoke* of ``s_i``
segments, and the patch at corner ``c`` between the spokes of its two sides
is a grid, so its opposite sides have equal counts: ``n_i = s_{i-1} +
s_{i+1}``. For ``k = 3`` that gives ``s_i = N / 2 - n_i`` (``N`` the
polygon's count, even), for ``k = 5`` the unique solution of the cyclic
system; each must be a whole number of at least 1. A 4-sided polygon with
equal opposite counts is one grid. The grids' points are the transfinite
(Coons) interpolation of their four sides, the spokes straight and evenly
cut. Two centres are tried, the mean of the ``m_i`` and the point whose
distances to them come nearest (least squares, ``_FIT_STEPS``
Gauss-Newton steps) to ``s_i`` times the polygon's mean segment, and the
template of the higher least quality is kept (only the fitted centre
passes on the plate with 20 holes at 10k quads: valence-4 share 89.17 ->
89.75 %, least quality and scaled Jacobian unchanged). Every set of at
least 3 of the corners is tried (a corner left out is a node of a side),
and of the templates whose quads are all strictly convex (exact) and of
quality at least ``_LEAST_Q`` the one of the highest least quality is
kept (measured against dropping the flattest corner one at a time: the
plate at 10k quads 89.75 -> 90.42 %, at 100k 92.56 -> 92.71 %, the gear
at 100k 98.50 -> 98.57 %, least quality and scaled Jacobian as before the
templates). When none passes, the polygon is left to the recursive
partition.

Only the centre is irregular (valence ``k``; none for one grid): the
partition of the same polygon leaves irregular vertices all over it (the
corner pockets between the rows of a square and of a round hole in it: 890
of the 1,272 irregular interior vertices before the clean-up on the square
with a hole at 100k quads).

Why the quads cover the polygon exactly once: each is strictly convex and
counter-clockwise (exact :func:`orient2d`), and the sum of their boundary
chains is the polygon's (every spoke and grid line is walked once each way),
so the count of quads over a point is the polygon's winding number (the
argument of :mod:`meshcore.quads.paving_fronts`).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from meshcore.geometry.constructions import coons_grid
from meshcore.mesh.quality import quad_quality
from meshcore.quads import paving_kernel as pk

_LEAST = 12  # polygons with fewer nodes are left to the partition
_CORNER = 135.0  # a node of a smaller interior angle (degrees) is a corner
_MOST_CORNERS = 6  # polygons with more corners are left to the partition
_FIT_STEPS = 20  # Gauss-Newton steps fitting a template's centre to its spoke counts
_LEAST_Q = 0.4  # least quality (8.4) of a template's quad


def _spokes(n: np.ndarray) -> np.ndarray | None:
    """The spoke counts ``s`` with ``n_i = s_{i-1} + s_{i+1}`` (k = 3 or 5), or None."""
    k = len(n)
    if k not in (3, 5):
        return None
    A = np.zeros((k, k))
    i = np.arange(k)
    A[i, (i - 1) % k] = A[i, (i + 1) % k] = 1.0
    s = np.linalg.solve(A, n.astype(float))
    r = np.rint(s)
    if np.abs(s - r).max() > 1e-9 or r.min() < 1:
        return None
    return r.astype(np.int64)


class _Grids:
    """The points and quads of a template, new points numbered from ``n``."""

    def __init__(self, P: np.ndarray):
        self.P = P
        self.n = len(P)
        self.pts: list[np.ndarray] = []
        self.quads: list[np.ndarray] = []

    def new(self, xy: np.ndarray) -> np.ndarray:
        ids = self.n + np.arange(len(xy))
        self.n += len(xy)
        self.pts.append(xy)
        return ids

    def grid(self, bot, right, top, left) -> None:
        """A grid on four id chains (as :func:`coons_grid`), corners shared."""
        Q = np.concatenate([self.P, *self.pts]) if self.pts else self.P
        xy = coons_grid(Q[bot], Q[right], Q[top], Q[left])
        a, b = len(bot) - 1, len(left) - 1
        g = np.empty((a + 1, b + 1), np.int64)
        g[:, 0], g[:, b], g[0, :], g[a, :] = bot, top, left, right
        if a > 1 and b > 1:
            g[1:a, 1:b] = self.new(xy[1:a, 1:b].reshape(-1, 2)).reshape(a - 1, b - 1)
        quads = np.stack([g[:-1, :-1], g[1:, :-1], g[1:, 1:], g[:-1, 1:]], axis=-1)
        self.quads.append(quads.reshape(-1, 4))

    def done(self):
        pts = np.concatenate(self.pts) if self.pts else np.zeros((0, 2))
        return pts, np.concatenate(self.quads)


def _centres(P: np.ndarray, loop: np.ndarray, M: np.ndarray, s: np.ndarray) -> list:
    """Two centres tried: the mean of the spokes' ends ``M``, and the point whose
    distances to them are nearest (least squares, Gauss-Newton) to the spoke
    counts ``s`` times the polygon's mean segment."""
    X = P[loop]
    want = s * float(np.hypot(*(np.roll(X, -1, axis=0) - X).T).mean())
    c = mean = M.mean(axis=0)
    for _ in range(_FIT_STEPS):
        d = c - M
        r = np.hypot(d[:, 0], d[:, 1])
        J = d / np.maximum(r, 1e-300)[:, None]
        c = c - np.linalg.lstsq(J, r - want, rcond=None)[0]
    return [mean, c] if np.isfinite(c).all() else [mean]


def _subdivided(P: np.ndarray, loop: np.ndarray, at: np.ndarray) -> list:
    """The templates on corners at positions ``at`` of ``loop``: [(points, quads)]."""
    N, k = len(loop), len(at)
    n = (np.roll(at, -1) - at) % N
    if k == 4:
        if n[0] != n[2] or n[1] != n[3]:
            return []
        g = _Grids(P)
        side = [loop[(at[i] + np.arange(n[i] + 1)) % N] for i in range(4)]
        g.grid(side[0], side[1], side[2][::-1], side[3][::-1])
        return [g.done()]
    s = _spokes(n)
    if s is None:
        return []
    # m_i at p_i = s_{i-1} segments past corner i; spoke i from m_i to the centre
    m = (at + np.roll(s, 1)) % N
    out = []
    for xy in _centres(P, loop, P[loop[m]], s):
        g = _Grids(P)
        centre = g.new(xy[None, :])[0]
        spokes = []
        for i in range(k):
            a = P[loop[m[i]]]
            t = (np.arange(1, s[i]) / s[i])[:, None]
            inner = g.new(a + t * (xy - a)) if s[i] > 1 else np.zeros(0, np.int64)
            spokes.append(np.concatenate([[loop[m[i]]], inner, [centre]]))
        for i in range(k):
            j = (i + 1) % k  # the patch at corner j, between spokes i and j
            bot = loop[(m[i] + np.arange(s[j] + 1)) % N]
            right = loop[(at[j] + np.arange(s[i] + 1)) % N]
            g.grid(bot, right, spokes[j][::-1], spokes[i])
        out.append(g.done())
    return out


def template(P: np.ndarray, loop: np.ndarray, theta: np.ndarray):
    """A polygon's midpoint-subdivision mesh (module docstring): ``(new points,
    quads)`` with new ids from ``len(P)``, counter-clockwise, strictly convex
    (exact), of quality at least ``_LEAST_Q``, covering the polygon exactly
    once (module docstring); or None. ``loop``: the polygon's nodes,
    counter-clockwise (the domain on the left); ``theta``: the interior
    angle (degrees) at each node. References: §8.5.1 (closing the last
    region of paving), §8.7.2 (splitting a polygon into meshable patterns).
    """
    N = len(loop)
    if N < _LEAST or len(np.unique(loop)) != N:
        return None
    at = np.flatnonzero(theta < _CORNER)
    if not 3 <= len(at) <= _MOST_CORNERS:
        return None
    # on the polygon's own points (ids 0 .. N-1, new ones from N): no copy of P per try
    X, own = P[loop], np.arange(N)
    best, least = None, _LEAST_Q
    for k in range(len(at), 2, -1):
        for corners in combinations(at.tolist(), k):
            for pts, quads in _subdivided(X, own, np.asarray(corners, np.int64)):
                Q = np.concatenate([X, pts])
                if pk.convex_and_good(Q, quads, _LEAST_Q).all():
                    q = float(quad_quality(Q, quads).min())
                    if best is None or q > least:
                        best, least = (pts, quads), q
    if best is None:
        return None
    pts, quads = best  # own ids back to P's: the loop's, then the new points' from len(P)
    return pts, np.concatenate([loop, len(P) + np.arange(len(pts))])[quads]
