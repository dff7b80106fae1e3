"""Tetrahedral meshes of closed surfaces: boundary recovery, then Delaunay refinement.

:func:`tetrahedralize` fills the regions a closed surface bounds
(:func:`meshcore.domain.surface.parse_surface`: bodies, cavities, nested
bodies) with positively oriented tetrahedra whose faces cover every input
triangle, and refines them (Shewchuk's Delaunay refinement in 3D) until
the requested radius-edge ratio, volume and size hold.

Pipeline (every tetrahedralization is our kernel's,
:class:`meshcore.delaunay.kernel3d.IncrementalDelaunay3d`, kept between
phases and only ever grown by point insertion):

1. **Delaunay of the surface points** (the vertices the triangles use).
2. **Boundary recovery, conforming** (§9.2, §9.3.4, §9.3.5): the input edges
   between facets are cut into *subsegments* and every *facet* (an input
   triangle, or exactly coplanar neighbours merged: see below) into
   *subfaces*, the 2D Delaunay triangulation (kernel2d, in the facet's
   plane) of the facet's corners, the points added on its edges and the
   points added inside it. Rounds: every subsegment that is not an edge of
   the tetrahedralization is split at its midpoint (edges first, §9.3.4 (A));
   when all are edges, every subface that is not a face is split at its
   circumcentre, unless that point lies outside the facet or encroaches a
   subsegment (lies in its diametral ball, the ball B_AB of §9.2), in which
   case the subsegments it encroaches are split instead (Shewchuk's rule;
   the "projection of the point of maximal angle" of §9.2 and Pebay's
   heuristics are replaced by these circumcentre / midpoint rules, which
   terminate for input angles of at least 90 degrees). Every new point lies
   on the input surface (§9.3.5): on an input edge or in an input triangle,
   up to the rounding of its coordinates.
3. **Regions**: the tetrahedra are grouped by flood fill across the faces
   that are not subfaces; a group takes the region of the facets it meets
   from their inner side (``orient3d`` of the subface and the opposite
   vertex, exact), groups touching the convex hull's outside are dropped.
4. **Delaunay refinement** (Shewchuk, "Tetrahedral mesh generation by
   Delaunay refinement", 1998), in rounds, *lazy*: the surface pieces that
   went missing are recovered as in 2. (missing subfaces alone are split in
   one batch with the round's oversized subfaces below, and the last oversized
   ones, at most ``Knobs.tail`` of all subfaces, with the interior round's
   splits: each batch retriangulates whole facets; the eager variant, ``Knobs.eager``,
   also splits every subsegment and subface any vertex encroaches; measured
   on the torus it adds 4x more points); with a radius-edge bound, every
   subsegment longer than ``feature_size`` (2) times the feature size of a
   thin facet and every subface of a circumradius above ``0.7`` times it is
   split (:func:`_feature_sizes`, see below); then
   the bad tetrahedra (circumradius over shortest edge above
   ``max_radius_edge``, volume above ``max_volume``, circumradius above
   ``0.7 size``, the size being ``size_field``'s value at the circumcentre
   where one is given, :mod:`meshcore.tets.sizing`, as it is at a
   subsegment's midpoint and a subface's centroid above) in decreasing
   order of circumradius: the circumcentre is
   inserted unless it encroaches a subsegment (closed diametral ball, exact
   sign of :func:`~meshcore.geometry.predicates3d.dot3d`) or a subface
   (equatorial ball), which is split instead (a subface also when the subsegment the
   centre encroaches is protected); a circumcentre outside the
   surface's box (a tetrahedron leaning flat on the surface) splits the
   tetrahedron's faces that are subfaces. Insertions of one round skip a
   tetrahedron already destroyed by an earlier one (a lazy queue), in one
   compiled loop (:meth:`~meshcore.delaunay.kernel3d.IncrementalDelaunay3d.insert_guarded`);
   the surface pieces the rejected centres encroach are split after them,
   only for the tetrahedra still alive. Flat folds (:func:`_flat_folds`)
   are not refined.
5. **Slivers** (``min_dihedral``, :mod:`meshcore.tets.slivers`): on the
   final tetrahedra, flips, smoothing and insertion
   (:func:`meshcore.tets.slivers.improve`, after Klingner and Shewchuk)
   raise every tetrahedron under the bound, never flipping a face on the
   surface. **The output is then no longer Delaunay.** What is left
   is reported with its cause (``left``; ``left["improvement"]`` counts the
   operations and the tetrahedra the second stage left above the ratio).

Choices the methods text leaves open
------------------------------------
* Recovery is *conforming* (Steiner points on the surface, TetGen's
  default), not constrained: our kernel only inserts points.
  ``keep_boundary`` (no point on the surface): a surface whose recovery
  needs no Steiner point (a Delaunay-admissible surface) keeps its
  Delaunay tetrahedra; a star-shaped one is the cone from one interior
  Steiner point (the Chebyshev centre of the kernel polyhedron, from a
  linear program) to every input triangle, each checked positive by exact
  ``orient3d`` (Schönhardt's prism: exactly one point); any other is
  recovered conforming (every input triangle its own facet), then its
  surface Steiner points are lifted inside one at a time
  (:func:`meshcore.tets.keep.lift_surface_points`: the hole each leaves is
  re-triangulated in the input triangle's plane and coned to the moved
  point, every sign exact): as many interior points as recovery put on the
  surface (the 32 x 16 torus: 42; TetGen ``-pY`` 13). Then 3-2 flips
  raise the tetrahedra under ``Knobs.kept_flip_below`` degrees
  (:func:`meshcore.tets.keep.flip_slivers`; the torus's flat tetrahedra on
  trapezoids coplanar up to rounding: 241 -> 43).
* The refinement decisions of *where* to insert (a circumcentre in a facet,
  a vertex inside an equatorial ball) use float constructions; only the
  subsegment encroachment and every validity fact (orientation, region
  sides) are exact signs. A misjudged tie only changes which point is
  added.
* **Facets.** Input triangles joined across an edge whose four points are
  exactly coplanar (exact ``orient3d == 0``) form one facet, meshed as one
  polygon (TetGen merges coplanar facets too): the diagonals a planar face
  was triangulated with are no constraints, so they make no small input
  angles (the L-block's caps are fans with 18-degree angles: refined to
  radius-edge 2 it took 29,867 tetrahedra and gave up 1,679 before, 61
  tetrahedra now). A facet with no point added keeps its input triangles;
  otherwise its subfaces are the 2D Delaunay triangulation of its points,
  the pockets outside a non-convex facet dropped
  (:meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.retriangulate`).
  Triangles coplanar only up to rounding are not merged: the tetrahedron
  on their four corners is then a sliver forced by the input (``left``
  names it ``fold``).
* **Batches.** Subface centres split in one round are kept at least
  ``separation`` times their circumradius apart (two neighbouring subfaces
  of nearly one circle gave points 1e-4 apart at size 0.125, and with them
  Poisson convergence of rate 1).
* **Thin parts: feature size first.** Lazy refinement of a thin slab
  (1 x 1 x 0.01) cascaded: the bad tetrahedra lay along the side strips,
  their centres encroached the rim subsegments and the strips, which were
  split again and again (edges down to h/70, over 50k points, not finished
  in 300 s), while the large faces, whose subfaces every such centre also
  encroached, stayed two triangles. Now a facet whose local feature size
  (:func:`_feature_sizes`: the distance from its corners to the nearest
  facet sharing no vertex with it) is below ``thin`` (1/4) of its shortest
  edge is first refined to ``feature_size`` (2) times it: the slab's faces
  get the thickness's scale, and the refinement ends (24k tetrahedra, 1.3
  CPU s, every ratio at most 2). On the other test shapes (cube,
  icosphere, tori, cavity box, L-block) no facet is thin: nothing changes.
  Refining every facet to its feature size (no ``thin`` filter) would split
  half the edges of a torus, whose tube is narrower than twice its long
  edges, and only add points.
* **Thin facets far above their size** (:mod:`meshcore.tets.seeding`): with
  a uniform size (``size`` and the feature size above, the smaller), a thin
  facet whose largest subface is over 3 times the bound gets a triangular
  lattice of 0.9 times its size in one batch, the rounds then only
  finishing the band along its boundary (the thin plate at size 0.00616:
  36 rounds -> 15). Other facets are refined as before: on the cube minus
  a ball at 100k the seeded faces' later rounds retriangulated them whole
  more often (31 retriangulations against 18) and took longer.
* **Small input angles** (:mod:`meshcore.tets.angles`): subsegments at
  one input vertex are split on concentric shells; a *sharp* input vertex
  (features meeting below ``Knobs.small_angle``, 60 degrees, or a dihedral
  angle below ``Knobs.sharp_dihedral``, 85) gets a protecting ball (the
  shells stop at its sphere, facet split points inside it are moved onto
  it, no interior point goes in it); a *sharp* input edge (dihedral angle
  below ``Knobs.sharp_edge``, 70, or above 360 minus it) gets a protecting
  cylinder (no interior point in it, no subface split for encroachment at a
  circumcentre in it). The rule for what is left: a bad
  tetrahedron is not refined when its circumcentre lies in a protecting
  ball or cylinder, or when its shortest edge joins two different
  input features meeting at an input vertex or segment at an angle below
  60 degrees (15 between two segments of one facet) -- skinny because of
  the input (Shewchuk 1998); ``left`` counts them as ``input_angle`` and
  ``left["input_angles"]`` names each vertex or segment. Pieces smaller
  than ``protect`` times their input edge are still not split and the
  rounds are capped (``Knobs``); what that leaves is ``given_up`` and,
  by cause, ``left``.

References
----------
Methods text §9.2 (Delaunay-admissible segments in R^3, the ball B_AB),
§9.3 (faces: Case 1, empty B_f^min, is Delaunay; §9.3.4 edges first, then
faces; §9.3.5 new points on the surface), §9.5 (the empty
tetrahedralization of the surface points); J. R. Shewchuk, "Tetrahedral
Mesh Generation by Delaunay Refinement" (SoCG 1998); H. Si, "TetGen"
(ACM TOMS 2015) for the ``-q`` radius-edge convention.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.csgraph import connected_components

from meshcore.delaunay.kernel3d import SKIP_OUTSIDE
from meshcore.delaunay.recovery3d import (
    KNOBS,
    TET_EDGES,
    TET_FACES,
    SurfaceRecovery,
    ball_pairs,
    face_keys,
    face_rows,
    member,
    recover,
    tet_circumcenters,
)
from meshcore.delaunay.regions3d import RegionLabels, fresh_rows, regions
from meshcore.domain.surface import as_surface
from meshcore.errors import AlgorithmError, InputError, positive_parameter
from meshcore.geometry.predicates3d import orient3d
from meshcore.limits import MIN_RADIUS_EDGE
from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.topology import unique_ints
from meshcore.tets.angles import (
    held_by_cylinders,
    input_forced,
    protecting_balls,
    protecting_cylinders,
)
from meshcore.tets.keep import flip_slivers, lift_surface_points
from meshcore.tets.seeding import far_facets, seed_facets
from meshcore.tets.sizing import SizeField3d

__all__ = [
    "TetrahedralizationResult",
    "tetrahedralize",
    "tetra_dihedral_angles",
    "tetra_radius_edge",
]


_TET_FACES = TET_FACES.copy()
_TET_EDGES = TET_EDGES.copy()


@dataclass(frozen=True, eq=False)
class TetrahedralizationResult:
    """What :func:`tetrahedralize` returns.

    Attributes
    ----------
    mesh : Mesh
        3D points and one ``tetra`` block, positively oriented (meshio's
        order: ``orient3d(p0, p1, p2, p3) < 0`` in Shewchuk's sign, i.e. a
        positive signed volume ``(p1 - p0) . ((p2 - p0) x (p3 - p0)) / 6``).
        The surface's vertices come first, in increasing input index, then
        the points added. Cell sets ``region_k`` per region of the surface.
    region : (m,) int64
        The region of each tetrahedron (``Surface.shell_region`` numbering).
    boundary_faces : (k, 3) int64
        The mesh faces on the surface, oriented outward (out of the region).
    boundary_source : (k,) int64
        The input triangle each boundary face lies in (the one holding its
        centroid: a face of a facet merged from coplanar input triangles may
        straddle their common edge).
    triangle_facet : (t,) int64
        The facet of each input triangle: input triangles joined across
        edges whose four points are exactly coplanar form one facet, meshed
        as one polygon (the edges inside it are no constraints). The
        boundary faces of a facet tile exactly the union of its triangles.
    surface_points_added, interior_points_added : int
    rounds : int
        Recovery plus refinement rounds.
    given_up : int
        Bad tetrahedra left (their circumcentre could not be used, or the
        round cap was reached).
    left : dict
        The tetrahedra of the result above ``max_radius_edge``
        (``radius_edge_above``) and below ``min_dihedral``
        (``dihedral_below``), counted by cause: ``fold`` (two of its faces
        on the surface: it fills the angle between two facets, which the
        input forces when that angle is near 180 degrees, e.g. two input
        triangles coplanar up to rounding), ``input_angle`` (skinny because
        of a small input angle, a fold there included, or left because the
        subface its circumcentre encroaches lies in a sharp edge's protecting
        cylinder, :mod:`meshcore.tets.angles`; where, in
        ``input_angles``: the input vertex or segment and how many
        tetrahedra), ``surface`` (four vertices on the surface, its centre
        encroaching pieces too small to split), ``interior``; and the ten
        worst by least dihedral angle (row in ``tetra``, cause, angle, ratio).
    timings : dict
        Seconds per phase.
    """

    mesh: Mesh
    region: np.ndarray
    boundary_faces: np.ndarray
    boundary_source: np.ndarray
    triangle_facet: np.ndarray
    surface_points_added: int
    interior_points_added: int
    rounds: int
    given_up: int
    left: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Geometry helpers (constructions, rounded)
# ---------------------------------------------------------------------------


def tetra_radius_edge(points: np.ndarray, tetra: np.ndarray) -> np.ndarray:
    """Circumradius over shortest edge of each tetrahedron: the ratio that
    :func:`tetrahedralize`'s ``max_radius_edge`` bounds.

    Parameters
    ----------
    points : (n, 3) float64
    tetra : (m, 4) int64

    Returns
    -------
    (m,) float64
        At least sqrt(6) / 4 (the regular tetrahedron's); not finite for a flat
        tetrahedron (float constructions, as
        :func:`~meshcore.delaunay.recovery3d.tet_circumcenters`).

    References
    ----------
    Shewchuk (1998)'s refinement measure, TetGen's ``-q``; methods text §9.5.
    """
    d = points[tetra[:, TET_EDGES[:, 0]]] - points[tetra[:, TET_EDGES[:, 1]]]
    _, R = tet_circumcenters(points, tetra)
    return R / np.sqrt(np.einsum("ijk,ijk->ij", d, d).min(axis=1))


def _volumes(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Unsigned volumes of tetrahedra (constructions)."""
    a = P[T[:, 0]]
    return (
        np.abs(np.einsum("ij,ij->i", P[T[:, 1]] - a, np.cross(P[T[:, 2]] - a, P[T[:, 3]] - a)))
        / 6.0
    )


def tetra_dihedral_angles(points: np.ndarray, tetra: np.ndarray) -> np.ndarray:
    """The six dihedral angles of each tetrahedron, in degrees.

    Parameters
    ----------
    points : (n, 3) float64
    tetra : (m, 4) int64

    Returns
    -------
    (m, 6) float64
        The angle between the two faces at each edge, edges in the order
        01, 02, 03, 12, 13, 23 (70.53 degrees for all six of a regular
        tetrahedron). A flat tetrahedron has angles 0 and 180.

    References
    ----------
    Quality of tetrahedra (DESIGN.md "Quality measures"); the least dihedral
    angle is TetGen's and Gmsh's sliver measure.
    """
    P = np.asarray(points, dtype=np.float64)
    T = np.asarray(tetra, dtype=np.int64)
    # Face normals (outward), opposite each vertex.
    n = []
    for i in range(4):
        f = T[:, TET_FACES[i]]
        a = P[f[:, 0]]
        nrm = np.cross(P[f[:, 1]] - a, P[f[:, 2]] - a)
        norm = np.linalg.norm(nrm, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            n.append(nrm / norm[:, None])
    out = np.empty((len(T), 6))
    for k, (i, j) in enumerate(TET_EDGES.tolist()):
        # The edge ij is shared by the faces opposite the two other vertices.
        p, q = (x for x in range(4) if x not in (i, j))
        cos = -np.einsum("ij,ij->i", n[p], n[q])
        out[:, k] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return np.nan_to_num(out, nan=0.0)


def _point_triangle_distance(X, A, B, C) -> np.ndarray:
    """Distance from each point X[i] to the triangle (A[i], B[i], C[i]) (constructions).

    The closest point by the Voronoi regions of the triangle's corners,
    edges and interior (Ericson, "Real-Time Collision Detection", 5.1.5).
    """

    def dot(u, v):
        return np.einsum("ij,ij->i", u, v)

    ab, ac = B - A, C - A
    d1, d2 = dot(ab, X - A), dot(ac, X - A)
    d3, d4 = dot(ab, X - B), dot(ac, X - B)
    d5, d6 = dot(ab, X - C), dot(ac, X - C)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = (d1 / (d1 - d3))[:, None]
        t_ac = (d2 / (d2 - d6))[:, None]
        t_bc = ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None]
        v = (vb / (va + vb + vc))[:, None]
        w = (vc / (va + vb + vc))[:, None]
    Q = np.select(
        [
            ((d1 <= 0) & (d2 <= 0))[:, None],
            ((d3 >= 0) & (d4 <= d3))[:, None],
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0))[:, None],
            ((d6 >= 0) & (d5 <= d6))[:, None],
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0))[:, None],
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[:, None],
        ],
        [A, B, A + t_ab * ab, C, A + t_ac * ac, B + t_bc * (C - B)],
        A + v * ab + w * ac,
    )
    return np.linalg.norm(X - Q, axis=1)


def _feature_sizes(b: SurfaceRecovery) -> np.ndarray:
    """A local feature size of each facet (inf where none is near).

    The least distance from one of the facet's corners to an input triangle
    of a facet that shares no vertex with it (the two faces of a thin slab
    ``h`` thick: ``h``, however long their edges); only triangles within
    twice their longest edge of the corner are looked at, since the size
    matters only below the local edge lengths. This is Ruppert's and
    Shewchuk's local feature size (the distance to the nearest feature not
    incident to the point) at the input vertices, between facets.
    Constructions (float).
    """
    F, P, grp = b.facets, b.P, b.group
    n_g = len(b.group_tris)
    out = np.full(n_g, np.inf)
    a, bb, c = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    longest = np.maximum.reduce(
        [np.linalg.norm(bb - a, axis=1), np.linalg.norm(c - bb, axis=1),
         np.linalg.norm(a - c, axis=1)]
    )  # fmt: skip
    vi, ti = ball_pairs(P[: b.n_surface], (a + bb + c) / 3.0, 2.0 * longest)
    if vi.size == 0:
        return out
    # Vertex-facet incidence, and facets sharing a vertex (keys g * n_g + h).
    inc = sp.csr_matrix(
        (np.ones(F.size), (np.repeat(grp, 3), F.reshape(-1))), shape=(n_g, b.n_surface)
    )
    inc.data[:] = 1.0
    near = (inc @ inc.T).tocoo()
    touching = np.sort(near.row.astype(np.int64) * n_g + near.col)
    # Each pair (corner v, triangle t) for every facet g at v, kept when g and
    # t's facet share no vertex.
    vg = inc.T.tocsr()
    vg.sort_indices()
    counts = np.diff(vg.indptr)[vi]
    rep = np.repeat(np.arange(len(vi)), counts)
    offset = np.arange(len(rep)) - np.repeat(np.cumsum(counts) - counts, counts)
    g = vg.indices[np.repeat(vg.indptr[vi], counts) + offset].astype(np.int64)
    keep = ~member(g * n_g + grp[ti[rep]], touching)
    g, rep = g[keep], rep[keep]
    if g.size == 0:
        return out
    pairs = rep[np.concatenate([[True], rep[1:] != rep[:-1]])]  # rep is sorted
    d = np.full(len(vi), np.inf)
    d[pairs] = _point_triangle_distance(P[vi[pairs]], a[ti[pairs]], bb[ti[pairs]], c[ti[pairs]])
    np.minimum.at(out, g, d[rep])
    return out


# ---------------------------------------------------------------------------
# Keys of edges and faces
# ---------------------------------------------------------------------------


# ---------------------------------------------------------------------------
# The builder: the kernel, the surface's pieces, the points
# ---------------------------------------------------------------------------


# ---------------------------------------------------------------------------
# Phases
# ---------------------------------------------------------------------------


def _boundary_face_count(
    b: SurfaceRecovery, T: np.ndarray, sub: np.ndarray | None = None
) -> np.ndarray:
    """How many faces of each tetrahedron are subfaces (of ``b``, or ``sub``)."""
    if len(T) == 0:
        return np.zeros(0, dtype=np.int64)
    return (face_rows(T, b.sub if sub is None else sub) >= 0).sum(axis=1)


def _flat_folds(b: SurfaceRecovery, T: np.ndarray) -> np.ndarray:
    """Tetrahedra on a fold of two facets coplanar up to rounding (a mask).

    Two of its faces are subfaces and its least dihedral angle is below
    ``flat_fold`` degrees: the four corners of a planar quadrilateral whose
    coordinates are not exactly coplanar (a torus's trapezoids). No point
    can improve it; it is kept out of the refinement and, at the end, out
    of the mesh (:func:`_drop_flat_folds`, before the sliver improvement). (Refining
    it split its subfaces, whose new points made new flat folds: on the
    32 x 16 torus 830 of the 938 points added, and a cascade once the splits
    were made lazy, :func:`_insert_interior`.)
    """
    out = np.zeros(len(T), dtype=bool)
    # Two subfaces cover the four corners: only tetrahedra with every corner on the
    # surface are looked up.
    rows = np.flatnonzero(b.on_surface()[T].all(axis=1)) if len(T) else np.zeros(0, np.int64)
    rows = rows[_boundary_face_count(b, T[rows]) >= 2]
    if rows.size:
        out[rows] = _least_dihedral(b.P, T[rows]) < b.knobs.flat_fold
    return out


def _drop_flat_folds(b: SurfaceRecovery, T: np.ndarray, region: np.ndarray):
    """Remove the flat fold tetrahedra; the surface takes their two other faces.

    The boundary moves by the tetrahedron's volume (rounding: its corners
    are coplanar up to rounding); the two input triangles and the two new
    faces tile the same quadrilateral, so their facets are reported as one
    (``triangle_facet``). Returns (tetra, region, subfaces, sources, facet
    of each input triangle).
    """
    src = b.sources()
    flat = _flat_folds(b, T)
    facet = b.group
    if not flat.any():
        return T, region, b.sub, src, facet
    drop = T[flat]
    fk = face_keys(drop[:, TET_FACES].reshape(-1, 3))
    sk = face_keys(b.sub)
    order = np.argsort(sk)
    is_sub = member(fk, sk[order])
    pos = np.minimum(np.searchsorted(sk[order], fk), len(sk) - 1)
    gone = order[pos[is_sub]]  # the subfaces the dropped tetrahedra hold
    faces = drop[:, TET_FACES].reshape(-1, 3)[~is_sub][:, ::-1]  # out of the region
    owner = np.repeat(np.arange(len(drop)), 4)
    first_sub = order[pos].reshape(-1, 4)[np.arange(len(drop)), np.argmax(is_sub.reshape(-1, 4), 1)]
    new_src = src[first_sub][owner[~is_sub]]
    keep = np.ones(len(b.sub), dtype=bool)
    keep[gone] = False
    # The facets of each dropped tetrahedron's subfaces are reported as one.
    g = b.sub_facet[gone].reshape(-1, 2)
    n_g = len(b.group_tris)
    graph = sp.csr_matrix((np.ones(len(g)), (g[:, 0], g[:, 1])), shape=(n_g, n_g))
    _, merged = connected_components(graph, directed=False)
    return (
        T[~flat],
        region[~flat],
        np.concatenate([b.sub[keep], faces]),
        np.concatenate([src[keep], new_src]),
        merged[facet],
    )


def _left_report(
    b: SurfaceRecovery,
    T: np.ndarray,
    sub: np.ndarray,
    max_radius_edge,
    min_dihedral,
    improved: dict | None = None,
) -> dict:
    """The tetrahedra left above ``max_radius_edge`` or below ``min_dihedral``, and why;
    with the sliver stage's counts ``improved`` as ``improvement``, where
    ``radius_edge_traded`` counts the tetrahedra of circumradius above ``max_radius_edge``
    times their shortest edge (0 without a finite bound).

    Causes: ``fold`` (two faces on the surface: the tetrahedron fills the
    angle between two facets, forced by the input where that angle is near
    180 degrees or small), ``input_angle`` (skinny because of a small input
    angle, :func:`meshcore.tets.angles.input_forced`; ``input_angles`` lists
    where: the input vertex or segment, input numbering, and how many
    tetrahedra), ``surface`` (its four vertices on the surface, its
    circumcentre encroaching a subface too small to split), ``interior``
    (the round cap was reached).
    """
    c, R, short, cos = _measured(b.P, T)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = R / short
    ratio = np.where(np.isfinite(ratio), ratio, np.inf)
    dih = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    on_surface = np.ones(b.n, dtype=bool)
    on_surface[b.n_surface :] = (b.pt_edge[b.n_surface :] >= 0) | (b.pt_facet[b.n_surface :] >= 0)
    folds = _boundary_face_count(b, T, sub) >= 2
    surf = ~folds & on_surface[T].all(axis=1)
    cause = np.where(folds, 0, np.where(surf, 1, 2))
    # Skinny because of a small input angle (``meshcore.tets.angles``), named by place.
    bad = np.zeros(len(T), dtype=bool)
    if max_radius_edge:
        bad |= ratio > max_radius_edge
    if min_dihedral:
        bad |= dih < min_dihedral
    # A fold at a small input angle (its circumcentre in a protecting ball or
    # cylinder) is skinny because of that angle: it is named with it.
    rows = np.flatnonzero(bad)
    forced, where = input_forced(b, T[rows], c[rows])
    # Left because the subface its circumcentre encroaches lies by a sharp edge.
    rest = np.flatnonzero(~forced)
    held = held_by_cylinders(b, c[rows[rest]])
    for r, e in zip(rest[held >= 0].tolist(), held[held >= 0].tolist(), strict=True):
        forced[r] = True
        where[r] = sorted(int(v) for v in b.edges[e])
    cause[rows[forced]] = 3
    places: dict = {}
    for w in (w for w, f in zip(where, forced, strict=True) if f):
        key = tuple(int(b.source[z]) for z in w)
        places[key] = places.get(key, 0) + 1
    names = ("fold", "surface", "interior", "input_angle")
    out: dict = {
        "input_angles": [
            {"vertex" if len(k) == 1 else "segment": list(k) if len(k) > 1 else k[0],
             "tetrahedra": n}
            for k, n in sorted(places.items())
        ]
    }  # fmt: skip
    for key, bad in (
        ("radius_edge_above", ratio > max_radius_edge if max_radius_edge else None),
        ("dihedral_below", dih < min_dihedral if min_dihedral else None),
    ):
        if bad is None:
            continue
        out[key] = {n: int((bad & (cause == k)).sum()) for k, n in enumerate(names)}
    # A stable argsort's first ten (ties by index), without sorting every angle.
    worst = np.arange(len(dih))
    if len(dih) > 10:
        worst = np.flatnonzero(dih <= np.partition(dih, 9)[9])
    worst = worst[np.argsort(dih[worst], kind="stable")][:10]
    out["worst"] = [
        {
            "tetrahedron": int(t),
            "cause": names[int(cause[t])],
            "min_dihedral": round(float(dih[t]), 4),
            "radius_edge": round(float(ratio[t]), 4) if np.isfinite(ratio[t]) else None,
        }
        for t in worst.tolist()
    ]
    if improved is not None:
        traded = 0
        if max_radius_edge and math.isfinite(max_radius_edge):
            traded = int((R > max_radius_edge * short).sum())
        out["improvement"] = {**improved, "radius_edge_traded": traded}
    return out


class _SizeMap:
    """The target edge length at points ``X`` (``(k, 3) -> (k,)``): the smaller of
    ``size`` and the size field's value there; ``uniform`` is ``size`` when no field
    is given (None otherwise)."""

    def __init__(self, size: float | None, field: SizeField3d | None) -> None:
        self.size = size
        self.field = field
        self.uniform = size if field is None else None

    def __call__(self, X: np.ndarray) -> np.ndarray:
        if self.field is None:
            return np.full(len(X), self.size)
        if self.size is None:
            return self.field(X)
        return np.minimum(self.field(X), self.size)

    def at(self, where: Callable[[], np.ndarray]) -> float | np.ndarray:
        """``self(where())``, or just the uniform size (the points not computed)."""
        return self.uniform if self.uniform is not None else self(where())


def _size_map(size: float | None, field: SizeField3d | None) -> _SizeMap | None:
    """The size map of ``size`` and ``size_field``; None when neither is given."""
    if size is None and field is None:
        return None
    return _SizeMap(size, field)


@njit(cache=True, error_model="numpy")
def _circumsphere(P, T, t):
    """(offset of the circumcentre from ``P[T[t, 0]]``, circumradius, determinant) of
    tetrahedron ``t``: the floating-point operations of
    :func:`~meshcore.delaunay.recovery3d.tet_circumcenters` (numpy's ``einsum`` adds three
    products ``p`` as ``(p0 + p2) + p1``: so do the sums here)."""
    i0, i1, i2, i3 = T[t, 0], T[t, 1], T[t, 2], T[t, 3]
    ax, ay, az = P[i0, 0], P[i0, 1], P[i0, 2]
    ux, uy, uz = P[i1, 0] - ax, P[i1, 1] - ay, P[i1, 2] - az
    vx, vy, vz = P[i2, 0] - ax, P[i2, 1] - ay, P[i2, 2] - az
    wx, wy, wz = P[i3, 0] - ax, P[i3, 1] - ay, P[i3, 2] - az
    vwx, vwy, vwz = vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx
    wux, wuy, wuz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
    uvx, uvy, uvz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    det = (ux * vwx + uz * vwz) + uy * vwy
    den = 2.0 * det
    uu = (ux * ux + uz * uz) + uy * uy
    vv = (vx * vx + vz * vz) + vy * vy
    ww = (wx * wx + wz * wz) + wy * wy
    ox = (uu * vwx + vv * wux + ww * uvx) / den
    oy = (uu * vwy + vv * wuy + ww * uvy) / den
    oz = (uu * vwz + vv * wuz + ww * uvz) / den
    return ox, oy, oz, math.sqrt((ox * ox + oz * oz) + oy * oy), det


@njit(cache=True)
def _shortest2(P, T, t):
    """Squared shortest edge of tetrahedron ``t`` (the float operations of
    :func:`tetra_radius_edge`'s shortest edge, before its root)."""
    short = np.inf
    for k in range(6):
        a = T[t, _TET_EDGES[k, 0]]
        b = T[t, _TET_EDGES[k, 1]]
        dx = P[a, 0] - P[b, 0]
        dy = P[a, 1] - P[b, 1]
        dz = P[a, 2] - P[b, 2]
        short = min(short, (dx * dx + dz * dz) + dy * dy)
    return short


@njit(cache=True, error_model="numpy")
def _measures(P, T, max_radius_edge, max_volume, size_radius, size, C, R):
    """Circumcentres ``C`` and circumradii ``R`` of tetrahedra ``T``, and which are bad.

    One pass, the floating-point operations of
    :func:`~meshcore.delaunay.recovery3d.tet_circumcenters`, :func:`tetra_radius_edge` and
    :func:`_volumes`. Bad: circumradius above
    ``max_radius_edge`` times the shortest edge, volume above ``max_volume``,
    circumradius above ``size_radius * size`` (``size`` NaN: none), or too flat
    for a float circumcentre (its centroid in ``C`` and an infinite ``R`` then).
    """
    m = T.shape[0]
    bad = np.empty(m, np.bool_)
    for t in range(m):
        ox, oy, oz, r, det = _circumsphere(P, T, t)
        is_bad = r > max_radius_edge * math.sqrt(_shortest2(P, T, t))
        is_bad |= abs(det) / 6.0 > max_volume
        i0 = T[t, 0]
        if math.isfinite(r):
            C[t, 0], C[t, 1], C[t, 2] = P[i0, 0] + ox, P[i0, 1] + oy, P[i0, 2] + oz
        else:
            for k in range(3):
                C[t, k] = (((P[i0, k] + P[T[t, 1], k]) + P[T[t, 2], k]) + P[T[t, 3], k]) / 4.0
            r = np.inf
            is_bad = True
        R[t] = r
        bad[t] = is_bad | (r > size_radius * size)
    return bad


@njit(cache=True, error_model="numpy")
def _shapes(P, T, C, R, S, D):
    """Circumcentres ``C`` and radii ``R`` (as
    :func:`~meshcore.delaunay.recovery3d.tet_circumcenters`), shortest edges ``S`` (as
    :func:`tetra_radius_edge`) and the cosine ``D`` of the least dihedral angle (1 where a face
    is degenerate) of tetrahedra ``T``, one pass."""
    nrm = np.empty((4, 3))
    for t in range(T.shape[0]):
        ox, oy, oz, r, _ = _circumsphere(P, T, t)
        i0 = T[t, 0]
        C[t, 0], C[t, 1], C[t, 2] = P[i0, 0] + ox, P[i0, 1] + oy, P[i0, 2] + oz
        R[t] = r
        S[t] = math.sqrt(_shortest2(P, T, t))
        D[t] = _least_dihedral_cos(P, T, t, nrm)


@njit(cache=True, error_model="numpy")
def _least_dihedral_cos(P, T, t, nrm):
    """The largest cosine of the six dihedral angles of tetrahedron ``t``, the operations
    of :func:`tetra_dihedral_angles` (1.0 where one is NaN: its angle counts as 0)."""
    for i in range(4):
        a = T[t, _TET_FACES[i, 0]]
        b = T[t, _TET_FACES[i, 1]]
        c = T[t, _TET_FACES[i, 2]]
        ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
        vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        L = math.sqrt((nx * nx + ny * ny) + nz * nz)
        nrm[i, 0], nrm[i, 1], nrm[i, 2] = nx / L, ny / L, nz / L
    best = -np.inf
    for k in range(6):
        i, j = _TET_EDGES[k, 0], _TET_EDGES[k, 1]
        p = -1
        q = -1
        for x in range(4):
            if x != i and x != j:
                if p < 0:
                    p = x
                else:
                    q = x
        cos = -((nrm[p, 0] * nrm[q, 0] + nrm[p, 2] * nrm[q, 2]) + nrm[p, 1] * nrm[q, 1])
        if math.isnan(cos):
            return 1.0
        best = max(best, cos)
    return best


def _measured(P: np.ndarray, T: np.ndarray) -> tuple:
    """(circumcentres, circumradii, shortest edges, cosines of the least dihedral angles)
    of tetrahedra ``T``: :func:`_shapes` in one compiled pass, without temporaries."""
    T = np.ascontiguousarray(T, dtype=np.int64)
    m = len(T)
    C, R, S, D = np.empty((m, 3)), np.empty(m), np.empty(m), np.empty(m)
    _shapes(P, T, C, R, S, D)
    return C, R, S, D


@njit(cache=True, error_model="numpy")
def _least_dihedral_cosines(P, T, D):
    """``D`` of :func:`_shapes` alone (no circumspheres)."""
    nrm = np.empty((4, 3))
    for t in range(T.shape[0]):
        D[t] = _least_dihedral_cos(P, T, t, nrm)


def _least_dihedral(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(m,) degrees: ``tetra_dihedral_angles(P, T).min(axis=1)``, in one compiled pass."""
    D = np.empty(len(T))
    _least_dihedral_cosines(P, np.ascontiguousarray(T, dtype=np.int64), D)
    return np.degrees(np.arccos(np.clip(D, -1.0, 1.0)))


class _BadTets:
    """The bad tetrahedra of each refinement round, kept by slot between rounds.

    Only the tetrahedra with a vertex added since the last round (every
    tetrahedron an insertion creates holds the new point) are measured
    (:func:`_measures`); the others keep their circumcentre, radius and
    verdict, since the points never move and the bounds are fixed.
    """

    def __init__(self, max_radius_edge, max_volume, size_at, knobs) -> None:
        self.bounds = (max_radius_edge, math.inf if max_volume is None else max_volume)
        self.size_at = size_at
        self.knobs = knobs
        self.n = 0
        self.C = np.zeros((0, 3))
        self.R = np.zeros(0)
        self.bad = np.zeros(0, dtype=bool)

    def __call__(self, P, slots, T, inside) -> tuple[np.ndarray, np.ndarray]:
        """Rows of ``inside`` (rows of ``T``) whose tetrahedron is bad, and their
        circumcentres, worst (largest radius) first.

        A tetrahedron too flat for its float circumcentre (positive by the
        exact sign, zero in float) is bad; its centroid is inserted instead.
        """
        fresh = fresh_rows(T, self.n)
        top = int(slots.max()) + 1 if len(slots) else 0
        if top > len(self.R):
            extra = max(top, 2 * len(self.R)) - len(self.R)
            self.C = np.concatenate([self.C, np.zeros((extra, 3))])
            self.R = np.concatenate([self.R, np.zeros(extra)])
            self.bad = np.concatenate([self.bad, np.zeros(extra, dtype=bool)])
        m = len(fresh)
        C, R = np.empty((m, 3)), np.empty(m)
        size_at = self.size_at
        uniform = math.nan if size_at is None or size_at.uniform is None else size_at.uniform
        bad = _measures(P, T[fresh], *self.bounds, self.knobs.size_radius, uniform, C, R)
        if size_at is not None and size_at.uniform is None:
            bad |= R > self.knobs.size_radius * size_at(C)
        s = slots[fresh]
        self.C[s], self.R[s], self.bad[s] = C, R, bad
        self.n = len(P)
        si = slots[inside]
        rows = np.flatnonzero(self.bad[si])
        rows = rows[np.argsort(-self.R[si[rows]], kind="stable")]
        return rows, self.C[si[rows]]


def _insert_interior(
    b: SurfaceRecovery, slots, region, rows, centres, tets, oversized
) -> tuple[int, int]:
    """Insert circumcentres of tetrahedra ``rows``, or split what they encroach, and
    split subfaces ``oversized``.

    ``slots`` and ``region`` (per tetrahedron row) describe the structure at
    the start of the round. A circumcentre that encroaches a subsegment or a
    subface is not inserted; the others are inserted one at a time, in the
    given order, skipping those whose tetrahedron an earlier insertion
    destroyed and those that do not fall in a tetrahedron of the mesh
    (outside the regions). Only then are the surface pieces split that the
    rejected centres encroach, and only for the tetrahedra still alive
    (the lazy queue applied to the splits too: on the 32 x 16 torus the
    first round's 13 interior points destroy 1,560 of its 1,697 bad
    tetrahedra, and splitting for all of them put 364 points on the
    surface). Returns (points inserted or splits made, candidates skipped
    as outside or given up).
    """
    n_c = len(rows)
    z = np.zeros(0, dtype=np.int64)
    blocked = np.zeros(n_c, dtype=bool)
    # (candidate, piece) pairs to split if the candidate's tetrahedron survives;
    # ``held``: candidates whose only encroached pieces are protected.
    seg_pairs, sub_pairs = (z, z), (z, z)
    splits = np.zeros(n_c, dtype=bool)
    held = np.zeros(n_c, dtype=bool)

    def encroaching(idx: np.ndarray) -> None:
        """Block candidates ``idx`` that encroach a subsegment or a subface."""
        nonlocal seg_pairs, sub_pairs
        xi, si = b.encroached_segments(centres[idx])
        xi = idx[xi]
        if si.size:
            guard = b.protected_segments(si)
            blocked[xi] = True
            splits[xi[~guard]] = True
            held[xi[guard]] = True
            seg_pairs = (
                np.concatenate([seg_pairs[0], xi[~guard]]),
                np.concatenate([seg_pairs[1], si[~guard]]),
            )
        if len(b.sub):
            xf, fi = b.encroached_subfaces(centres[idx])
            xf = idx[xf]
            if fi.size:
                guard = b.protected_subfaces(fi)
                fresh = ~splits[xf]  # a subsegment first, as Shewchuk's rule orders them
                blocked[xf] = True
                new = (xf[~guard & fresh], fi[~guard & fresh])
                sub_pairs = (
                    np.concatenate([sub_pairs[0], new[0]]),
                    np.concatenate([sub_pairs[1], new[1]]),
                )
                held[xf[guard & fresh]] = True
                splits[new[0]] = True

    encroaching(np.arange(n_c))
    # No interior point inside a protecting ball or cylinder (``meshcore.tets.angles``).
    ball = (b.in_balls(centres) >= 0) | (b.in_cylinders(centres) >= 0)
    held |= ball & ~splits
    blocked |= ball
    # Far circumcentres (of nearly flat tetrahedra) lie outside the surface's box:
    # outside every region.
    lo, hi = b.P[: b.n_surface].min(axis=0), b.P[: b.n_surface].max(axis=0)
    far = ~((centres >= lo) & (centres <= hi)).all(axis=1) & ~blocked
    if far.any():
        # Such a tetrahedron leans on the surface: split its faces that are
        # subfaces (Shewchuk's rule for a circumcentre beyond a subface), or
        # insert its centroid when it has none.
        idx = np.flatnonzero(far)
        faces = tets[rows[idx]][:, TET_FACES].reshape(-1, 3)
        fk = face_keys(faces)
        sk = face_keys(b.sub)
        order = np.argsort(sk)
        pos = np.minimum(np.searchsorted(sk[order], fk), len(sk) - 1)
        hit = sk[order][pos] == fk
        leaning = hit.reshape(-1, 4).any(axis=1)
        cand = np.repeat(idx, 4)[hit]
        sub_rows = order[pos[hit]]
        guard = b.protected_subfaces(sub_rows)
        sub_pairs = (
            np.concatenate([sub_pairs[0], cand[~guard]]),
            np.concatenate([sub_pairs[1], sub_rows[~guard]]),
        )
        held[idx[leaning]] = True
        lone = idx[~leaning]
        centres[lone] = b.P[tets[rows[lone]]].mean(axis=1)
        far[lone] = False
        # The centroid obeys the circumcentre's rule: it splits what it encroaches
        # (inserted next to a subface, it made flat tetrahedra whose centroids
        # went nearer still: 59,429 of them on star seed 1046).
        encroaching(lone)
        inb = (b.in_balls(centres[lone]) >= 0) | (b.in_cylinders(centres[lone]) >= 0)
        held[lone[inb]] = True
        blocked[lone[inb]] = True
    keep = ~blocked & ~far
    allowed = np.zeros(int(slots.max()) + 1, dtype=bool)
    allowed[slots] = region >= 0
    # One compiled loop: each insertion may destroy later candidates' tetrahedra.
    out = b.dt.insert_guarded(centres[keep], slots[rows[keep]], allowed)
    new = out >= 0
    done = int(new.sum())
    outside = int((out == SKIP_OUTSIDE).sum())
    if done:
        b.P = np.concatenate([b.P, centres[keep][new]])
        b.pt_edge = np.concatenate([b.pt_edge, np.full(done, -1, dtype=np.int64)])
        b.pt_facet = np.concatenate([b.pt_facet, np.full(done, -1, dtype=np.int64)])
        b.n += done
        b.interior_added += done
    # The rejected candidates whose tetrahedron is still there (a reused slot
    # holds a new vertex) split what they encroach.
    rej = np.flatnonzero(~keep)
    alive = np.zeros(n_c, dtype=bool)
    if rej.size:
        now = np.sort(b.dt.tets(slots[rows[rej]]), axis=1)
        alive[rej] = (now == np.sort(tets[rows[rej]], axis=1)).all(axis=1)
    outside += int((held & alive & ~splits).sum())
    # The facets the subsegment splits touch are retriangulated with the subface
    # splits: a retriangulation renumbers ``b.sub``, and ``sub_pairs`` name rows of it.
    touched: list = []
    done += b.split_segments(seg_pairs[1][alive[seg_pairs[0]]], touched)
    n_sub, n_seg = b.split_subfaces(
        np.concatenate([sub_pairs[1][alive[sub_pairs[0]]], oversized]), touched
    )
    return done + n_sub + n_seg, outside


def _refine(b: SurfaceRecovery, region_of: RegionLabels, bad_tets: _BadTets, progress):
    """Delaunay refinement rounds; returns (rounds, bad tetrahedra left).

    ``region_of`` and ``bad_tets`` are kept between rounds: each round measures only
    what was created since the last.
    """
    size_at = bad_tets.size_at
    seeded = np.zeros(len(b.facet_size), dtype=bool)
    rounds = 0
    left = 0
    for rounds in range(1, b.knobs.refinement_rounds + 1):
        if b.n >= b.knobs.max_points:
            raise AlgorithmError(
                f"the refinement reached its limit of {b.knobs.max_points:,} points before "
                "the tetrahedra met the bounds; ask for a larger size, size_field or max_volume",
                code="too_many_points",
            )
        # Missing subsegments first (with the subfaces that then go missing); missing
        # subfaces alone are split with the round's oversized ones below, in one
        # batch (a retriangulation of their facets each, not one round apiece).
        seg_missing, sub_missing = b.missing()
        if seg_missing.size:
            recover(b, None)
            sub_missing = seg_missing[:0]
        if b.knobs.eager:
            seg_bad, sub_bad = b.encroached_by_vertices()
            seg_bad = seg_bad[~b.protected_segments(seg_bad)]
            sub_bad = sub_bad[~b.protected_subfaces(sub_bad)]
        else:
            seg_bad = sub_bad = np.zeros(0, dtype=np.int64)
        # The size bound and each facet's feature size (``_feature_sizes``).
        cap = b.segment_size(np.arange(len(b.seg)))
        if size_at is not None:
            cap = np.minimum(cap, size_at.at(lambda: 0.5 * (b.P[b.seg[:, 0]] + b.P[b.seg[:, 1]])))
        L = np.linalg.norm(b.P[b.seg[:, 0]] - b.P[b.seg[:, 1]], axis=1)
        long = np.flatnonzero((L > cap) & (L >= 1.5 * b.radial_floor(b.seg)))
        seg_bad = unique_ints(np.concatenate([seg_bad, long]))
        if seg_bad.size:
            b.split_segments(seg_bad)
            continue
        if size_at is None or size_at.uniform is not None:
            # A thin facet far above its (uniform) size: a lattice of points at once
            # (``meshcore.tets.seeding``), not a round per 1.5x more points.
            bound = b.facet_size if size_at is None else np.minimum(b.facet_size, size_at.uniform)
            bound = np.where(np.isfinite(b.facet_size), bound, np.inf)
            far = far_facets(b, b.knobs.size_radius * bound, seeded)
            if far.size:
                seeded[far] = True
                seed_facets(b, far, bound[far])
                continue
        cap = b.facet_size[b.sub_facet]
        if size_at is not None:
            cap = np.minimum(cap, size_at.at(lambda: b.P[b.sub].mean(axis=1)))
        if np.isfinite(cap).any():
            _, r = b.sub_circles()
            sub_bad = unique_ints(
                np.concatenate([sub_bad, np.flatnonzero(r > b.knobs.size_radius * cap)])
            )
        # The last few oversized subfaces (a tail of rounds, each retriangulating
        # whole facets for a handful of points) are split with the interior round's.
        tail = sub_bad.size <= b.knobs.tail * len(b.sub) and not sub_missing.size
        if sub_bad.size and not tail:
            b.split_subfaces(np.concatenate([sub_missing, sub_bad]))
            continue
        if sub_missing.size:
            recover(b, None)
        slots, T = b.tets()
        region = region_of(slots, T)
        inside = np.flatnonzero(region >= 0)
        Ti = T[inside]
        rows, centres = bad_tets(b.P, slots, T, inside)
        # A flat fold is dropped at the end (``_drop_flat_folds``): no point fixes it.
        fold = _flat_folds(b, Ti[rows])
        rows, centres = rows[~fold], centres[~fold]
        # Skinny because of a small input angle (``meshcore.tets.angles``): left.
        forced, _ = input_forced(b, Ti[rows], centres)
        rows, centres = rows[~forced], centres[~forced]
        left = len(rows)
        if left == 0:
            if sub_bad.size:
                b.split_subfaces(sub_bad)
                continue
            return rounds, 0
        done, skipped = _insert_interior(
            b, slots[inside], region[inside], rows, centres, Ti, sub_bad
        )
        del slots, T, region, inside, Ti  # freed before the next round's (b.tets())
        if progress is not None:
            progress(0.5, f"refinement round {rounds}: {left} bad tetrahedra")
        if done == 0:
            return rounds, skipped
    return rounds, left


# ---------------------------------------------------------------------------
# keep_boundary: the cone from one interior point
# ---------------------------------------------------------------------------


def _kernel_centre(P: np.ndarray, F: np.ndarray) -> np.ndarray | None:
    """Chebyshev centre of the kernel of a closed outward surface (LP), or None."""
    from scipy.optimize import linprog

    a = P[F[:, 0]]
    n = np.cross(P[F[:, 1]] - a, P[F[:, 2]] - a)
    norm = np.linalg.norm(n, axis=1)
    n = n / norm[:, None]
    # n . x + r <= n . a  for every face; maximize r.
    A = np.column_stack([n, np.ones(len(n))])
    rhs = np.einsum("ij,ij->i", n, a)
    res = linprog(
        c=[0, 0, 0, -1.0], A_ub=A, b_ub=rhs, bounds=[(None, None)] * 3 + [(0, None)],
        method="highs",
    )  # fmt: skip
    if not res.success or res.x[3] <= 0:
        return None
    return res.x[:3]


def _cone(b: SurfaceRecovery, region_count: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Tetrahedra of the cone from one interior point per region, if each is star-shaped."""
    tets, regs = [], []
    for r in range(region_count):  # a loop over regions
        F = b.facets[b.facet_region == r]
        c = _kernel_centre(b.P, F)
        if c is None:
            return None
        a, bb, cc = b.P[F[:, 0]], b.P[F[:, 1]], b.P[F[:, 2]]
        if not (orient3d(a, bb, cc, c) > 0).all():
            return None  # rounding put the centre on a face's plane
        v = b.n
        b.P = np.concatenate([b.P, c[None]])
        b.n += 1
        b.interior_added += 1
        tets.append(np.column_stack([F, np.full(len(F), v)]))  # orient3d > 0
        regs.append(np.full(len(F), r))
    return np.concatenate(tets), np.concatenate(regs)


# ---------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------


def _criteria_checked(max_radius_edge, min_dihedral, max_volume, size):
    mre = positive_parameter(max_radius_edge, "max_radius_edge")
    if mre is not None and mre < MIN_RADIUS_EDGE:
        raise InputError(
            f"max_radius_edge must be at least {MIN_RADIUS_EDGE} (no tetrahedralization "
            f"reaches lower ratios in general), got {max_radius_edge!r}",
            loc=("max_radius_edge",),
            code="bad_parameter",
        )
    return (
        mre,
        positive_parameter(min_dihedral, "min_dihedral", 70.0),
        positive_parameter(max_volume, "max_volume"),
        positive_parameter(size, "size"),
    )


def tetrahedralize(
    surface,
    *,
    empty: bool = False,
    max_radius_edge: float | None = 2.0,
    min_dihedral: float | None = None,
    max_volume: float | None = None,
    size: float | None = None,
    size_field=None,
    keep_boundary: bool = False,
    progress: Callable[[float, str], None] | None = None,
) -> TetrahedralizationResult:
    """Tetrahedra filling the regions of a closed surface, refined to the given bounds.

    Parameters
    ----------
    surface : Surface or dict
        A validated surface (:func:`meshcore.domain.surface.parse_surface`),
        or ``{"points": ..., "triangles": ...}`` (parsed here).
    empty : bool
        Only the surface points and the Steiner points on the surface that
        recovery needs (the empty tetrahedralization of §9.5); the bounds
        below are ignored. As in refinement, splits next to a sharp input
        vertex stop at its protecting ball (:mod:`meshcore.tets.angles`):
        without it the splits spiralled into the vertex.
    max_radius_edge : float or None
        Refine until every tetrahedron's circumradius over its shortest edge
        is at most this (TetGen's ``-q``; default 2.0, at least 1.1), except
        next to input angles too small for it (the rounds are capped and the
        rest counted in ``given_up``). None: no radius-edge bound.
    min_dihedral : float, optional
        Degrees in (0, 70]: slivers removed after refinement (flips,
        smoothing and insertion, each raising the local least dihedral
        angle; the result is then not Delaunay). Best effort: ``left`` counts the tetrahedra still
        below it, by cause, and ``left["improvement"]`` the operations.
    max_volume : float, optional
        Every tetrahedron's volume at most this.
    size : float, optional
        Target edge length: subsegments longer than it are split, subfaces
        and tetrahedra with a circumradius above ``0.7 size``.
    size_field : mapping, optional
        ``{"points": [[x, y, z], ...], "values": [h, ...]}``: target edge
        lengths at scattered points, interpolated linearly (nearest value
        outside their hull; :class:`meshcore.tets.sizing.SizeField3d`) and
        used as ``size`` is, at each piece's midpoint, centroid or
        circumcentre; with ``size`` too, the smaller of the two.
    keep_boundary : bool
        Add no point on the surface: the boundary faces are exactly the
        input triangles, with interior Steiner points only (none for a
        Delaunay-admissible surface, one per star-shaped region, else the
        conforming recovery's surface points lifted inside); no refinement
        then (the bounds are ignored).
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.

    Returns
    -------
    TetrahedralizationResult
        Positively oriented tetrahedra, each in one region; their volumes
        add up to the enclosed volume (to rounding); the boundary faces are
        exactly the subfaces, which tile every input triangle; no face is
        shared by more than two tetrahedra.

    Raises
    ------
    InputError
        Invalid surface (as :func:`parse_surface`) or bounds
        (``bad_parameter``).
    AlgorithmError
        ``recovery_failed`` (recovery did not finish, or with
        ``keep_boundary`` a surface point could not be lifted inside);
        ``too_many_points`` (the refinement reached ``Knobs.max_points``,
        300,000, before the bounds were met: no under-refined mesh is
        returned).

    References
    ----------
    Methods text §9.2, §9.3 (edges then faces), §9.3.5, §9.5; Shewchuk
    (1998) for the refinement.
    """
    surface = as_surface(surface)
    criteria = _criteria_checked(max_radius_edge, min_dihedral, max_volume, size)
    field = None if size_field is None else SizeField3d(size_field)
    size_at = _size_map(criteria[3], field)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    b = SurfaceRecovery(surface, KNOBS, merge=not keep_boundary)
    if criteria[3] is not None or field is not None:
        b.size_cap = min(criteria[3] or math.inf, math.inf if field is None else field.values.min())
    if not (empty or keep_boundary) and criteria[0] is not None:
        # Radius-edge refinement reaches the local feature size: the surface first.
        lfs = _feature_sizes(b)
        thin = lfs < b.knobs.thin * b.facet_short
        b.facet_size[thin] = b.knobs.feature_size * lfs[thin]
    if not keep_boundary:
        # Small input angles: protecting balls at the sharp vertices (recovery's
        # concentric shells spiral into a sharp vertex without them, `empty` too).
        protecting_balls(b)
    if not (empty or keep_boundary):
        protecting_cylinders(b)
    timings["delaunay"] = time.perf_counter() - t0
    rounds = 0
    given_up = 0
    left: dict = {}
    if keep_boundary:
        t1 = time.perf_counter()
        slots, T = b.tets()
        seg_missing, sub_missing = b.missing()
        if seg_missing.size == 0 and sub_missing.size == 0:
            region = regions(b, slots, T)
            keep = region >= 0
            tetra, region = T[keep], region[keep]
        else:
            cone = _cone(b, surface.region_count)
            if cone is not None:
                tetra, region = cone
            else:
                # Conforming recovery, then its surface points lifted inside.
                rounds += recover(b, progress)
                slots, T = b.tets()
                region = regions(b, slots, T)
                keep = region >= 0
                lifted = np.arange(b.n_surface, b.n)[::-1]
                tri_of_facet = np.argsort(b.group)
                b.P, tetra, region = lift_surface_points(
                    b.P, T[keep], region[keep], b.sub, tri_of_facet[b.sub_facet], b.facets,
                    lifted,
                )  # fmt: skip
                tetra, region, _ = flip_slivers(b.P, tetra, region, b.knobs.kept_flip_below)
                b.interior_added += b.surface_added
                b.surface_added = 0
        timings["recovery"] = time.perf_counter() - t1
    else:
        t1 = time.perf_counter()
        rounds += recover(b, progress)
        timings["recovery"] = time.perf_counter() - t1
        mre, mdh, mvol, _ = criteria
        bounded = mre is not None or mvol is not None or size_at is not None
        # Regions and bad tetrahedra kept by slot through every refinement round.
        region_of = RegionLabels(b)
        bad_tets = _BadTets(mre or math.inf, mvol, size_at, b.knobs)
        if not empty and bounded:
            t2 = time.perf_counter()
            r, given_up = _refine(b, region_of, bad_tets, progress)
            rounds += r
            timings["refinement"] = time.perf_counter() - t2
        # Encroachment fixes may have left pieces missing: recover again (no-op if whole).
        rounds += recover(b, progress)
        slots, T = b.tets()
        region = region_of(slots, T)
        keep = region >= 0
        tetra, region = T[keep], region[keep]
        # The kernel is done with: its memory freed before the last passes.
        del slots, T, keep, region_of, bad_tets
        b.release_kernel()
        tetra, region, sub, sub_src, triangle_facet = _drop_flat_folds(b, tetra, region)
        improved = None
        if not empty and mdh is not None:
            from meshcore.tets.slivers import remove_slivers  # (imports this module)

            # Slivers: flips, smoothing and insertion (the result is no longer Delaunay).
            t4 = time.perf_counter()
            tetra, region, improved = remove_slivers(b, tetra, region, sub, mdh, mre or math.inf)
            timings["improvement"] = time.perf_counter() - t4
        left = _left_report(b, tetra, sub, None if empty else mre, None if empty else mdh, improved)
    if keep_boundary:
        # Boundary faces: the input triangles.
        sub, sub_src, triangle_facet = b.facets, np.arange(len(b.facets)), b.group
    # Kernel order (orient3d > 0) to meshio's positive volume: swap two vertices.
    tetra = tetra[:, [0, 1, 3, 2]]
    cell_sets = {f"region_{r}": [np.flatnonzero(region == r)] for r in range(surface.region_count)}
    mesh = Mesh(b.P, (CellBlock("tetra", tetra),), cell_sets=cell_sets)
    timings["total"] = time.perf_counter() - t0
    return TetrahedralizationResult(
        mesh=mesh,
        region=region,
        boundary_faces=sub,
        boundary_source=sub_src,
        triangle_facet=triangle_facet,
        surface_points_added=b.surface_added,
        interior_points_added=b.interior_added,
        rounds=rounds,
        given_up=given_up,
        left=left,
        timings=timings,
    )
