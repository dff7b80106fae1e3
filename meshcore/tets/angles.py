"""Small input angles: protecting balls at sharp vertices, and tetrahedra the input keeps skinny.

Delaunay refinement with a radius-edge bound terminates when the input's
angles are not too small (Shewchuk 1998: segments at least 60 degrees apart,
segments and facets at least 69 degrees, dihedral angles at least 90). Random
closed surfaces have much smaller ones, and refinement next to them splits
ever nearer the vertex or the edge where they meet (a spiral of
subsegment, subface and tetrahedron splits: points 1e-15 from a vertex,
then two points that coincide in a facet's plane). Two cures, as in
Shewchuk's, TetGen's and CGAL's meshers:

* **Protecting balls** (:func:`protecting_balls`; Cheng and Poon, "Graded
  conforming Delaunay tetrahedralization with bounded radius-edge ratio",
  2003; Cohen-Steiner, de Verdière and Yvinec, "Conforming Delaunay
  triangulations in 3D", 2002): every *sharp* input vertex (two segments on
  no common facet, or a segment and a facet on its inner side, less than
  ``Knobs.small_angle`` apart; or an incident segment of interior dihedral
  angle below ``Knobs.sharp_dihedral``) gets a ball of radius a power of
  two, at most ``Knobs.ball_fraction`` of its local feature size (the
  distance to the nearest other input vertex or non-incident input
  triangle), so balls never meet. Inside the ball the only points are the
  vertex and points on the ball's sphere: the concentric shells of
  :meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.split_segments` stop
  at the sphere, a subface's split point inside the ball is moved onto the
  sphere (:meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.onto_balls`),
  and no interior point is inserted inside it (the tetrahedron asking for
  it is left, cause ``input_angle``). Then the subsegments from the vertex
  to its sphere are edges for good, and the splits next to it end.
* **Protecting cylinders** (:func:`protecting_cylinders`, after the
  protection along sharp edges of CGAL's meshers and the same balls' idea):
  every *sharp* input edge (interior dihedral angle below
  ``Knobs.sharp_edge``, 70 degrees, or above 360 minus it: two facets nearly
  folded onto each other across a thin slot outside) gets a cylinder around
  it, of radius a power of two at most ``Knobs.ball_fraction`` of its length
  and of its distance to the nearest input vertex off it. No interior point
  is inserted inside it, a subface whose circumcentre lies inside it is not
  split for encroachment (the tetrahedron asking for it is left), and a
  tetrahedron whose circumcentre lies inside it is left, named by the edge
  (:func:`held_by_cylinders` names those left for such a subface). Before,
  the refinement along an edge of 13 degrees split the subfaces on both
  sides of it ever nearer the edge: star seed 3264, 1,027,890 tetrahedra in
  307 CPU s; now 2,312. Recovery (missing pieces) is not restricted.
* **Skinny because of the input** (:func:`input_forced`; Shewchuk,
  "Tetrahedral mesh generation by Delaunay refinement", 1998, §5): a bad
  tetrahedron whose shortest edge joins points on two different input
  features (vertices, segments, facets; neither holding the other) that
  meet at an input vertex or segment, at an angle (seen from it) below
  ``Knobs.small_angle`` (``Knobs.facet_angle`` for two segments of one
  facet), is not refined: no point makes it better, and its circumcentre's
  splits are the spiral.

References
----------
Methods text §9.2, §9.3 (the recovery these pieces belong to); J. R.
Shewchuk (SoCG 1998); S.-W. Cheng and S.-H. Poon (SODA 2003); D.
Cohen-Steiner, É. Colin de Verdière and M. Yvinec (SoCG 2002).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.delaunay.recovery3d import TET_EDGES, SurfaceRecovery, ball_pairs, tri_circumcenters
from meshcore.mesh.topology import unique_ints

_TET_EDGES = TET_EDGES.copy()

__all__ = [
    "held_by_cylinders",
    "input_forced",
    "protecting_balls",
    "protecting_cylinders",
    "segment_dihedrals",
]


def _unit(x: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return x / n


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angles (degrees) between vectors (rows)."""
    c = np.einsum("ij,ij->i", _unit(u), _unit(v))
    return np.degrees(np.arccos(np.clip(np.nan_to_num(c, nan=1.0), -1.0, 1.0)))


def _pairs(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (i, j), i != j, of rows with the same (sorted) ``group``."""
    bounds = np.flatnonzero(
        np.diff(np.concatenate([[-1], group, [group.max() + 1 if len(group) else 0]]))
    )
    start = bounds[:-1]
    size = np.diff(bounds)
    first = np.repeat(start, size)
    deg = np.repeat(size, size)
    i = np.repeat(np.arange(len(group)), deg)
    j = np.repeat(first, deg) + (np.arange(len(i)) - np.repeat(np.cumsum(deg) - deg, deg))
    keep = i != j
    return i[keep], j[keep]


def segment_dihedrals(b: SurfaceRecovery) -> tuple[np.ndarray, np.ndarray]:
    """The input segments (``edges`` rows, ascending) and the interior dihedral angle
    (degrees, between their two input triangles, inside the region) of each."""
    n = b.n_surface
    P = b.P
    F = b.facets
    seg_e = unique_ints(b.seg_edge)
    E = b.edges[seg_e]
    if len(E) == 0:
        return seg_e, np.zeros(0)
    tri_edges = np.sort(np.stack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], 1), axis=2)
    key = tri_edges[..., 0] * n + tri_edges[..., 1]
    order = np.argsort(key.reshape(-1), kind="stable")
    ks = key.reshape(-1)[order]
    ek = E[:, 0] * n + E[:, 1]
    pos = np.searchsorted(ks, ek)
    t1, t2 = order[pos] // 3, order[pos + 1] // 3
    nrm = _unit(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]))
    far = F[t2][(F[t2] != E[:, :1]) & (F[t2] != E[:, 1:])]
    convex = np.einsum("ij,ij->i", nrm[t1], P[far] - P[F[t1, 0]]) < 0
    phi = _angle(nrm[t1], nrm[t2])
    return seg_e, np.where(convex, 180.0 - phi, 180.0 + phi)


def sharp_vertices(b: SurfaceRecovery) -> np.ndarray:
    """Mask of the input vertices where features meet at a small angle (see the module)."""
    k = b.knobs
    P = b.P
    F = b.facets
    out = np.zeros(b.n_surface, dtype=bool)
    seg_e, dihedral = segment_dihedrals(b)
    E = b.edges[seg_e]
    if len(E) == 0:
        return out
    nrm = _unit(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]))
    sharp_seg = dihedral < k.sharp_dihedral
    out[E[sharp_seg].reshape(-1)] = True
    # Pairs of segments at a vertex that share no facet.
    ends = np.concatenate([E[:, 0], E[:, 1]])
    other = np.concatenate([E[:, 1], E[:, 0]])
    groups = np.concatenate([b.edge_groups[seg_e]] * 2)
    order = np.argsort(ends, kind="stable")
    ends, other, groups = ends[order], other[order], groups[order]
    i, j = _pairs(ends)
    common = (groups[i, :, None] == groups[j, None, :]).any(axis=(1, 2))
    ang = _angle(P[other[i]] - P[ends[i]], P[other[j]] - P[ends[j]])
    out[ends[i][~common & (ang < k.small_angle)]] = True
    # A segment and a facet (an input triangle at the vertex, of another facet than
    # the segment's two) on its inner side, the segment over the triangle's corner.
    cv = F.reshape(-1)
    ct = np.repeat(np.arange(len(F)), 3)
    corner = np.tile(np.arange(3), len(F))
    order = np.argsort(cv, kind="stable")
    cv, ct, corner = cv[order], ct[order], corner[order]
    lo = np.searchsorted(cv, ends, side="left")
    hi = np.searchsorted(cv, ends, side="right")
    cnt = hi - lo
    si = np.repeat(np.arange(len(ends)), cnt)
    ci = np.repeat(lo, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    t = ct[ci]
    g = b.group[t]
    mine = (groups[si] == g[:, None]).any(axis=1)
    si, ci, t = si[~mine], ci[~mine], t[~mine]
    if si.size:
        v = ends[si]
        d = _unit(P[other[si]] - P[v])
        a1 = P[F[t, (corner[ci] + 1) % 3]] - P[v]
        a2 = P[F[t, (corner[ci] + 2) % 3]] - P[v]
        nn = nrm[t]
        h = np.einsum("ij,ij->i", d, nn)
        dp = d - h[:, None] * nn
        w = np.einsum("ij,ij->i", np.cross(a1, a2), nn)
        s1 = np.einsum("ij,ij->i", np.cross(dp, a2), nn) * w
        s2 = np.einsum("ij,ij->i", np.cross(a1, dp), nn) * w
        over = (s1 >= 0) & (s2 >= 0) & (h < 0)
        small = np.degrees(np.arcsin(np.clip(-h, 0.0, 1.0))) < k.small_angle
        out[v[over & small]] = True
    return out


def _point_triangle_distance(X, A, B, C) -> np.ndarray:
    """Distance from each point X[i] to the triangle (A[i], B[i], C[i]) (constructions)."""
    ab, ac, ax = B - A, C - A, X - A
    nrm = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", nrm, nrm)
    # Barycentric coordinates of the projection; inside: the plane distance.
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.einsum("ij,ij->i", np.cross(ax, ac), nrm) / nn
        w = np.einsum("ij,ij->i", np.cross(ab, ax), nrm) / nn
        plane = np.abs(np.einsum("ij,ij->i", ax, nrm)) / np.sqrt(nn)
    inside = (v >= 0) & (w >= 0) & (v + w <= 1)

    def seg(P, Q):
        d = Q - P
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.clip(np.einsum("ij,ij->i", X - P, d) / np.einsum("ij,ij->i", d, d), 0, 1)
        return np.linalg.norm(X - (P + np.nan_to_num(s)[:, None] * d), axis=1)

    edge = np.minimum(np.minimum(seg(A, B), seg(B, C)), seg(C, A))
    return np.where(inside, np.minimum(plane, edge), edge)


def protecting_balls(b: SurfaceRecovery) -> int:
    """Give every sharp input vertex of ``b`` its protecting ball (``b.ball``); their number.

    Radius: the largest power of two at most ``Knobs.ball_fraction`` times
    the vertex's local feature size (nearest other input vertex, nearest
    input triangle not incident to it) and half of ``b.size_cap``.
    """
    sharp = np.flatnonzero(sharp_vertices(b))
    if sharp.size == 0:
        return 0
    P = b.P[: b.n_surface]
    F = b.facets
    d_near, _ = cKDTree(P).query(P[sharp], k=2)
    lfs = d_near[:, 1].copy()
    a, bb, c = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    longest = np.maximum.reduce(
        [np.linalg.norm(bb - a, axis=1), np.linalg.norm(c - bb, axis=1),
         np.linalg.norm(a - c, axis=1)]
    )  # fmt: skip
    xi, ti = ball_pairs(P[sharp], (a + bb + c) / 3.0, longest + lfs.max())
    touch = (F[ti] == sharp[xi][:, None]).any(axis=1)
    xi, ti = xi[~touch], ti[~touch]
    if xi.size:
        dist = _point_triangle_distance(P[sharp[xi]], a[ti], bb[ti], c[ti])
        np.minimum.at(lfs, xi, dist)
    # Each incident facet's refinement size too (a thin facet's, ``facet_size``).
    size = np.full(b.n_surface, np.inf)
    np.minimum.at(size, F.reshape(-1), np.repeat(b.facet_size[b.group], 3))
    r = np.minimum(b.knobs.ball_fraction * lfs, 0.5 * np.minimum(b.size_cap, size[sharp]))
    ok = r > 0
    b.ball[sharp[ok]] = np.exp2(np.floor(np.log2(r[ok])))
    b._ball_tree = None
    return int(ok.sum())


def protecting_cylinders(b: SurfaceRecovery) -> int:
    """Give every sharp input edge of ``b`` its protecting cylinder; their number.

    Sharp: an interior dihedral angle below ``Knobs.sharp_edge``, or above 360
    degrees minus it (two facets nearly folded onto each other across a thin slot
    outside: each one's points encroach the other's subfaces). Radius: the
    largest power of two at most ``Knobs.ball_fraction`` times the edge's length
    and times the distance from the edge to the nearest input vertex off it.
    """
    seg_e, dihedral = segment_dihedrals(b)
    e = seg_e[np.minimum(dihedral, 360.0 - dihedral) < b.knobs.sharp_edge]
    if e.size == 0:
        return 0
    E = b.edges[e]
    P = b.P[: b.n_surface]
    a, c = P[E[:, 0]], P[E[:, 1]]
    L = np.linalg.norm(c - a, axis=1)
    lim = b.knobs.ball_fraction * L
    vi, ci = ball_pairs(P, 0.5 * (a + c), 1.5 * L)
    off = (vi != E[ci, 0]) & (vi != E[ci, 1])
    vi, ci = vi[off], ci[off]
    if vi.size:
        d = c[ci] - a[ci]
        t = np.clip(np.einsum("ij,ij->i", P[vi] - a[ci], d) / np.einsum("ij,ij->i", d, d), 0, 1)
        dist = np.linalg.norm(P[vi] - (a[ci] + t[:, None] * d), axis=1)
        np.minimum.at(lim, ci, b.knobs.ball_fraction * dist)
    b.cyl_edge, b.cyl_radius = e, np.exp2(np.floor(np.log2(lim)))
    return len(e)


def held_by_cylinders(b: SurfaceRecovery, centres: np.ndarray) -> np.ndarray:
    """For each circumcentre, the sharp input edge (``edges`` row) whose protecting
    cylinder holds the circumcentre of a subface it encroaches, or -1.

    Such a subface is not split (``SurfaceRecovery.protected_subfaces``), so the
    tetrahedron of that circumcentre is left because of the edge's angle.
    """
    out = np.full(len(centres), -1, dtype=np.int64)
    if b.cyl_edge.size == 0 or len(centres) == 0:
        return out
    cc = np.where(np.isfinite(centres).all(axis=1)[:, None], centres, 1e300)
    xi, fi = b.encroached_subfaces(cc)
    if xi.size:
        o, _ = tri_circumcenters(b.P, b.sub[fi])
        e = b.in_cylinders(np.where(np.isfinite(o).all(axis=1)[:, None], o, 1e300))
        out[xi[e >= 0]] = e[e >= 0]
    return out


def _feature_tables(b: SurfaceRecovery):
    """Per facet its input vertices (CSR, sorted), and the segments between two facets
    (keys ``min(g, h) * G + max(g, h)`` sorted, edge ids ascending within a key).

    Input data only: built once per ``b``.
    """
    tables = b.__dict__.get("_feature_tables")
    if tables is None:
        G = len(b.group_tris)
        F = b.facets
        corners = unique_ints(np.repeat(b.group, 3) * b.n_surface + F.reshape(-1))
        ptr = np.searchsorted(corners // b.n_surface, np.arange(G + 1))
        eg = b.edge_groups
        keys = eg.min(axis=1) * G + eg.max(axis=1)
        order = np.argsort(keys, kind="stable")
        tables = (ptr, corners % b.n_surface, keys[order], order)
        b._feature_tables = tables
    return tables


@njit(cache=True, inline="always")  # no copy per literal argument
def _has(arr, lo, hi, x):
    for i in range(lo, hi):
        if arr[i] == x:
            return True
    return False


@njit(cache=True)
def _cos(x0, x1, x2, y0, y1, y2):
    """Cosine of the angle between two vectors, as ``_angle`` computes it (NaN: 1)."""
    nx = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    ny = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
    c = ((x0 / nx) * (y0 / ny) + (x2 / nx) * (y2 / ny)) + (x1 / nx) * (y1 / ny)  # as einsum
    if math.isnan(c):
        return 1.0
    return min(1.0, max(-1.0, c))


@njit(cache=True, error_model="numpy")
def _forced_candidates(
    P, T, pt_edge, pt_facet, n_surface, edges, edge_groups, ptr, corners, pair_keys,
    pair_edges, n_groups, small, flat,
):  # fmt: skip
    """For each tetrahedron of ``T``: the cosine of the input angle its shortest edge spans
    (2.0 where none), the bound (degrees) and the input vertex or segment (two ends, -1)."""
    m = T.shape[0]
    cos = np.full(m, 2.0)
    bound = np.zeros(m)
    at = np.full((m, 2), -1, np.int64)
    va = np.empty(corners.shape[0] + 2, np.int64)
    vc = np.empty(corners.shape[0] + 2, np.int64)
    shared = np.empty(corners.shape[0] + 2, np.int64)
    for t in range(m):
        # The shortest edge (the first of the shortest, edges in TET_EDGES order).
        best = np.inf
        p = -1
        q = -1
        for k in range(6):
            i = T[t, _TET_EDGES[k, 0]]
            j = T[t, _TET_EDGES[k, 1]]
            dx = P[i, 0] - P[j, 0]
            dy = P[i, 1] - P[j, 1]
            dz = P[i, 2] - P[j, 2]
            d = dx * dx + dy * dy + dz * dz
            if d < best:
                best = d
                p = i
                q = j
        ka, fa = _feature(p, n_surface, pt_edge, pt_facet)
        kc, fc = _feature(q, n_surface, pt_edge, pt_facet)
        if ka == 3 or kc == 3 or (ka == kc and fa == fc):
            continue
        na = _vertices(ka, fa, edges, ptr, corners, va)
        nc = _vertices(kc, fc, edges, ptr, corners, vc)
        # Neither feature on the other's closure.
        if (ka == 0 and _has(vc, 0, nc, fa)) or (kc == 0 and _has(va, 0, na, fc)):
            continue
        if ka == 1 and kc == 2 and (edge_groups[fa, 0] == fc or edge_groups[fa, 1] == fc):
            continue
        if kc == 1 and ka == 2 and (edge_groups[fc, 0] == fa or edge_groups[fc, 1] == fa):
            continue
        ns = 0
        for i in range(na):
            if _has(vc, 0, nc, va[i]) and not _has(shared, 0, ns, va[i]):
                shared[ns] = va[i]
                ns += 1
        if ns == 0:
            continue
        line = -1
        if ka == 2 and kc == 2 and ns >= 2:
            key = min(fa, fc) * n_groups + max(fa, fc)
            k = np.searchsorted(pair_keys, key)
            while k < pair_keys.shape[0] and pair_keys[k] == key:
                e = pair_edges[k]
                if _has(shared, 0, ns, edges[e, 0]) and _has(shared, 0, ns, edges[e, 1]):
                    line = e
                    break
                k += 1
        if line >= 0:
            o = P[edges[line, 0]]
            u0 = P[edges[line, 1], 0] - o[0]
            u1 = P[edges[line, 1], 1] - o[1]
            u2 = P[edges[line, 1], 2] - o[2]
            nu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            u0, u1, u2 = u0 / nu, u1 / nu, u2 / nu
            x0, x1, x2 = P[p, 0] - o[0], P[p, 1] - o[1], P[p, 2] - o[2]
            y0, y1, y2 = P[q, 0] - o[0], P[q, 1] - o[1], P[q, 2] - o[2]
            xu = x0 * u0 + x1 * u1 + x2 * u2
            yu = y0 * u0 + y1 * u1 + y2 * u2
            cos[t] = _cos(
                x0 - xu * u0, x1 - xu * u1, x2 - xu * u2, y0 - yu * u0, y1 - yu * u1,
                y2 - yu * u2,
            )  # fmt: skip
            at[t, 0] = min(edges[line, 0], edges[line, 1])
            at[t, 1] = max(edges[line, 0], edges[line, 1])
            bound[t] = small
        else:
            m0 = 0.5 * (P[p, 0] + P[q, 0])
            m1 = 0.5 * (P[p, 1] + P[q, 1])
            m2 = 0.5 * (P[p, 2] + P[q, 2])
            vv = -1
            dv = np.inf
            for i in range(ns):  # the nearest shared vertex, the smallest on ties
                z = shared[i]
                d0, d1, d2 = P[z, 0] - m0, P[z, 1] - m1, P[z, 2] - m2
                d = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                if d < dv or (d == dv and z < vv):
                    dv = d
                    vv = z
            cos[t] = _cos(
                P[p, 0] - P[vv, 0], P[p, 1] - P[vv, 1], P[p, 2] - P[vv, 2],
                P[q, 0] - P[vv, 0], P[q, 1] - P[vv, 1], P[q, 2] - P[vv, 2],
            )  # fmt: skip
            at[t, 0] = vv
            # The facet bound when the two features lie on a common facet.
            common = False
            if ka != 0 and kc != 0:
                for x in range(2 if ka == 1 else 1):
                    g = edge_groups[fa, x] if ka == 1 else fa
                    for y in range(2 if kc == 1 else 1):
                        common |= g == (edge_groups[fc, y] if kc == 1 else fc)
            bound[t] = flat if common else small
    return cos, bound, at


@njit(cache=True, inline="always")
def _feature(p, n_surface, pt_edge, pt_facet):
    """Kind (0 vertex, 1 segment, 2 facet, 3 interior) and id of point ``p``'s feature."""
    if p < n_surface:
        return 0, p
    if pt_edge[p] >= 0:
        return 1, pt_edge[p]
    if pt_facet[p] >= 0:
        return 2, pt_facet[p]
    return 3, -1


@njit(cache=True)
def _vertices(kind, fid, edges, ptr, corners, out):
    """The input vertices of a feature's closure into ``out``; their number."""
    if kind == 0:
        out[0] = fid
        return 1
    if kind == 1:
        out[0] = edges[fid, 0]
        out[1] = edges[fid, 1]
        return 2
    n = ptr[fid + 1] - ptr[fid]
    out[:n] = corners[ptr[fid] : ptr[fid + 1]]
    return n


def input_forced(b: SurfaceRecovery, T: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, list]:
    """Which tetrahedra ``T`` are skinny because of a small input angle, and where.

    A tetrahedron is when its circumcentre lies inside a protecting ball
    (where no point is inserted: its badness is the ball's), or when its
    shortest edge joins two points on different input features (an input
    vertex, a segment, a facet; neither on the other's closure) that share
    an input vertex or segment, and the angle between the two points seen
    from the shared segment's line (two facets across it) or vertex (the
    shared vertex nearest the edge, the smallest on ties) is below
    ``Knobs.small_angle`` (``Knobs.facet_angle`` when both lie on one
    facet's boundary).

    ``centres``: their circumcentres. Returns the mask and, per forced
    tetrahedron, the input vertices
    (surface numbering) of the vertex or segment where the angle is.
    One compiled pass over the tetrahedra (the features are looked up in
    per-facet tables built once).
    """
    m = len(T)
    mask = np.zeros(m, dtype=bool)
    where: list = [None] * m
    if m == 0:
        return mask, where
    ptr, corners, pair_keys, pair_edges = _feature_tables(b)
    cos, bound, at = _forced_candidates(
        b.P, np.ascontiguousarray(T, dtype=np.int64), b.pt_edge, b.pt_facet, b.n_surface,
        b.edges, b.edge_groups, ptr, corners, pair_keys, pair_edges, len(b.group_tris),
        b.knobs.small_angle, b.knobs.facet_angle,
    )  # fmt: skip
    cand = np.flatnonzero(cos <= 1.0)
    mask[cand] = np.degrees(np.arccos(cos[cand])) < bound[cand]
    for r in np.flatnonzero(mask).tolist():  # the forced ones, to name their place
        where[r] = [int(at[r, 0])] if at[r, 1] < 0 else [int(at[r, 0]), int(at[r, 1])]
    # Inside a protecting ball: a vertex and the circumcentre both inside one.
    if b.ball.any():
        rest = np.flatnonzero(~mask)
        if rest.size:
            cc = centres[rest]
            cc = np.where(np.isfinite(cc).all(axis=1)[:, None], cc, math.inf)
            vin = b.in_balls(np.nan_to_num(cc, posinf=1e300, neginf=-1e300))
            hit = vin >= 0
            mask[rest[hit]] = True
            for r, v in zip(rest[hit].tolist(), vin[hit].tolist(), strict=True):
                where[r] = [int(v)]
    # Inside a protecting cylinder: the circumcentre next to a sharp edge.
    if b.cyl_edge.size:
        rest = np.flatnonzero(~mask)
        if rest.size:
            cc = centres[rest]
            cc = np.where(np.isfinite(cc).all(axis=1)[:, None], cc, 1e300)
            ein = b.in_cylinders(cc)
            hit = ein >= 0
            mask[rest[hit]] = True
            for r, e in zip(rest[hit].tolist(), ein[hit].tolist(), strict=True):
                where[r] = sorted(int(v) for v in b.edges[e])
    return mask, where
