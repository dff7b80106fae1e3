"""Other Delaunay tetrahedralizations of exactly co-spherical points (methods text
Remark 9.6), for :mod:`meshcore.delaunay.admissible3d`: a missing subface edge that
is the diagonal of a planar co-circular quadrilateral is given its cells' other
Delaunay tetrahedralization (cones on the cells' empty spheres) instead of a point.
"""

from __future__ import annotations

import numpy as np

from meshcore.delaunay.cavities3d import opposites
from meshcore.delaunay.recovery3d import (
    TET_FACES,
    SurfaceRecovery,
    face_keys,
    member,
)
from meshcore.geometry.predicates3d import insphere_scalar, orient3d, orient3d_scalar

__all__ = ["Reflipped", "TieFlips", "flip_ties"]


class TieFlips:
    """Other Delaunay tetrahedralizations of co-spherical points (Remark 9.6).

    Where points are exactly co-spherical the Delaunay tetrahedralization is
    not unique (the text: ``AB`` is Delaunay when the Voronoï cells of ``A``
    and ``B`` share a vertex, "the solution may be obtained after a swap"),
    and the kernel's symbolic perturbation picks one of them. A missing
    subface edge ``AC`` whose two subfaces ``ACB`` and ``CAD`` form a planar
    convex quadrilateral ``ABCD`` (exact ``orient3d``) is *noted*. If ``BD``
    is present, the tetrahedra on ``ABD`` and ``BCD`` must lie in at most two
    *cells* (one per side; a cell: the tetrahedra joined across faces whose
    far corner lies exactly on their circumsphere, exact ``insphere == 0``, a
    convex polytope inscribed in an empty sphere), each holding ``A, B, C,
    D`` (so the quadrilateral is co-circular). Each cell is re-tetrahedralized
    as a cone from one of its vertices (the first, in index order, that
    works) over its boundary with ``ABD, BCD`` replaced by ``ABC, ACD`` (and
    so for every other noted quadrilateral on the cell's hull faces): the
    cone must have exactly that boundary and keep every subface inside the
    cell, so the neighbours still match. When no cone of a cell works, one
    more quadrilateral of its boundary (two coplanar triangles, so
    co-circular, neither a subface) shared with one neighbour cell may be
    turned too, that cell re-tetrahedralized the same way, and so on
    :data:`DEPTH` levels (a triangular prism along a box's edge: two sides
    on the surface, the third shared).
    Every new tetrahedron lies on its cell's empty sphere: the
    tetrahedralization stays Delaunay, exactly, and nothing is added.
    Quadrilaterals that need more (a cell triangulated other than as a cone,
    more neighbours) stay missing and are split.
    """

    #: Cells of more tetrahedra than this are left alone.
    MAX_CELL = 64
    #: Levels of neighbour cells turned with a cell no cone fits (see :meth:`_fit`).
    DEPTH = 4

    def __init__(self, P: np.ndarray, T: np.ndarray, sub: np.ndarray) -> None:
        self.P = P
        self.T = T
        self.kernel_rows = len(T)  # rows from here on are the cones'
        self.order = self.keys = None  # the faces of T, sorted when first needed
        self.added: dict[tuple[int, ...], list[int]] = {}  # faces of the rows added
        self.sub_keys = np.sort(face_keys(sub))
        self.dead: set[int] = set()
        #: The noted quadrilaterals: each of their present triangles (sorted
        #: corners) -> (both present triangles, both wanted ones).
        self.wanted: dict[tuple[int, ...], tuple] = {}
        #: Cells re-tetrahedralized.
        self.cones = 0

    def holding(self, face) -> list[int]:
        """Rows of the live tetrahedra holding ``face``."""
        if self.keys is None:
            keys = face_keys(self.T[:, TET_FACES].reshape(-1, 3))
            self.order = np.argsort(keys, kind="stable")
            self.keys = keys[self.order]
        key = face_keys(np.array([face], dtype=np.int64))[0]
        lo, hi = np.searchsorted(self.keys, [key, key + 1])
        rows = [int(r) // 4 for r in self.order[lo:hi]]
        rows += self.added.get(tuple(sorted(int(v) for v in face)), [])
        return [r for r in rows if r not in self.dead]

    def cell(self, start: int) -> list[int] | None:
        """The rows of the cell of tetrahedron ``start`` (None if too large)."""
        P, T = self.P, self.T
        seen = [start]
        k = 0
        while k < len(seen):
            r = seen[k]
            k += 1
            q = P[T[r]].ravel().tolist()
            for f in TET_FACES:
                face = T[r][f].tolist()
                for o in self.holding(face):
                    if o in seen:
                        continue
                    x = (set(T[o].tolist()) - set(face)).pop()
                    if insphere_scalar(*q, *P[x].tolist()) == 0:
                        seen.append(o)
                        if len(seen) > self.MAX_CELL:
                            return None
        return seen

    def quad(self, a: int, b: int, c: int, d: int) -> bool:
        """Note the planar quadrilateral ``ABCD`` (subfaces ``ACB``, ``CAD``) as
        one whose diagonal ``AC`` is wanted, if it is convex (exact)."""
        q = self.P[[a, b, c, d]]
        # B and D on either side of AC (seen from a point off the plane, the normal's tip)
        tip = (q[0] + np.cross(q[2] - q[0], q[1] - q[0])).tolist()
        a_, b_, c_, d_ = q.tolist()
        if orient3d_scalar(*a_, *c_, *tip, *b_) * orient3d_scalar(*a_, *c_, *tip, *d_) >= 0:
            return False
        pair = (tuple(sorted((a, b, d))), tuple(sorted((b, c, d))))
        want = (tuple(sorted((a, b, c))), tuple(sorted((a, c, d))))
        self.wanted[pair[0]] = self.wanted[pair[1]] = (pair, want)
        return True

    def flip(self, a: int, b: int, c: int, d: int) -> bool:
        """Make ``AC`` present in place of ``BD`` (a noted quadrilateral ``ABCD``)
        if its cells allow it (see the class)."""
        if self.holding([a, b, c]) and self.holding([a, c, d]):
            return True  # made present by an earlier cone
        cells: list[list[int]] = []
        for r in self.holding([a, b, d]) + self.holding([b, c, d]):
            if any(r in cl for cl in cells):
                continue
            cl = self.cell(r)
            if cl is None or not {a, b, c, d} <= set(self.T[cl].ravel().tolist()):
                return False
            cells.append(cl)
        if not cells or len(cells) > 2:
            return False
        plan = []
        own = self.wanted[tuple(sorted((a, b, d)))]
        union = {r for cl in cells for r in cl}
        got: set[tuple[int, ...]] = set()
        for cl in cells:
            part = self._fit(cl, dict([own]), union, self.DEPTH)
            if part is None:
                return False
            for cell, cone in part:
                union |= set(cell)
                plan.append((cell, cone))
                got |= {tuple(f) for f in np.sort(cone[:, TET_FACES].reshape(-1, 3), 1).tolist()}
        if not {tuple(sorted((a, b, c))), tuple(sorted((a, c, d)))} <= got:
            return False
        for cl, cone in plan:
            new = list(range(len(self.T), len(self.T) + len(cone)))
            self.T = np.concatenate([self.T, cone])
            for r, tet in zip(new, cone.tolist(), strict=True):
                for f in TET_FACES.tolist():
                    self.added.setdefault(tuple(sorted(tet[k] for k in f)), []).append(r)
            self.dead.update(cl)
            self.cones += 1
        return True

    def _fit(self, cl: list[int], turns: dict, union: set[int], depth: int):
        """Cones for cell ``cl`` with ``turns`` and, when none fits, with one more
        boundary quadrilateral turned, shared with a neighbour cell fitted the same
        way (``depth`` levels): [(cell, cone), ...], or None."""
        cone = self._cone(cl, turns)
        if cone is not None:
            return [(cl, cone)]
        if depth == 0:
            return None
        for pair, want, nb in self._shared_quads(cl, union):
            wider = union | set(nb)
            mine = self._fit(cl, {**turns, pair: want}, wider, depth - 1)
            if mine is None:
                continue
            wider |= {r for c, _ in mine for r in c}
            theirs = self._fit(nb, {pair: want}, wider, depth - 1)
            if theirs is not None:
                return mine + theirs
        return None

    def _shared_quads(self, cl: list[int], union: set[int]):
        """The cell's boundary quadrilaterals (two coplanar triangles, no subface,
        so co-circular) whose other side is one cell outside ``union``: (their
        triangles, the other diagonal's, that cell), in order."""
        faces = np.sort(self.T[cl][:, TET_FACES].reshape(-1, 3), axis=1)
        uniq, count = np.unique(faces, axis=0, return_counts=True)
        out = uniq[count == 1]
        out = out[~member(face_keys(out), self.sub_keys)]
        found = []
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                e = set(out[i].tolist()) & set(out[j].tolist())
                if len(e) != 2:
                    continue
                y, w = ((set(out[k].tolist()) - e).pop() for k in (i, j))
                x, z = sorted(e)
                if orient3d_scalar(*self.P[[x, z, y, w]].ravel().tolist()) != 0:
                    continue
                t1, t2 = tuple(out[i].tolist()), tuple(out[j].tolist())
                h = [r for r in self.holding(list(t1)) + self.holding(list(t2)) if r not in cl]
                if len(h) != 2 or h[0] in union or h[1] in union:
                    continue
                nb = self.cell(h[0])
                if nb is None or h[1] not in nb or union & set(nb):
                    continue
                want = (tuple(sorted((x, y, w))), tuple(sorted((z, y, w))))
                found.append(((t1, t2), want, nb))
        return found

    def _cone(self, cl: list[int], turns: dict) -> np.ndarray | None:
        """The cone re-tetrahedralization of cell ``cl`` whose boundary is the
        cell's with the quadrilaterals ``turns`` (present triangles -> wanted
        ones) turned, and every noted one whose tetrahedra are all in the cell
        (on the hull), and which keeps the subfaces inside the cell (see the
        class), or None."""
        P, T = self.P, self.T
        faces = np.sort(T[cl][:, TET_FACES].reshape(-1, 3), axis=1)
        uniq, count = np.unique(faces, axis=0, return_counts=True)
        boundary = {tuple(f) for f in uniq[count == 1].tolist()}
        inner = uniq[count > 1]
        held = {tuple(f) for f in inner[member(face_keys(inner), self.sub_keys)].tolist()}
        mine = set(cl)
        for pair, want in turns.items():
            if pair[0] in boundary and pair[1] in boundary:
                boundary -= set(pair)
                boundary |= set(want)
        for f in list(boundary):
            if f in self.wanted and f in boundary:
                pair, want = self.wanted[f]
                if (
                    pair[0] in boundary
                    and pair[1] in boundary
                    and mine.issuperset(self.holding(pair[0]) + self.holding(pair[1]))
                ):  # another noted quadrilateral, on the hull
                    boundary -= set(pair)
                    boundary |= set(want)
        W = np.array(sorted(boundary), dtype=np.int64)
        for v in sorted(set(T[cl].ravel().tolist())):
            s = orient3d(P[W[:, 0]], P[W[:, 1]], P[W[:, 2]], np.broadcast_to(P[v], (len(W), 3)))
            cone = np.column_stack([np.full(int((s != 0).sum()), v), W[s != 0]])
            neg = orient3d(*(P[cone[:, k]] for k in range(4))) < 0
            cone[neg, 0], cone[neg, 1] = cone[neg, 1], v
            f, n = np.unique(
                np.sort(cone[:, TET_FACES].reshape(-1, 3), 1), axis=0, return_counts=True
            )
            inside = {tuple(x) for x in f[n == 2].tolist()}
            if {tuple(x) for x in f[n == 1].tolist()} == boundary and held <= inside:
                return cone
        return None

    def _live(self) -> np.ndarray:
        keep = np.ones(len(self.T), dtype=bool)
        keep[list(self.dead)] = False
        return keep

    def tets(self) -> np.ndarray:
        """The live tetrahedra."""
        return self.T[self._live()]

    def cone_rows(self) -> np.ndarray:
        """The rows of :meth:`tets` made by the cones (increasing)."""
        return np.flatnonzero(np.flatnonzero(self._live()) >= self.kernel_rows)


class Reflipped:
    """The builder seen through a tetrahedralization changed by :class:`TieFlips`:
    its kernel's ``adjacent`` answers for the rows of ``T`` (slots are rows), so
    :func:`~meshcore.delaunay.recovery3d.regions` labels the flipped tetrahedra."""

    def __init__(self, b: SurfaceRecovery, T: np.ndarray) -> None:
        self._b = b
        keys = face_keys(T[:, TET_FACES].reshape(-1, 3))
        order = np.argsort(keys, kind="stable")
        pair = np.flatnonzero(keys[order][1:] == keys[order][:-1])
        adj = np.full(4 * len(T), -1, dtype=np.int64)
        adj[order[pair]] = order[pair + 1] // 4
        adj[order[pair + 1]] = order[pair] // 4
        self._adj = adj.reshape(-1, 4)

    @property
    def dt(self):
        return self

    def adjacent(self, slots: np.ndarray) -> np.ndarray:
        return self._adj[slots]

    def __getattr__(self, name: str):
        return getattr(self._b, name)


def flip_ties(P: np.ndarray, T: np.ndarray, sub: np.ndarray, E: np.ndarray) -> TieFlips:
    """Try :class:`TieFlips` on the missing subface edges ``E`` that are diagonals of
    planar quadrilaterals of two subfaces ``sub`` (a loop over those only), in the
    tetrahedralization ``T`` of points ``P``."""
    flips = TieFlips(P, T, sub)
    C, D, held = opposites(sub, E)
    two = np.flatnonzero(held == 2)
    if two.size == 0:
        return flips
    a, c = E[two].min(axis=1), E[two].max(axis=1)
    b, d = C[two], D[two]
    flat = np.flatnonzero(orient3d(P[a], P[b], P[c], P[d]) == 0)
    quads = [
        q for q in zip(*(x[flat].tolist() for x in (a, b, c, d)), strict=True) if flips.quad(*q)
    ]
    for q in quads:
        flips.flip(*q)
    return flips
