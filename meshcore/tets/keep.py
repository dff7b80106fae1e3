"""``keep_boundary`` for any closed surface: the surface Steiner points lifted inside.

Conforming recovery (:func:`meshcore.delaunay.recovery3d.recover`) puts its
Steiner points on the surface: on input edges and inside input triangles.
:func:`lift_surface_points` then moves each of them, one at a time, off the
surface into the region it bounds, and fills the thin gap it leaves with
tetrahedra, so that at the end the boundary faces are exactly the input
triangles and every added point is interior (TetGen's ``-Y`` goal, reached by
another road: TetGen recovers the faces with interior points directly).

One point ``p`` (§9.3.5's points on the surface, undone):

1. Its *surface star*: the boundary faces at ``p``, grouped by the input
   triangle they lie in (one group for a point inside a triangle, two for a
   point on an edge). In each group the faces' far edges chain into a path
   around ``p`` (a cycle inside a triangle); with ``p`` gone, the path closed
   by the straight step through ``p`` is a polygon in the triangle's plane,
   triangulated by ear clipping (in the plane's frame, float; an ear is
   strictly convex and holds no other vertex of the polygon).
2. ``p`` moves to ``p' = p + t (c - p)``, ``c`` the mean centroid of its
   tetrahedra, or as far along the triangles' inner normals (their sum:
   beyond a reflex edge the centroid can lie outside the wedge where both
   triangles' cones are positive), ``t`` = 1/2, 1/4, ... until every tetrahedron at ``p`` and
   every *cone* tetrahedron (a polygon triangle and ``p'``) is positively
   oriented by the exact :func:`~meshcore.geometry.predicates3d.orient3d`.
   The cones fill exactly the gap between the polygons and the faces at
   ``p'`` (their faces through ``p'`` are the old boundary faces, the
   diagonals' faces, shared by two cones, and, on an edge, the face through
   the closing step, shared by the two triangles' cones); the polygon
   triangles become the boundary faces. Once every point of a triangle is
   gone, its polygon triangulation is the triangle itself.

Every sign that decides validity is exact; only the triangulation of a
polygon and the trial points are float constructions, and a trial that a
rounding error spoils is caught by the exact check (the next, smaller ``t``
is tried; after 60 halvings the surface is refused).

References
----------
Methods text §9.3.5 (new points on the surface), §9.5 (the empty
tetrahedralization); H. Si, "TetGen" (ACM TOMS 2015), ``-Y``.
"""

from __future__ import annotations

import numpy as np

from meshcore.errors import AlgorithmError
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh.topology import edge_keys

__all__ = ["lift_surface_points"]

#: Halvings of the step toward the centroid before a point is given up.
_HALVINGS = 60


def _cross2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _ear_clip(uv: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles (indices into ``uv``) of a simple counter-clockwise polygon.

    At each step the ear of largest least angle among the strictly convex
    corners whose triangle holds no other polygon vertex (closed test, up to
    a relative tolerance); float, checked downstream by exact signs.
    """
    idx = list(range(len(uv)))
    out = []
    scale = float(np.ptp(uv, axis=0).max()) if len(uv) else 1.0
    tol = 1e-12 * scale * scale
    while len(idx) > 3:
        best, best_q = -1, -1.0
        k = len(idx)
        for i in range(k):  # a loop over the polygon's corners (small)
            a, b, c = uv[idx[i - 1]], uv[idx[i]], uv[idx[(i + 1) % k]]
            if _cross2(a, b, c) <= tol:
                continue
            inside = False
            for j in idx:
                if j in (idx[i - 1], idx[i], idx[(i + 1) % k]):
                    continue
                x = uv[j]
                if (
                    _cross2(a, b, x) >= -tol
                    and _cross2(b, c, x) >= -tol
                    and _cross2(c, a, x) >= -tol
                ):
                    inside = True
                    break
            if inside:
                continue
            q = _least_angle(a, b, c)
            if q > best_q:
                best, best_q = i, q
        if best < 0:
            raise AlgorithmError(
                "keep_boundary: a hole left by a surface point could not be triangulated",
                code="recovery_failed",
            )
        out.append((idx[best - 1], idx[best], idx[(best + 1) % len(idx)]))
        del idx[best]
    if _cross2(uv[idx[0]], uv[idx[1]], uv[idx[2]]) <= tol:
        raise AlgorithmError(
            "keep_boundary: a hole left by a surface point is flat", code="recovery_failed"
        )
    out.append((idx[0], idx[1], idx[2]))
    return out


def _least_angle(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Least corner angle (radians) of a 2D triangle."""
    out = np.pi
    for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
        u, v = q - p, r - p
        cos = float(u @ v) / max(float(np.linalg.norm(u) * np.linalg.norm(v)), 1e-300)
        out = min(out, float(np.arccos(np.clip(cos, -1.0, 1.0))))
    return out


def _chain(faces: np.ndarray, p: int) -> list[int]:
    """The far edges of the faces at ``p`` (outward), chained: the path around ``p``."""
    nxt: dict[int, int] = {}
    heads = set()
    for f in faces.tolist():  # a loop over the faces at p (a few)
        k = f.index(p)
        u, v = f[(k + 1) % 3], f[(k + 2) % 3]
        nxt[u] = v
        heads.add(v)
    starts = [u for u in nxt if u not in heads]
    if len(starts) > 1:
        raise AlgorithmError(
            "keep_boundary: a surface point's faces in one triangle are not one fan",
            code="recovery_failed",
        )
    u = starts[0] if starts else next(iter(nxt))
    path = [u]
    while u in nxt and len(path) <= len(faces):
        u = nxt[u]
        if u == path[0]:
            break
        path.append(u)
    if len(path) != len(faces) + (1 if starts else 0):
        raise AlgorithmError(
            "keep_boundary: a surface point's faces in one triangle are not one fan",
            code="recovery_failed",
        )
    return path


def lift_surface_points(
    P: np.ndarray,
    tetra: np.ndarray,
    region: np.ndarray,
    faces: np.ndarray,
    face_triangle: np.ndarray,
    triangles: np.ndarray,
    points: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Move the surface Steiner points ``points`` inside; the boundary becomes ``triangles``.

    Parameters
    ----------
    P : (n, 3) float64
        Coordinates (a copy is returned with the moved points).
    tetra : (m, 4) int64
        Positively oriented tetrahedra (``orient3d > 0`` in Shewchuk's sign),
        filling the regions; ``region`` their region.
    faces, face_triangle : (k, 3) int64, (k,) int64
        The boundary faces, outward, and the input triangle each lies in.
    triangles : (t, 3) int64
        The input triangles, outward (each a facet: no coplanar merging).
    points : (s,) int64
        The Steiner points on the surface, lifted in the given order.

    Returns
    -------
    (P, tetra, region)
        Whose boundary faces are exactly ``triangles``. Raises
        ``AlgorithmError`` (``recovery_failed``) where a point cannot be
        lifted (no step toward its tetrahedra's centroid keeps them positive).

    References
    ----------
    Methods text §9.3.5, §9.5 (see the module docstring).
    """
    P = np.array(P, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    pts = np.asarray(points, dtype=np.int64)
    T = _Rows(np.asarray(tetra, dtype=np.int64), np.asarray(region, dtype=np.int64), pts, len(P))
    F = _Rows(
        np.asarray(faces, dtype=np.int64), np.asarray(face_triangle, dtype=np.int64), pts, len(P)
    )
    for p in pts.tolist():  # one point at a time
        at = T.at(p)
        mine = F.at(p)
        if at.size == 0 or mine.size == 0:
            continue
        cones = []
        inward = np.zeros(3)
        ftri = F.tag[mine]
        for t in np.unique(ftri).tolist():  # one or two input triangles
            group = F.rows[mine[ftri == t]]
            path = _chain(group, p)
            a, b, c = P[tri[t]]
            e1 = (b - a) / np.linalg.norm(b - a)
            n = np.cross(b - a, c - a)
            n = n / np.linalg.norm(n)
            inward -= n
            e2 = np.cross(n, e1)
            uv = np.stack([(P[path] - a) @ e1, (P[path] - a) @ e2], 1)
            for i, j, k in _ear_clip(uv):
                cones.append((path[i], path[j], path[k], t))
        cone = np.array(cones, dtype=np.int64)
        old = T.rows[at]
        centre = P[old].mean(axis=1).mean(axis=0)
        x0 = P[p].copy()
        toward = centre - x0
        # Toward the centroid, else along the triangles' inner normal (bisector):
        # the cones need p' strictly inside every polygon triangle's plane, which
        # a centroid beyond a reflex edge's wedge never gives.
        dirs = (toward, inward * (np.linalg.norm(toward) / max(np.linalg.norm(inward), 1e-300)))
        Q = np.where(old == p, -1, old)
        step = 0.5
        ok = False
        for _ in range(_HALVINGS):  # halving the step until every sign is positive
            for d in dirs:
                x = x0 + step * d
                corners = [np.where(Q[:, [k]] < 0, x, P[np.maximum(Q[:, k], 0)]) for k in range(4)]
                ok = (orient3d(*corners) > 0).all()
                if ok:
                    xs = np.broadcast_to(x, (len(cone), 3))
                    ok = (orient3d(P[cone[:, 0]], P[cone[:, 1]], P[cone[:, 2]], xs) > 0).all()
                if ok:
                    break
            if ok:
                break
            step *= 0.5
        if not ok:
            raise AlgorithmError(
                f"keep_boundary: the surface point {p} could not be moved inside "
                "keeping its tetrahedra positive",
                code="recovery_failed",
            )
        P[p] = x
        T.add(np.column_stack([cone[:, :3], np.full(len(cone), p)]), int(T.tag[at[0]]))
        F.drop(mine)
        F.add(cone[:, :3], cone[:, 3])
    tetra, region = T.live()
    return P, tetra, region


class _Rows:
    """A growing set of rows (tetrahedra or faces) with a tag each, and the rows at each point.

    Only the points to lift are indexed (``at``): their rows at the start,
    and every row added later that holds one.
    """

    def __init__(self, rows: np.ndarray, tag: np.ndarray, points: np.ndarray, n: int) -> None:
        self.rows = rows.copy()
        self.tag = np.asarray(tag, dtype=np.int64).copy()
        self.alive = np.ones(len(rows), dtype=bool)
        self.m = len(rows)
        self.watch = np.zeros(n, dtype=bool)
        self.watch[points] = True
        r, c = np.nonzero(self.watch[rows])
        v = rows[r, c]
        order = np.argsort(v, kind="stable")
        v, r = v[order], r[order]
        cut = np.flatnonzero(np.diff(v)) + 1
        self.index: dict[int, list[int]] = {
            int(k[0]): g.tolist() for k, g in zip(np.split(v, cut), np.split(r, cut), strict=True)
            if len(k)
        }  # fmt: skip

    def at(self, p: int) -> np.ndarray:
        rows = np.asarray(self.index.get(p, []), dtype=np.int64)
        return rows[self.alive[rows]]

    def add(self, rows: np.ndarray, tag) -> None:
        k = len(rows)
        if self.m + k > len(self.rows):
            grow = max(self.m + k, 2 * len(self.rows)) - len(self.rows)
            self.rows = np.concatenate([self.rows, np.zeros((grow, rows.shape[1]), np.int64)])
            self.tag = np.concatenate([self.tag, np.zeros(grow, np.int64)])
            self.alive = np.concatenate([self.alive, np.zeros(grow, dtype=bool)])
        new = np.arange(self.m, self.m + k)
        self.rows[new] = rows
        self.tag[new] = tag
        self.alive[new] = True
        self.m += k
        for i, row in zip(new.tolist(), rows.tolist(), strict=True):  # a few rows
            for v in row:
                if self.watch[v]:
                    self.index.setdefault(v, []).append(i)

    def drop(self, rows: np.ndarray) -> None:
        self.alive[rows] = False

    def live(self) -> tuple[np.ndarray, np.ndarray]:
        keep = np.flatnonzero(self.alive[: self.m])
        return self.rows[keep], self.tag[keep]


def flip_slivers(
    P: np.ndarray, tetra: np.ndarray, region: np.ndarray, bound: float, passes: int = 5
) -> tuple[np.ndarray, np.ndarray, int]:
    """3-2 flips that raise the least dihedral angle of tetrahedra below ``bound`` degrees.

    For a tetrahedron below the bound, each of its edges held by exactly
    three tetrahedra in a closed ring (an inner edge: its three faces through
    the edge each shared by two of them) is a candidate: the three are
    replaced by the two on the ring's triangle and the edge's ends, when both
    are positively oriented by the exact ``orient3d`` and their least
    dihedral angle beats that of the three. The union, hence every boundary
    face, is unchanged (the six outer faces of the three are the faces of
    the two). The flat tetrahedra a kept boundary leaves on two input
    triangles coplanar up to rounding (a torus's trapezoids) go this way.
    Passes over disjoint flips until none applies, at most ``passes`` (the
    first pass makes 80 % of the flips on the torus). Returns (tetra,
    region, flips made).

    References
    ----------
    Methods text §9.5 (improving the tetrahedralization of the surface
    points); the 3-2 flip of Joe's and Shewchuk's tetrahedral flips.
    """
    from meshcore.tets.refinement import tetra_dihedral_angles

    T = np.asarray(tetra, dtype=np.int64).copy()
    R = np.asarray(region, dtype=np.int64).copy()
    total = 0
    pairs = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
    for _ in range(passes):  # passes of disjoint flips
        dih = tetra_dihedral_angles(P, T).min(axis=1)
        bad = np.flatnonzero(dih < bound)
        if bad.size == 0:
            break
        key = edge_keys(T[:, pairs[:, 0]], T[:, pairs[:, 1]], len(P)).reshape(-1)
        order = np.argsort(key, kind="stable")
        ks = key[order]
        start = np.searchsorted(ks, key)
        three = (np.searchsorted(ks, key + 1) - start == 3).reshape(-1, 6)
        bad = bad[three[bad].any(axis=1)]
        used = np.zeros(len(T), dtype=bool)
        gone, new_t, new_r = [], [], []
        for t in bad[np.argsort(dih[bad], kind="stable")].tolist():  # worst first
            if used[t]:
                continue
            for e in np.flatnonzero(three[t]).tolist():  # its edges in three tetrahedra
                i0 = start[6 * t + e]
                ring = order[i0 : i0 + 3] // 6
                if used[ring].any():
                    continue
                u, v = sorted(T[t, pairs[e]].tolist())  # the edge, lo first
                others = [[x for x in T[r].tolist() if x not in (u, v)] for r in ring.tolist()]
                verts = sorted({x for o in others for x in o})
                # A closed ring: three vertices, each in exactly two of the three tetrahedra.
                if len(verts) != 3 or any(sum(x in o for o in others) != 2 for x in verts):
                    continue
                a, b, c = verts
                A = P[[a, a]]
                B = P[[b, b]]
                C = P[[c, c]]
                D = P[[u, v]]
                s = orient3d(A, B, C, D)
                if not (s[0] * s[1] < 0):
                    continue
                cand = np.array([[a, b, c, u], [a, b, c, v]])
                cand[s < 0] = cand[s < 0][:, [1, 0, 2, 3]]
                chk = orient3d(P[cand[:, 0]], P[cand[:, 1]], P[cand[:, 2]], P[cand[:, 3]])
                if not (chk > 0).all():
                    continue
                if tetra_dihedral_angles(P, cand).min() <= dih[ring].min():
                    continue
                used[ring] = True
                gone.extend(ring.tolist())
                new_t.append(cand)
                new_r.append(np.full(2, R[ring[0]]))
                break
        if not new_t:
            break
        keep = np.ones(len(T), dtype=bool)
        keep[gone] = False
        T = np.concatenate([T[keep], *new_t])
        R = np.concatenate([R[keep], *new_r])
        total += len(new_t)
    return T, R, total
