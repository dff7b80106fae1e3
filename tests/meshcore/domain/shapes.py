"""Closed surfaces for the 3D tests: boxes, spheres, tori, prisms, star-shaped polyhedra.

Each builder returns ``(points (n, 3) float64, triangles (m, 3) int64)`` with
triangles oriented outward (right-hand normals leaving the solid), and the
exact enclosed volume where it is simple (boxes, prisms).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull


def _outward(points: np.ndarray, tri: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Turn each triangle so its normal points away from ``inside`` (per triangle)."""
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    nrm = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", nrm, a - inside) < 0
    out = tri.copy()
    out[flip, 1], out[flip, 2] = tri[flip, 2], tri[flip, 1]
    return out


def box(lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0), n: int = 1):
    """A box, each face an n x n grid of squares split into two triangles.

    ::

        z
        |  6-------7
        | /|      /|      corners i = x + 2 y + 4 z of the unit cube
        4-------5  |
        |  2----|--3
        | /     | /
        0-------1 --x
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    t = np.linspace(0.0, 1.0, n + 1)
    pts, tris = [], []
    base = 0
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0.0, 1.0):
            g = np.zeros(((n + 1) ** 2, 3))
            uu, vv = np.meshgrid(t, t, indexing="ij")
            g[:, u] = uu.ravel()
            g[:, v] = vv.ravel()
            g[:, axis] = side
            idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
            q0 = idx[:-1, :-1].ravel()
            q1 = idx[1:, :-1].ravel()
            q2 = idx[1:, 1:].ravel()
            q3 = idx[:-1, 1:].ravel()
            tri = np.concatenate([np.stack([q0, q1, q2], 1), np.stack([q0, q2, q3], 1)])
            if side == 0.0:
                tri = tri[:, [0, 2, 1]]
            pts.append(g)
            tris.append(tri + base)
            base += len(g)
    P = np.concatenate(pts)
    T = np.concatenate(tris)
    # Merge the points shared by faces.
    key = np.round(P * (4 * n)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    P = P[first]
    T = inv.reshape(-1)[T]
    return lo + P * (hi - lo), T


def box_volume(lo, hi) -> float:
    return float(np.prod(np.asarray(hi, float) - np.asarray(lo, float)))


def icosphere(level: int = 1, radius: float = 1.0):
    """A unit icosahedron subdivided ``level`` times, projected on the sphere."""
    g = (1 + 5**0.5) / 2
    P = np.array(
        [[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
         [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]],
        dtype=float,
    )  # fmt: skip
    P /= np.linalg.norm(P, axis=1)[:, None]
    T = ConvexHull(P).simplices
    for _ in range(level):
        e = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
        e.sort(axis=1)
        ue, inv = np.unique(e, axis=0, return_inverse=True)
        inv = inv.reshape(3, -1)
        mid = P[ue[:, 0]] + P[ue[:, 1]]
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        m = len(P) + inv
        P = np.concatenate([P, mid])
        a, b, c = T[:, 0], T[:, 1], T[:, 2]
        T = np.concatenate(
            [np.stack(x, 1) for x in ((a, m[0], m[2]), (b, m[1], m[0]), (c, m[2], m[1]), tuple(m))]
        )
    T = _outward(P, T, np.zeros(3))
    return P * radius, T


def torus(R: float = 2.0, r: float = 0.7, nu: int = 16, nv: int = 8):
    """A torus around z: nu segments around the axis, nv around the tube."""
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing="ij")
    P = np.stack(
        [
            (R + r * np.cos(vv)) * np.cos(uu),
            (R + r * np.cos(vv)) * np.sin(uu),
            r * np.sin(vv),
        ],
        -1,
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * nv + j).ravel()
    b = (((i + 1) % nu) * nv + j).ravel()
    c = (((i + 1) % nu) * nv + (j + 1) % nv).ravel()
    d = (i * nv + (j + 1) % nv).ravel()
    T = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    centre = np.stack([R * np.cos(u), R * np.sin(u), 0 * u], 1)[np.repeat(i.ravel(), 1)]
    T = _outward(P, T, np.concatenate([centre, centre]))
    return P, T


def prism(polygon, cap_triangles, height: float = 1.0):
    """A polygon (k, 2) counter-clockwise, extruded along z, caps triangulated as given."""
    poly = np.asarray(polygon, dtype=float)
    k = len(poly)
    P = np.concatenate(
        [np.column_stack([poly, np.zeros(k)]), np.column_stack([poly, np.full(k, height)])]
    )
    cap = np.asarray(cap_triangles, dtype=np.int64)
    i = np.arange(k)
    j = (i + 1) % k
    sides = np.concatenate([np.stack([i, j, j + k], 1), np.stack([i, j + k, i + k], 1)])
    T = np.concatenate([cap[:, [0, 2, 1]], cap + k, sides])
    return P, T


def prism_volume(polygon, height: float = 1.0) -> float:
    x, y = np.asarray(polygon, float).T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) * height


L_POLYGON = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
L_CAPS = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]


def l_block():
    return prism(L_POLYGON, L_CAPS)


def schonhardt(twist_degrees: float = 30.0):
    """Schönhardt's twisted triangular prism: no tetrahedralization without Steiner points.

    Each side quad is split by its reflex diagonal (the one the twist folds
    inward), so every tetrahedron on the six vertices pokes out of it.
    """
    th = 2 * np.pi * np.arange(3) / 3
    tw = np.radians(twist_degrees)
    P = np.concatenate(
        [
            np.stack([np.cos(th), np.sin(th), np.zeros(3)], 1),
            np.stack([np.cos(th + tw), np.sin(th + tw), np.ones(3)], 1),
        ]
    )
    tris = [[0, 2, 1], [3, 4, 5]]
    centre = np.array([0.0, 0.0, 0.5])
    for k in range(3):
        b0, b1, t0, t1 = k, (k + 1) % 3, 3 + k, 3 + (k + 1) % 3
        for d in ((b0, t1), (b1, t0)):
            if d == (b0, t1):
                pair = [[b0, b1, t1], [b0, t1, t0]]
            else:
                pair = [[b0, b1, t0], [b1, t1, t0]]
            # Reflex diagonal: the far corner of the second triangle lies outside the
            # first triangle's plane (seen from the axis).
            a, b, c = P[pair[0]]
            nrm = np.cross(b - a, c - a)
            if np.dot(nrm, a - centre) < 0:
                nrm = -nrm
            other = [x for x in pair[1] if x not in pair[0]][0]
            if np.dot(nrm, P[other] - a) > 0:
                tris.extend(pair)
                break
    T = _outward(P, np.array(tris, dtype=np.int64), np.tile(centre, (len(tris), 1)))
    return P, T


def star(radii: np.ndarray, directions: np.ndarray):
    """A star-shaped polyhedron: the convex hull triangulation of unit directions, scaled."""
    d = directions / np.linalg.norm(directions, axis=1)[:, None]
    T = ConvexHull(d).simplices
    T = _outward(d, T, np.zeros(3))
    return d * np.asarray(radii)[:, None], T
