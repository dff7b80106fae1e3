"""Slivers of :func:`meshcore.tets.refinement.tetrahedralize` (``min_dihedral``).

:func:`remove_slivers` on the refined tetrahedra: :func:`improve` raises
the least dihedral angle by flips, smoothing and insertion
(:mod:`meshcore.tets.improve`, after Klingner and Shewchuk, "Aggressive
tetrahedral mesh improvement", 2007) until every tetrahedron reaches the
bound where it can. The result is no longer a Delaunay tetrahedralization.

Choices the methods text leaves open (it names sliver exudation,
perturbation or smoothing):

* Local improvement alone, on the tetrahedra within ``ZONE_RINGS`` rings of
  those under the bound: edge and face removal, smoothing of a free vertex,
  and a new point in a star cavity where none of those gains. No perturbed
  insertion round (Chew's random points near the circumcentre) runs before
  it: the improvement reaches 15 degrees (and 20) on every test shape and on
  the benchmark's cube minus a ball, torus and thin plate without one, with
  fewer tetrahedra and without a second pass over the whole mesh.
* The surface is kept: faces on the surface (and between regions) are never
  flipped; the points the refinement put inside move freely, those it put
  inside a facet slide in the facet's plane (to rounding, as they were
  placed), the input vertices and the points on input edges stay.
* The radius-edge bound is kept: no operation makes a tetrahedron above
  ``max(max_radius_edge, the worst of the tetrahedra it replaces)``
  (``UNBOUNDED_CAP`` when none is asked); only where that leaves tetrahedra
  under the bound, a second stage without the cap runs, and
  ``radius_edge_traded`` counts the tetrahedra left above the ratio.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.delaunay.recovery3d import (
    TET_FACES,
    SurfaceRecovery,
    member,
)
from meshcore.mesh.tetstore import N_ROWS, CellStore, face_key
from meshcore.mesh.topology import group_slots
from meshcore.tets.improve import NK, OUT_OF_POINTS, OUT_OF_ROWS, improve_passes
from meshcore.tets.refinement import _least_dihedral

__all__ = ["improve", "remove_slivers"]


#: Passes over the tetrahedra under the bound.
PASSES = 30
#: The radius-edge cap of the first stage when no ``max_radius_edge`` is asked (TetGen's
#: default bound): without one, flips and smoothing made tetrahedra of large ratio, and
#: Poisson on the cube converged at rate 1.74 instead of 1.9 in the max norm.
UNBOUNDED_CAP = 2.0
#: Spare point rows for insertion (grown as needed).
SPARE = 1024
#: Rings of vertex neighbours around the tetrahedra under the bound that the improvement
#: edits (an operation on a sliver reaches its first ring; what it makes, the next ones).
ZONE_RINGS = 3


def _face_keys(F: np.ndarray) -> np.ndarray:
    """Keys of faces as :func:`meshcore.mesh.tetstore.face_key` makes them (base ``NK``)."""
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    lo = np.minimum(np.minimum(a, b), c)
    hi = np.maximum(np.maximum(a, b), c)
    return (lo * NK + (a + b + c - lo - hi)) * NK + hi


def improve(
    points: np.ndarray,
    tetra: np.ndarray,
    region: np.ndarray,
    faces: np.ndarray,
    free: np.ndarray,
    normals: np.ndarray,
    bound: float,
    max_radius_edge: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Flips, smoothing and insertion that raise the least dihedral angle towards ``bound``.

    Parameters
    ----------
    points : (n, 3) float64
    tetra : (m, 4) int64
        The kernel's order (``orient3d > 0``, Shewchuk's sign).
    region : (m,) int64
    faces : (k, 3) int64
        Constrained faces (the surface, the faces between regions): kept. Every face
        of ``tetra`` held by one tetrahedron only is among them.
    free : (n,) bool
        The points that may move.
    normals : (n, 3) float64
        For a free point, the unit normal of the plane it must stay in (a point
        inside a planar facet), or zeros.
    bound : float
        Degrees: tetrahedra under it are improved.
    max_radius_edge : float
        No tetrahedron is made above it (or above the worst it replaces).

    Returns
    -------
    points, tetra, region, stats
        The moved points followed by the inserted ones (free, inside the
        zone), the new tetrahedra (same order convention; each positive by
        the exact ``orient3d``, filling the same regions, every constrained
        face still a face), their regions, and the counts of
        ``edge_removals``, ``face_removals``, ``smoothing_moves``,
        ``points_inserted``, ``passes``.
        Only the tetrahedra within ``ZONE_RINGS`` rings of vertex neighbours of
        those under ``bound`` are edited (the faces bounding that zone are kept
        and the vertices on them stay, except the surface's, which slide as
        above): the others come first, unchanged, then the zone's.

    References
    ----------
    Methods text §8.3 (local operations on sub-topologies); Klingner and
    Shewchuk (2007).
    """
    tetra = np.asarray(tetra, dtype=np.int64)
    points = np.asarray(points, dtype=np.float64)
    fixed = ~np.asarray(free, bool)
    # Only the zone around the tetrahedra under the bound is edited; its boundary faces
    # are constrained and their vertices fixed, so the tetrahedra outside stay as they are.
    zone, rim_k = _zone_rim(tetra, _least_dihedral(points, tetra) < bound, len(points))
    rim, rim_k = _lone(np.sort(rim_k))
    subk = np.sort(_face_keys(np.asarray(faces, dtype=np.int64)))
    fixed[rim[~member(rim_k, subk)].ravel()] = True  # not the surface's: it may slide
    T = np.ascontiguousarray(tetra[zone][:, [0, 1, 3, 2]])
    # Spare rows: flips and insertions reuse the rows they free; on the benchmark shapes
    # at 100k the zone never grew by 1.1 % (twice the rows, as by default, cost ~90 MB
    # at 1M tetrahedra).
    state = CellStore(points, T, fixed, SPARE, spare_rows=len(T) // 8 + 256)
    reg = np.full(state.T.shape[0], -1, dtype=np.int64)
    reg[: len(T)] = region[zone]
    N = np.zeros_like(state.P)
    N[: len(normals)] = normals
    subk = np.sort(np.concatenate([subk, rim_k]))
    counters = np.zeros(4, np.int64)
    left = PASSES
    while left > 0:
        done, status = improve_passes(
            state.P, state.T, state.alive, state.head, state.nxt, state.prv, state.free,
            state.cnt, reg, subk, state.fixed, N, float(bound), float(max_radius_edge),
            np.int64(left), counters,
        )  # fmt: skip
        left -= done
        if status not in (OUT_OF_ROWS, OUT_OF_POINTS):
            break
        # Both grow by compacting the live rows, in order: their regions follow.
        rows = int(state.cnt[N_ROWS])
        kept = reg[:rows][state.alive[:rows].astype(bool)]
        if status == OUT_OF_ROWS:
            state.grow_rows()
        else:
            state.grow_points(SPARE + state.P.shape[0] // 4)
            N = np.concatenate([N, np.zeros((len(state.P) - len(N), 3))])
        reg = np.full(state.T.shape[0], -1, dtype=np.int64)
        reg[: len(kept)] = kept
    rows = int(state.cnt[N_ROWS])
    alive = state.alive[:rows].astype(bool)
    stats = {
        "edge_removals": int(counters[0]),
        "face_removals": int(counters[1]),
        "smoothing_moves": int(counters[2]),
        "points_inserted": int(counters[3]),
        "passes": PASSES - left,
    }
    out = np.concatenate([tetra[~zone], state.T[:rows][alive][:, [0, 1, 3, 2]]])
    return state.points().copy(), out, np.concatenate([region[~zone], reg[:rows][alive]]), stats


@njit(cache=True)
def _zone_rim(T, bad, n):
    """(m,) bool: the tetrahedra within ``ZONE_RINGS`` rings of vertex neighbours of
    ``bad``; and the keys (:func:`_face_keys`, unsorted) of their faces that may bound the
    zone: those without a vertex of the last ring's tetrahedra. (A face with such a vertex
    is held by two tetrahedra of the zone, every tetrahedron at that vertex being in it,
    or by one only in the whole mesh: a constrained face. One without is held twice in
    the keys exactly when both its tetrahedra are in the zone.)"""
    m = T.shape[0]
    zone = bad.copy()
    mark = np.zeros(n, np.bool_)
    for _ in range(ZONE_RINGS):
        mark[:] = False
        for t in range(m):
            if zone[t]:
                for j in range(4):
                    mark[T[t, j]] = True
        for t in range(m):
            zone[t] = mark[T[t, 0]] or mark[T[t, 1]] or mark[T[t, 2]] or mark[T[t, 3]]
    keys = np.empty(4 * m, np.int64)
    k = 0
    for t in range(m):
        if not zone[t]:
            continue
        for j in range(4):
            a, b, c = T[t, TET_FACES[j, 0]], T[t, TET_FACES[j, 1]], T[t, TET_FACES[j, 2]]
            if mark[a] or mark[b] or mark[c]:
                continue
            keys[k] = face_key(a, b, c, NK)
            k += 1
    return zone, keys[:k]


def _lone(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The keys of sorted face keys ``k`` that occur once, and their faces' corners,
    sorted ((k, 3)): (corners, keys)."""
    lone = np.ones(len(k), dtype=bool)
    same = k[1:] == k[:-1]
    lone[1:] &= ~same
    lone[:-1] &= ~same
    k = k[lone]
    return np.stack([k // (NK * NK), (k // NK) % NK, k % NK], 1), k


def remove_slivers(
    b: SurfaceRecovery, tetra: np.ndarray, region: np.ndarray, sub: np.ndarray, bound, mre
) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`improve` on the refined tetrahedra of ``b`` (its points inside may move; the
    points it inserts are appended to ``b`` as interior points); (tetra, region, stats).
    The stats' ``radius_edge_traded`` is counted by the caller's report, which measures
    the tetrahedra anyway (:func:`meshcore.tets.refinement._left_report`)."""
    free = np.zeros(b.n, dtype=bool)
    free[b.n_surface :] = b.pt_edge[b.n_surface :] < 0
    # Points inside a facet slide in its plane.
    on_facet = np.flatnonzero(free & (b.pt_facet >= 0))
    order, start = group_slots(b.group, b.group.max() + 1)
    tri = b.facets[order[start[:-1]]]  # the first triangle of each facet
    a, c, d = (b.P[tri[:, k]] for k in range(3))
    nrm = np.cross(c - a, d - a)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    normals = np.zeros((b.n, 3))
    normals[on_facet] = nrm[b.pt_facet[on_facet]]
    stats: dict = {}
    first = mre if math.isfinite(mre) else UNBOUNDED_CAP
    for cap in (first, math.inf):
        if math.isinf(cap) and _least(b.P, tetra) >= bound:
            break
        # Second stage, where the bound is not reached: the radius-edge bound is traded.
        n = len(b.P)
        b.P, tetra, region, st = improve(b.P, tetra, region, sub, free, normals, bound, cap)
        free = np.concatenate([free, np.ones(len(b.P) - n, dtype=bool)])
        normals = np.concatenate([normals, np.zeros((len(b.P) - n, 3))])
        for key, value in st.items():
            stats[key] = stats.get(key, 0) + value
    added = len(b.P) - b.n
    b.pt_edge = np.concatenate([b.pt_edge, np.full(added, -1, dtype=np.int64)])
    b.pt_facet = np.concatenate([b.pt_facet, np.full(added, -1, dtype=np.int64)])
    b.n += added
    b.interior_added += added
    return tetra, region, stats


def _least(P: np.ndarray, tetra: np.ndarray) -> float:
    return float(_least_dihedral(P, tetra).min()) if len(tetra) else 180.0
