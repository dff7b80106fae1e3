"""Slivers of :func:`meshcore.tets.refinement.tetrahedralize` (``min_dihedral``).

Two stages. :func:`sliver_pass`, inside the Delaunay refinement:
``PERTURBED_ROUNDS`` round(s) of perturbed insertion (Chew's random points near
the circumcentre, as Li and Teng analyse them).
Then :func:`remove_slivers` on the final tetrahedra: :func:`improve` raises
the least dihedral angle by flips, smoothing and insertion
(:mod:`meshcore.tets.improve`, after Klingner and Shewchuk, "Aggressive
tetrahedral mesh improvement", 2007) until every tetrahedron reaches the
bound where it can. The result is no longer a Delaunay tetrahedralization.

Choices the methods text leaves open (it names sliver exudation,
perturbation or smoothing):

* One round of perturbed insertion, then local improvement: perturbed
  insertion alone (8 rounds) left 1.74 degrees on the icosphere at size 0.05
  in 25 CPU s (13.8 s without); the improvement alone reaches 15.00 degrees
  there in about 1 s more, but on the thin slab (1 x 1 x 0.01) it stopped at
  9.4 degrees next to slivers whose four vertices are on the two faces,
  which a Delaunay point insertion removes (15.00 with both). The first
  round does nearly all the work (at about 100k tetrahedra and 15 degrees,
  the cube minus a ball: 1,310 points, then 1; the torus: 1,566, then 9 and
  1), and each further round costs passes over the whole mesh: one round,
  the improvement finishes the rest. On the cube at sizes 0.25 and 0.125
  (``max_radius_edge`` None) Poisson's max-norm rate is 1.88 with the round
  and 1.74 without it (the improvement then makes 132 edge removals instead
  of 2); but with other seeds of the random candidates the round gives 1.78,
  1.66 and 1.74: over these two sizes the rate moves by about 0.1 with small
  changes of the meshes (the maximum error's node and its star are the same).
* The surface is kept: faces on the surface (and between regions) are never
  flipped; the points the refinement put inside move freely, those it put
  inside a facet slide in the facet's plane (to rounding, as they were
  placed), the input vertices and the points on input edges stay.
* The radius-edge bound is kept: no operation makes a tetrahedron above
  ``max(max_radius_edge, the worst of the tetrahedra it replaces)``; only
  when that leaves tetrahedra under the bound, a second stage without the
  cap runs, and ``radius_edge_traded`` counts the tetrahedra left above the
  ratio (the 32 x 16 torus: 15.20 degrees, 13 tetrahedra up to ratio 6.5;
  with the cap, 6.8 degrees).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.delaunay.recovery3d import (
    TET_FACES,
    RegionLabels,
    SurfaceRecovery,
    face_keys,
    member,
    recover,
    tri_circumcenters,
)
from meshcore.mesh.tetstore import N_ROWS, CellStore
from meshcore.tets.improve import NK, OUT_OF_POINTS, OUT_OF_ROWS, improve_passes
from meshcore.tets.refinement import (
    _circumsphere,
    _flat_folds,
    _least_dihedral,
    _least_dihedral_cos,
    _measured,
    _shortest2,
)

__all__ = ["improve", "remove_slivers", "sliver_pass"]

_TET_FACES = TET_FACES.copy()
#: The one tetrahedron of four points, for the compiled measures of :func:`_quality`.
_ONE = np.arange(4, dtype=np.int64).reshape(1, 4)

#: Passes over the tetrahedra under the bound.
PASSES = 30
#: The radius-edge cap of the first stage when no ``max_radius_edge`` is asked (TetGen's
#: default bound): without one, flips and smoothing made tetrahedra of large ratio, and
#: Poisson on the cube converged at rate 1.74 instead of 1.9 in the max norm.
UNBOUNDED_CAP = 2.0
#: Rounds of perturbed insertion before the improvement (each is a pass over the whole mesh;
#: the improvement finishes what they leave; see the module docstring).
PERTURBED_ROUNDS = 1
#: Random candidates per sliver in perturbed insertion, besides its circumcentre, and the
#: radius of the ball they are drawn from, in units of the circumradius.
CANDIDATES = 16
CANDIDATE_BALL = 0.5
#: Spare point rows for insertion (grown as needed).
SPARE = 1024
#: Rings of vertex neighbours around the tetrahedra under the bound that the improvement
#: edits (an operation on a sliver reaches its first ring; what it makes, the next ones).
ZONE_RINGS = 3


def _face_keys(F: np.ndarray) -> np.ndarray:
    """Keys of faces as :func:`meshcore.mesh.tetstore.face_key` makes them (base ``NK``)."""
    s = np.sort(F, axis=1)
    return (s[:, 0] * NK + s[:, 1]) * NK + s[:, 2]


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
    """Flips and smoothing that raise the least dihedral angle towards ``bound`` degrees.

    Parameters
    ----------
    points : (n, 3) float64
    tetra : (m, 4) int64
        The kernel's order (``orient3d > 0``, Shewchuk's sign).
    region : (m,) int64
    faces : (k, 3) int64
        Constrained faces (the surface, the faces between regions): kept.
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
        The moved points, the new tetrahedra (same order convention; each
        positive by the exact ``orient3d``, filling the same regions, every
        constrained face still a face), their regions, and the counts of
        ``edge_removals``, ``face_removals``, ``smoothing_moves``, ``passes``.
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
    zone = _zone(tetra, _least_dihedral(points, tetra) < bound, len(points))
    rim = _rim(tetra[zone])
    subk = np.sort(_face_keys(np.asarray(faces, dtype=np.int64)))
    rim_k = _face_keys(rim)
    fixed[rim[~member(rim_k, subk)].ravel()] = True  # not the surface's: it may slide
    T = np.ascontiguousarray(tetra[zone][:, [0, 1, 3, 2]])
    state = CellStore(points, T, fixed, SPARE)
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


def _zone(tetra: np.ndarray, bad: np.ndarray, n: int) -> np.ndarray:
    """(m,) bool: the tetrahedra within ``ZONE_RINGS`` rings of vertex neighbours of ``bad``."""
    zone = bad
    for _ in range(ZONE_RINGS):
        mark = np.zeros(n, dtype=bool)
        mark[tetra[zone].ravel()] = True
        zone = mark[tetra].any(axis=1)
    return zone


def _rim(tetra: np.ndarray) -> np.ndarray:
    """(k, 3): the faces of ``tetra`` that only one of them holds (the zone's boundary)."""
    F = tetra[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]].reshape(-1, 3)
    keys = _face_keys(F)
    order = np.argsort(keys, kind="stable")
    k = keys[order]
    lone = np.ones(len(k), dtype=bool)
    same = k[1:] == k[:-1]
    lone[1:] &= ~same
    lone[:-1] &= ~same
    return F[order[lone]]


def remove_slivers(
    b: SurfaceRecovery, tetra: np.ndarray, region: np.ndarray, sub: np.ndarray, bound, mre
) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`improve` on the refined tetrahedra of ``b`` (its points inside may move; the
    points it inserts are appended to ``b`` as interior points); (tetra, region, stats)."""
    free = np.zeros(b.n, dtype=bool)
    free[b.n_surface :] = b.pt_edge[b.n_surface :] < 0
    # Points inside a facet slide in its plane.
    on_facet = np.flatnonzero(free & (b.pt_facet >= 0))
    tri = b.facets[np.argsort(b.group, kind="stable")]
    first = np.searchsorted(np.sort(b.group), np.arange(b.group.max() + 1))
    a, c, d = (b.P[tri[first, k]] for k in range(3))
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
    stats["radius_edge_traded"] = 0
    if math.isfinite(mre):
        _, R, short, _ = _measured(b.P, tetra)
        stats["radius_edge_traded"] = int((R > mre * short).sum())
    added = len(b.P) - b.n
    b.pt_edge = np.concatenate([b.pt_edge, np.full(added, -1, dtype=np.int64)])
    b.pt_facet = np.concatenate([b.pt_facet, np.full(added, -1, dtype=np.int64)])
    b.n += added
    b.interior_added += added
    return tetra, region, stats


def _least(P: np.ndarray, tetra: np.ndarray) -> float:
    return float(_least_dihedral(P, tetra).min()) if len(tetra) else 180.0


def sliver_pass(
    b: SurfaceRecovery, bound: float, max_radius_edge: float, region_of: RegionLabels, progress
) -> int:
    """Slivers removed by perturbed insertion (Chew; Li and Teng); returns the rounds.

    Each tetrahedron whose least dihedral angle is below ``bound`` is
    offered its circumcentre and ``CANDIDATES`` random points of the
    ball of radius ``CANDIDATE_BALL`` times its circumradius around it. For
    each candidate the cavity it would open (the tetrahedra whose
    circumsphere holds it, float, grown from the tetrahedron holding it) and
    the tetrahedra it would create are evaluated; the candidate is rejected
    if its cavity leaves the sliver's region (it would cut the surface). The
    best candidate (largest least dihedral angle of the new tetrahedra; the
    first one, in the order above, that reaches ``bound``) is inserted only
    if that angle beats the least dihedral angle of the tetrahedra it
    removes and no new tetrahedron exceeds the radius-edge bound (or the
    cavity's worst): every insertion raises the local minimum, so the pass
    cannot cascade. A sliver with a face on the surface also gets points off
    that face along its normal (a tetrahedron filling a fold of nearly 180
    degrees between two facets has its circumcentre on the surface). Rounds
    stop when one inserts nothing.
    """
    rng = np.random.default_rng(0)
    k = CANDIDATES
    rounds = 0
    for rounds in range(1, PERTURBED_ROUNDS + 1):
        recover(b, None)
        slots, T = b.tets()
        region = region_of(slots, T)
        dih = _least_dihedral(b.P, T)
        rows = np.flatnonzero((region >= 0) & (dih < bound))
        rows = rows[~_flat_folds(b, T[rows])]
        if rows.size == 0:
            break
        rows = rows[np.argsort(dih[rows], kind="stable")]
        cache = _SlotCache(b, slots, T, region)
        sub_keys = np.sort(face_keys(b.sub))
        done = 0
        buf = np.concatenate([b.P, np.empty((len(rows), 3))])  # at most one point a sliver
        b.P = buf[: len(b.P)]
        for row in rows.tolist():  # sequential: each insertion changes the next cavities
            s = int(slots[row])
            if cache.stale[s]:
                continue
            reg = int(region[row])
            # The slot is not stale: the cache holds its circumsphere (-1: not finite).
            if cache.R[s] >= 0:
                c, R = cache.C[s : s + 1], cache.R[s : s + 1]
            else:
                c, R = b.P[T[row]].mean(axis=0)[None], np.zeros(1)
            d = rng.normal(size=(k, 3))
            d *= (rng.random(k) ** (1 / 3) / np.linalg.norm(d, axis=1))[:, None]
            X = np.concatenate([c, c + CANDIDATE_BALL * R[0] * d])
            fk = face_keys(T[row][TET_FACES])
            on = member(fk, sub_keys)
            if on.any():
                # Leaning on the surface (a fold): also points off the subface's
                # plane along its normal, on both sides (the wrong side is outside
                # the region and rejected).
                # From the centroid: a flat tetrahedron's circumcentre is rounding.
                f = T[row][TET_FACES[int(np.argmax(on))]]
                nrm = np.cross(b.P[f[1]] - b.P[f[0]], b.P[f[2]] - b.P[f[0]])
                _, rf = tri_circumcenters(b.P, f[None])
                nrm *= rf[0] / np.linalg.norm(nrm)
                t = np.array([0.05, 0.1, 0.2, 0.35, 0.5, -0.05, -0.1, -0.2, -0.35, -0.5])
                X = np.concatenate([X, b.P[T[row]].mean(axis=0) + t[:, None] * nrm])
            X = X[b.in_balls(X) < 0]
            k_best = _best_candidate(
                b.P, cache.V, cache.A, cache.C, cache.R, cache.reg, s, X, reg, max_radius_edge,
                bound,
            )  # fmt: skip
            if k_best < 0:
                continue
            res = b.dt.insert(X[k_best], near=None)
            if res.duplicate:
                continue
            buf[len(b.P)] = X[k_best]
            b.P = buf[: len(b.P) + 1]  # a view: no copy of every point per insertion
            b.n += 1
            b.interior_added += 1
            done += 1
            cache.update(res, reg)
        b.P = b.P.copy()
        b.pt_edge = np.concatenate([b.pt_edge, np.full(done, -1, dtype=np.int64)])
        b.pt_facet = np.concatenate([b.pt_facet, np.full(done, -1, dtype=np.int64)])
        if progress is not None:
            progress(0.8, f"sliver round {rounds}: {len(rows)} slivers, {done} points")
        if done == 0:
            break
    return rounds


@njit(cache=True, error_model="numpy")
def _quality(X):
    """(least dihedral angle in degrees, radius-edge ratio) of the tetrahedron X (4, 3).

    The refinement's compiled measures (:func:`~meshcore.tets.refinement._least_dihedral_cos`,
    ``_circumsphere``, ``_shortest2``). Numpy's error model: a flat tetrahedron gives
    angle 0 and an infinite or NaN ratio, as :func:`tetra_dihedral_angles` and
    :func:`_tet_circumcenters`.
    """
    t = np.int64(0)  # not a literal 0: the measures would be compiled for it too
    cos = _least_dihedral_cos(X, _ONE, t, np.empty((4, 3)))
    r = _circumsphere(X, _ONE, t)[3]
    return math.degrees(math.acos(min(1.0, max(-1.0, cos)))), r / math.sqrt(_shortest2(X, _ONE, t))


@njit(cache=True, error_model="numpy")
def _best_candidate(P, V, A, C, R, reg, t0, X, reg_id, max_radius_edge, bound):
    """The candidate of X to insert for the sliver at slot t0 (see :func:`sliver_pass`), or -1.

    For each candidate, in float: a walk from t0 to the tetrahedron holding
    it strictly inside (else rejected), the cavity (tetrahedra whose
    circumsphere holds it, grown across faces; rejected if it leaves region
    ``reg_id``), and the tetrahedra it would create. Kept if their least
    dihedral angle beats the cavity's and their radius-edge ratios stay
    within ``max(max_radius_edge, the cavity's worst)``; the best is
    returned, or the first reaching ``bound``.
    """
    best = -1
    best_dih = -1.0
    cav = np.empty(1024, np.int64)
    fu = np.empty(4096, np.int64)
    fj = np.empty(4096, np.int64)
    Y = np.empty((4, 3))
    for k in range(X.shape[0]):
        x = X[k]
        # --- walk (float orientation; a point on a face is not strictly inside) ---
        t = t0
        found = False
        for _ in range(100000):
            moved = False
            flat = False
            for i in range(4):
                a = P[V[t, _TET_FACES[i, 0]]]
                u = P[V[t, _TET_FACES[i, 1]]] - a
                v = P[V[t, _TET_FACES[i, 2]]] - a
                d = x - a
                o = (
                    d[0] * (u[1] * v[2] - u[2] * v[1])
                    + d[1] * (u[2] * v[0] - u[0] * v[2])
                    + d[2] * (u[0] * v[1] - u[1] * v[0])
                )
                if o > 0:
                    t = A[t, i]
                    moved = True
                    break
                if o == 0:
                    flat = True
            if not moved:
                found = not flat
                break
            if t < 0 or V[t, 0] < 0 or V[t, 1] < 0 or V[t, 2] < 0 or V[t, 3] < 0:
                break
        if not found or reg[t] != reg_id:
            continue
        # --- cavity ---
        cav[0] = t
        nc = 1
        nf = 0
        ok = True
        i = 0
        while i < nc and ok:
            c = cav[i]
            i += 1
            for j in range(4):
                n = A[c, j]
                seen = False
                for q in range(nc):
                    if cav[q] == n:
                        seen = True
                        break
                if seen:
                    continue
                r = R[n] if 0 <= n < R.shape[0] else -1.0
                dx = x - C[n] if 0 <= n < R.shape[0] else x
                if r > 0 and (dx * dx).sum() < r * r:
                    if reg[n] != reg_id or nc == cav.shape[0]:
                        ok = False  # the cavity would cross the surface (or is huge)
                        break
                    cav[nc] = n
                    nc += 1
                else:
                    if nf == fu.shape[0]:
                        ok = False
                        break
                    fu[nf] = c
                    fj[nf] = j
                    nf += 1
        if not ok:
            continue
        old_dih = np.inf
        old_ratio = 0.0
        for q in range(nc):
            for z in range(4):
                Y[z] = P[V[cav[q], z]]
            dd, rr = _quality(Y)
            old_dih = min(old_dih, dd)
            old_ratio = max(old_ratio, rr)
        new_dih = np.inf
        new_ratio = 0.0
        for q in range(nf):
            for z in range(4):
                Y[z] = x if z == fj[q] else P[V[fu[q], z]]
            dd, rr = _quality(Y)
            new_dih = min(new_dih, dd)
            new_ratio = max(new_ratio, rr)
        if new_dih <= old_dih or not new_ratio <= max(max_radius_edge, old_ratio):
            continue
        if new_dih > best_dih:
            best = k
            best_dih = new_dih
            if new_dih >= bound:
                break
    return best


class _SlotCache:
    """Vertices, neighbours, circumspheres and regions of the kernel's slots (one round).

    Vertex, slot and region numbers in int32 (the kernel's own width: its slots and
    vertices are below 2**31); grown by a quarter as insertions add slots.
    """

    def __init__(self, b: SurfaceRecovery, slots, T, region) -> None:
        """The real tetrahedra ``T`` at ``slots`` (as :meth:`SurfaceRecovery.tets` gives
        them) and their regions."""
        self.b = b
        A = b.dt.adjacent(slots)
        top = int(max(slots.max(), A.max())) + 1
        self.V = np.full((top, 4), -1, dtype=np.int32)
        self.A = np.full((top, 4), -1, dtype=np.int32)
        self.C = np.zeros((top, 3))
        self.R = np.full(top, -1.0)
        self.reg = np.full(top, -1, dtype=np.int32)
        self.stale = np.zeros(top, dtype=bool)
        _store(b.P, slots, T, A, self.V, self.A, self.C, self.R)
        self.reg[slots] = region

    def _grow(self, top: int) -> None:
        if top <= len(self.V):
            return
        extra = max(top, len(self.V) + len(self.V) // 4 + 1024) - len(self.V)
        self.V = np.concatenate([self.V, np.full((extra, 4), -1, dtype=np.int32)])
        self.A = np.concatenate([self.A, np.full((extra, 4), -1, dtype=np.int32)])
        self.C = np.concatenate([self.C, np.zeros((extra, 3))])
        self.R = np.concatenate([self.R, np.full(extra, -1.0)])
        self.reg = np.concatenate([self.reg, np.full(extra, -1, dtype=np.int32)])
        self.stale = np.concatenate([self.stale, np.zeros(extra, dtype=bool)])

    def update(self, res, reg: int) -> None:
        created = np.asarray(res.created, dtype=np.int64)
        A = self.b.dt.adjacent(created)
        self._grow(int(max(created.max(), A.max())) + 1)
        self.stale[res.removed] = True
        _store(self.b.P, created, self.b.dt.tets(created), A, self.V, self.A, self.C, self.R)
        nb = _set_regions(created, self.V, self.A, self.reg, reg)
        self.A[nb] = self.b.dt.adjacent(nb)


@njit(cache=True, error_model="numpy")
def _store(P, slots, V, A, V_out, A_out, C, R):
    """Vertices, neighbours and circumspheres (as :func:`_tet_circumcenters`; radius -1 for a
    ghost or where it is not finite) of the tetrahedra ``V`` at ``slots``."""
    for k in range(slots.shape[0]):
        s = slots[k]
        real = True
        for i in range(4):
            V_out[s, i] = V[k, i]
            A_out[s, i] = A[k, i]
            real &= V[k, i] >= 0
        if not real:
            R[s] = -1.0
            continue
        ox, oy, oz, r, _ = _circumsphere(P, V_out, s)
        i0 = V_out[s, 0]
        C[s, 0], C[s, 1], C[s, 2] = P[i0, 0] + ox, P[i0, 1] + oy, P[i0, 2] + oz
        R[s] = r if math.isfinite(r) else -1.0


@njit(cache=True)
def _set_regions(created, V, A, reg, reg_id):
    """Regions of the created slots (``reg_id``, -1 for a ghost) set; the distinct slots
    their neighbours are (whose neighbours changed), sorted."""
    seen = np.empty(4 * created.shape[0], np.int64)
    n = 0
    for k in range(created.shape[0]):
        s = created[k]
        reg[s] = reg_id if V[s, 0] >= 0 and V[s, 1] >= 0 and V[s, 2] >= 0 and V[s, 3] >= 0 else -1
        for i in range(4):
            if A[s, i] >= 0:
                seen[n] = A[s, i]
                n += 1
    return np.unique(seen[:n])
