"""What inserting a point on a surface would leave missing (the look-ahead of
:mod:`meshcore.delaunay.admissible3d`, methods text §9.2, §9.3.4).

Inserting a point ``X`` into a Delaunay tetrahedralization removes the
tetrahedra whose circumsphere holds it (its *cavity*) and joins ``X`` to the
cavity's boundary faces (Bowyer-Watson). So, before inserting, one knows which
of the surface's pieces (subfaces, subface edges) it takes away (all their
tetrahedra in the cavity, not on the hull) and which of the new pieces at ``X``
it makes (an edge ``XV`` where ``V`` is a vertex of the cavity, a face ``XPQ``
where ``PQ`` is an edge of its boundary). Float circumspheres: a choice among
valid split points, never a sign.

Besides the count, each point gets a *signature*: a 64-bit sum of a hash of
each piece it would leave missing (the pieces removed, the new edges' far
vertices, the new faces' base edges), so that two points leaving the same
pieces missing are told apart from two that only leave as many
(:func:`meshcore.delaunay.admissible3d`'s search tries one of each).
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

from meshcore.delaunay.hashgrid import _find_all, _table
from meshcore.delaunay.recovery3d import (
    TET_EDGES,
    TET_FACES,
    SurfaceRecovery,
    face_keys,
    member,
    packed_edge_keys,
    tet_circumcenters,
)

__all__ = ["Cavities", "opposites", "split_pieces"]


class Cavities:
    """What inserting a point would leave missing in the round's tetrahedralization
    ``T`` (the kernel's): the subfaces and subface ``edges`` all of whose
    tetrahedra have the point in their circumsphere (the insertion's cavity),
    unless on the hull (the cavity's boundary: they stay), and the new pieces at
    the point that the cavity's boundary does not give (float: a choice, not a
    sign)."""

    def __init__(
        self, b: SurfaceRecovery, slots: np.ndarray, T: np.ndarray, edges: np.ndarray
    ) -> None:
        self.T = T
        self.centres, self.radii = tet_circumcenters(b.P, T)  # flat tetrahedra: never
        # The hull's faces: those with no real tetrahedron across (the kernel's
        # neighbours of the tetrahedra in ``slots``).
        across = b.dt.adjacent(slots)
        real = np.zeros(max(int(across.max(initial=-1)), int(slots.max(initial=-1))) + 1, bool)
        real[slots] = True
        out = (across < 0) | ~real[np.maximum(across, 0)]
        hull = T[:, TET_FACES][out]
        hull_faces = np.sort(face_keys(hull))
        hull_edges = np.unique(packed_edge_keys(hull[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2)))
        # Per tetrahedron, the subface (edge) row of each of its faces (edges), -1 if
        # none; per subface (edge), its tetrahedra and whether it is on the hull.
        face_k, edge_k = face_keys(b.sub), packed_edge_keys(edges)
        self.edge_table = _table(edge_k)  # missing() looks the new faces' edges up in it
        self.pieces = []
        for corners, keys, k, table, on_hull in (
            (TET_FACES, face_keys, face_k, _table(face_k), hull_faces),
            (TET_EDGES, packed_edge_keys, edge_k, self.edge_table, hull_edges),
        ):
            at = _find_all(*table, keys(T[:, corners].reshape(-1, corners.shape[1])))
            self.pieces.append(
                (
                    at.reshape(len(T), -1),
                    np.bincount(at[at >= 0], minlength=len(k)),
                    member(k, on_hull),
                )
            )
        # Only the tetrahedra holding a piece count (the others hold none to remove).
        held = (self.pieces[0][0] >= 0).any(1) | (self.pieces[1][0] >= 0).any(1)
        self.rows = np.flatnonzero(held & np.isfinite(self.radii))

    def missing(
        self, X: np.ndarray, V: np.ndarray, base: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per point of ``X``: the subfaces and subface edges its insertion removes (all
        their tetrahedra in its cavity, not on the hull), plus its new edges to the
        vertices ``V`` (k, j; -1: none) and new faces on the subface edges ``base``
        (k, i, 2; -1: none) that the cavity's boundary does not give (an edge to a
        vertex of no cavity tetrahedron; a face on an edge not on the boundary): their
        count, and their signature (uint64, see the module docstring)."""
        tree = cKDTree(X)
        centres, radii = self.centres[self.rows], self.radii[self.rows]
        # The counts first (no list per tetrahedron), then the lists of those hit: the
        # same query twice, so the same hits (most tetrahedra hold no candidate).
        some = np.flatnonzero(tree.query_ball_point(centres, radii, return_length=True))
        hits = tree.query_ball_point(centres[some], radii[some])
        n = np.fromiter(map(len, hits), np.int64, len(hits))
        xi = np.fromiter(itertools.chain.from_iterable(hits), np.int64, int(n.sum()))
        ti = np.repeat(self.rows[some], n)
        out = np.zeros(len(X), dtype=np.int64)
        sig = np.zeros(len(X), dtype=np.uint64)
        in_cavity = []  # per kind: (point, piece) keys and their tetrahedra in the cavity
        for kind, (at, around, hull) in enumerate(self.pieces):
            piece = at[ti].reshape(-1)
            ok = piece >= 0
            key = np.repeat(xi, at.shape[1])[ok] * len(around) + piece[ok]
            uk, count = np.unique(key, return_counts=True)
            gone = (count == around[uk % len(around)]) & ~hull[uk % len(around)]
            np.add.at(out, uk[gone] // len(around), 1)
            np.add.at(sig, uk[gone] // len(around), _mix(uk[gone] % len(around), kind))
            in_cavity.append((uk, count))
        # The new edges: to the vertices of no cavity tetrahedron (per hit, which of its
        # point's V are corners of its tetrahedron: no sort of all the hits' corners).
        corners, Vx = self.T[ti], V[xi]
        at_hit = corners[:, :1] == Vx
        for c in range(1, corners.shape[1]):
            at_hit |= corners[:, c : c + 1] == Vx
        corner = np.zeros(V.shape, dtype=bool)
        h, j = np.nonzero(at_hit)
        corner[xi[h], j] = True
        new = (V >= 0) & ~corner
        out += new.sum(axis=1)
        sig += np.where(new, _mix(V, 2), np.uint64(0)).sum(axis=1, dtype=np.uint64)
        # The new faces: on the subface edges present with some but not all of their
        # tetrahedra in the cavity (or on the hull).
        want = base[:, :, 0] >= 0
        row = _find_all(*self.edge_table, packed_edge_keys(base.reshape(-1, 2))).reshape(want.shape)
        _, around, hull = self.pieces[1]
        uk, count = in_cavity[1]  # per (point, subface edge)
        m = len(around)
        c = np.zeros(row.size, dtype=np.int64)
        if uk.size:
            q = (np.arange(len(X))[:, None] * m + row).reshape(-1)
            pos = np.minimum(np.searchsorted(uk, q), len(uk) - 1)
            hit = (row.reshape(-1) >= 0) & (uk[pos] == q)
            c[hit] = count[pos[hit]]
        c = c.reshape(want.shape)
        r = np.maximum(row, 0)
        kept = (row >= 0) & (c > 0) & ((c < around[r]) | hull[r])
        new = want & ~kept
        out += new.sum(axis=1)
        on = packed_edge_keys(base.reshape(-1, 2)).reshape(want.shape)
        sig += np.where(new, _mix(on, 3), np.uint64(0)).sum(axis=1, dtype=np.uint64)
        return out, sig


def _mix(x: np.ndarray, kind: int) -> np.ndarray:
    """A 64-bit hash of the pieces ``x`` (non-negative ints, -1 ignored by the
    callers) of one ``kind`` (splitmix64's finalizer; sums of these are the
    signatures)."""
    z = (np.asarray(x).astype(np.uint64) * np.uint64(4) + np.uint64(kind)) * np.uint64(
        0x9E3779B97F4A7C15
    )
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def split_pieces(sub: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For subface edges ``E`` (``AB``, each in two subfaces ``ABC``, ``BAD``): the
    vertices a split point gets edges to (``A, B, C, D``) and the edges its new
    subfaces stand on (``AC, BC, AD, BD``), as :meth:`Cavities.missing` takes them."""
    C, D, _ = opposites(sub, E)
    A, B = E[:, 0], E[:, 1]
    V = np.stack([A, B, C, D], axis=1)
    base = np.stack(
        [np.stack([A, C], 1), np.stack([B, C], 1), np.stack([A, D], 1), np.stack([B, D], 1)], axis=1
    )
    return V, base


def opposites(sub: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For edges ``E``: the third vertices of the first two subfaces ``sub`` holding
    each (``C`` and ``D``, in row order; meaningful where it has them) and how many
    subfaces hold it."""
    k = packed_edge_keys(np.concatenate([sub[:, [0, 1]], sub[:, [1, 2]], sub[:, [2, 0]]]))
    opposite = np.concatenate([sub[:, 2], sub[:, 0], sub[:, 1]])
    order = np.argsort(k, kind="stable")
    ks = k[order]
    key = packed_edge_keys(E)
    lo = np.searchsorted(ks, key)
    held = np.searchsorted(ks, key + 1) - lo
    C = opposite[order[np.minimum(lo, len(k) - 1)]]
    D = opposite[order[np.minimum(lo + 1, len(k) - 1)]]
    return C, D, held
