r"""Mesh generation by recursive partition (divide and conquer, §8.7.2): 3D.

Input: a closed triangulated surface (:func:`~meshcore.domain.surface.parse_surface`;
one or more bodies, no cavity) and a size ``h`` (or a scattered size field,
the control space of Remark 8.10). Output: positively oriented tetrahedra
whose faces include every input triangle exactly (no point is added on the
surface) and every separator triangle.

Algorithm
---------
A stack of polyhedra, each a closed surface (outward triangles over its own
points, with their global numbers), starting with each body.

1. **Leaf or split.** A polyhedron of four faces is a tetrahedron. One whose
   bounding box is at most ``1.5`` times the larger of ``h`` and its longest
   edge on every side is a *leaf* (step 3): cutting further cannot make its
   tetrahedra smaller than its surface triangles. Otherwise a separator is
   sought.
2. **Separator surface.** Candidate cutting planes are tried in order
   (``strategy``, below). For a plane, the faces whose centroid lies below
   it form a set ``R``; the edges between ``R`` and the other faces form
   cycles of surface edges (a vertex met twice, a *pinch*, refuses the
   plane). Each cycle is projected on the plane and meshed there by the 2D
   recursive partition (:func:`~meshcore.partition.recursive.partition_polygon`,
   which keeps the cycle's vertices and places interior points by the sizes,
   the 2D separators subdivided "as in Delaunay point insertion"); the
   interior points are lifted onto the plane. The cycles are *planar
   polygons through boundary vertices* up to the zig-zag of the surface
   edges around the plane (exactly planar on surfaces whose vertices lie on
   the plane, such as grid-sampled boxes). The surface cut along the cycles
   must fall into exactly two parts, each touching every cycle; each part
   plus the separator triangles (oriented against the part's faces along the
   cycle) is a child. A candidate is accepted only if both children are
   valid closed surfaces, one shell each, already outward as built. The
   parent is valid, so only what the separators add is tested, by the exact
   tests of :func:`~meshcore.domain.surface.parse_surface` on those pairs
   (:func:`~meshcore.domain.surface.added_triangles_fit`): no separator
   triangle degenerate, repeating a face, or crossing or touching a face of
   the parent or another separator triangle other than in common vertices
   or a common edge; then each child's every edge is held by two of its
   faces running it opposite ways, and its volume is exactly positive (a
   separator outside the polyhedron makes one child inside-out). One shell
   and manifold vertices hold by construction (a connected part, a cycle
   passes each vertex once, a separator is a planar triangulation), and the
   child's :class:`~meshcore.domain.surface.Surface` is built directly, as
   ``parse_surface`` would return it. So the separator lies inside the
   polyhedron, and the children's volumes add up to the parent's.
3. **Meshable patterns** (a leaf, or a polyhedron no candidate splits):
   the Delaunay tetrahedralization of its vertices when every face of it is
   a Delaunay face (:func:`~meshcore.tets.tetrahedralize` with
   ``keep_boundary``); else the cone from one of its vertices that sees
   every face not incident to it strictly (exact ``orient3d``), the vertex
   whose worst tetrahedron is best; else the polyhedron cannot be cut
   without a new point (Schönhardt's prism): the cone from one interior
   Steiner point, the Chebyshev centre of its kernel (``tetrahedralize``
   with ``keep_boundary``), every tetrahedron checked positive exactly.
   Where several of these exist, the one whose worst tetrahedron is least
   flat (volume over cubed longest edge) is taken: a Delaunay or vertex
   cone tetrahedron on the four corners of a nearly planar surface quad
   (the torus's) is positive by the exact sign but has a float volume of
   zero, and the Steiner cone avoids it. A
   polyhedron that is none of these gets a wide search (more offsets, six
   random normals, ``wide_searches`` in ``stats``) and is split again;
   when that finds nothing either it is refused (``AlgorithmError``,
   ``code="unmeshable"``).

Strategies
----------
* ``balanced`` (default): planes normal to the principal axes of the
  polyhedron's vertices and to the coordinate axes, longest extent first,
  through the vertex nearest the median, then the 35 % and 65 %
  quantiles: halves of similar size, which shortens the pieces' longest
  side first.
* ``angle``: first the planes of the two faces at the most reflex edges
  (largest dihedral angle above 180 degrees), through the edge, which cut
  a non-convex polyhedron into convex-like parts (the L-block's two
  boxes); then the balanced planes.

Choices the text leaves open
----------------------------
* No point is added on the input surface: every input triangle is a face
  of the mesh, so the tetrahedra follow the sizes only as far as the
  surface's own sampling allows (give a surface sampled at about ``h``).
  Separators and their interior points follow ``h``.
* The plane only proposes a cycle; validity is decided by the exact tests
  of step 2 on the two children, not by the plane.
* Interior points of a separator are rounded onto the plane; the
  separator's triangles need not be exactly coplanar (they are surface
  triangles of both children, tested exactly).
* Cavities are refused (``code="unsupported"``): a cavity's shell would
  first have to be joined to the outer one, the 3D form of 2D bridges.
* A size field is read at the separator's points (inverse squared distance
  to the four nearest field points); leaves use the smallest size of the
  field at their vertices.

References
----------
Methods text §8.7.2 (recursive partition, separator surfaces, the
Schönhardt polyhedron), Remark 8.10 (control space); Schönhardt (1928).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshcore.domain.planar import parse_domain
from meshcore.domain.surface import (
    Surface,
    added_triangles_fit,
    as_surface,
    parse_surface,
    shell_volume,
)
from meshcore.errors import AlgorithmError, InputError, MeshcoreError, positive_parameter
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import edge_keys
from meshcore.partition.boundary import SizeMap
from meshcore.partition.recursive import PartitionResult, partition_polygon
from meshcore.tets import tetrahedralize

__all__ = ["recursive_partition_3d"]

#: A polyhedron whose bounding box is at most this many sizes on every side is a leaf.
LEAF = 1.5
_QUANTILES = (0.5, 0.35, 0.65)
_MAX_CANDIDATES = 12
# The wide search, for a part that no first candidate splits and no pattern meshes.
_QUANTILES_MORE = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.1, 0.9)
_RANDOM_NORMALS = 6
_MAX_CANDIDATES_MORE = 90
_REFLEX_EDGES = 4  # most reflex edges whose face planes the ``angle`` strategy tries
_FIELD_SAMPLES = 16  # size field grid over a separator, per side


class _Sizes:
    """``h(x)`` in 3D: a constant, or inverse squared distance to the 4 nearest field points."""

    def __init__(self, size: float | None, field: dict | None):
        self.size = size
        self.tree = None
        if field is not None:
            pts = np.asarray(field.get("points"), dtype=np.float64)
            val = np.asarray(field.get("values"), dtype=np.float64)
            if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0 or val.shape != (len(pts),):
                raise InputError(
                    "size_field must have points (k, 3) and values (k,)",
                    loc=("size_field",),
                    code="bad_parameter",
                )
            if not (np.isfinite(pts).all() and np.isfinite(val).all() and (val > 0).all()):
                raise InputError(
                    "size_field needs finite points and finite positive values",
                    loc=("size_field",),
                    code="bad_parameter",
                )
            self.tree, self.values = cKDTree(pts), val
        elif size is None:
            raise InputError("give size or size_field", loc=("size",), code="bad_parameter")

    def __call__(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
        if self.tree is None:
            return np.full(len(X), float(self.size))
        k = min(4, len(self.values))
        d, i = self.tree.query(X, k=k)
        d, i = np.asarray(d).reshape(len(X), k), np.asarray(i).reshape(len(X), k)
        w = 1.0 / np.maximum(d, 1e-300) ** 2
        h = (w * self.values[i]).sum(axis=1) / w.sum(axis=1)
        exact = d[:, 0] == 0.0
        h[exact] = self.values[i[exact, 0]]
        return h if self.size is None else np.minimum(h, self.size)


def _twins(F: np.ndarray) -> np.ndarray:
    """Twin of each half-edge ``3 t + k`` (``F[t, k] -> F[t, k + 1]``) of a closed surface."""
    src = F.reshape(-1)
    dst = F[:, [1, 2, 0]].reshape(-1)
    n = int(F.max()) + 1
    order = np.argsort(edge_keys(src, dst, n), kind="stable")
    twin = np.empty(len(src), dtype=np.int64)
    twin[order[0::2]] = order[1::2]
    twin[order[1::2]] = order[0::2]
    return twin


def _tet_order(T: np.ndarray) -> np.ndarray:
    """Kernel order (``orient3d > 0``) to meshio's positive volume."""
    return T[:, [0, 1, 3, 2]]


class _Poly:
    """A polyhedron: a parsed closed surface over local points, and their global numbers."""

    __slots__ = ("gid", "surf", "depth")

    def __init__(self, gid: np.ndarray, surf: Surface, depth: int):
        self.gid, self.surf, self.depth = gid, surf, depth


def _compact(P: np.ndarray, F: np.ndarray):
    """(global ids used, local points, local faces)."""
    used, inv = np.unique(F, return_inverse=True)
    return used, P[used], inv.reshape(-1, 3)


def _child(P: np.ndarray, F: np.ndarray, depth: int) -> _Poly | None:
    """A child polyhedron built directly (its faces known not to cross), or None.

    ``F`` is a part of a validated surface cut along unpinched cycles, closed
    by separator triangles that :func:`added_triangles_fit` accepted. It is
    one shell (a connected part plus disks along its cycles) and
    vertex-manifold by construction (a cycle passes a vertex once; a
    separator is a planar triangulation); every edge held by exactly two
    faces running it opposite ways and an exactly positive volume are
    checked here (a separator outside the polyhedron makes a child
    inside-out). The Surface is the one :func:`parse_surface` would return.
    """
    used, X, Fl = _compact(P, F)
    n = len(X)
    fwd = np.sort(Fl.reshape(-1) * n + Fl[:, [1, 2, 0]].reshape(-1))
    back = np.sort(Fl[:, [1, 2, 0]].reshape(-1) * n + Fl.reshape(-1))
    if (fwd[1:] == fwd[:-1]).any() or not np.array_equal(fwd, back):
        return None
    volume, sign = shell_volume(X, Fl)
    if sign <= 0:
        return None
    m = len(Fl)
    s = Surface(
        points=X,
        triangles=Fl,
        triangle_reversed=np.zeros(m, dtype=bool),
        triangle_shell=np.zeros(m, dtype=np.int64),
        shell_parent=np.array([-1]),
        shell_depth=np.array([0]),
        shell_region=np.array([0]),
        shell_volume=np.array([volume]),
        volume=volume,
        diameter=float(np.linalg.norm(X.max(axis=0) - X.min(axis=0))),
    )
    return _Poly(used, s, depth)


def _planes(X: np.ndarray, F: np.ndarray, twin: np.ndarray, strategy: str, more: bool):
    """Candidate planes ``(normal, offset)`` in the strategy's order (``more``: the wide search)."""
    out: list[tuple[np.ndarray, float]] = []
    normals: list[np.ndarray] = []
    cap = _MAX_CANDIDATES_MORE if more else _MAX_CANDIDATES

    def add(n: np.ndarray, off: float) -> None:
        if len(out) < cap:
            out.append((n, off))

    if strategy == "angle":
        # Reflex edges: the far vertex of the twin face lies outside the face's plane.
        h = np.arange(3 * len(F))
        t, k = h // 3, h % 3
        t2 = twin // 3
        far = F[t2, (twin % 3 + 2) % 3]
        a, b, c = X[F[t, 0]], X[F[t, 1]], X[F[t, 2]]
        reflex = np.flatnonzero((orient3d(a, b, c, X[far]) < 0) & (h < twin))
        if reflex.size:
            n1 = np.cross(b[reflex] - a[reflex], c[reflex] - a[reflex])
            f2 = F[t2[reflex]]
            n2 = np.cross(X[f2[:, 1]] - X[f2[:, 0]], X[f2[:, 2]] - X[f2[:, 0]])
            n1 /= np.linalg.norm(n1, axis=1)[:, None]
            n2 /= np.linalg.norm(n2, axis=1)[:, None]
            turn = np.einsum("ij,ij->i", n1, n2)  # the more reflex, the smaller
            for r in np.argsort(turn, kind="stable")[:_REFLEX_EDGES].tolist():
                p = X[F[t[reflex[r]], k[reflex[r]]]]
                for n in (n1[r], n2[r]):
                    add(n, float(n @ p))
    c = X.mean(axis=0)
    w, V = np.linalg.eigh(np.cov((X - c).T) + 1e-300 * np.eye(3))
    cand = [V[:, i] for i in np.argsort(-w)]
    ext = X.max(axis=0) - X.min(axis=0)
    axes = [np.eye(3)[i] for i in np.argsort(-ext, kind="stable")]
    if more:
        cand += list(np.random.default_rng(len(X)).normal(size=(_RANDOM_NORMALS, 3)))
    for pair in zip(cand, axes + [np.zeros(3)] * (len(cand) - 3), strict=True):
        for n in pair:
            n = n / max(float(np.linalg.norm(n)), 1e-300)
            if n.any() and all(abs(float(n @ m)) < 0.999 for m in normals):
                normals.append(n)
    for n in normals:
        q = X @ n
        qs = np.sort(q)
        for f in _QUANTILES_MORE if more else _QUANTILES:
            target = qs[int(f * (len(qs) - 1))]
            add(n, float(target))
    return out


def _cycles(F: np.ndarray, twin: np.ndarray, below: np.ndarray) -> list[np.ndarray] | None:
    """Cycles of half-edges of faces in ``below`` whose twin face is not; None at a pinch."""
    h = np.flatnonzero(below[np.arange(3 * len(F)) // 3] & ~below[twin // 3])
    if h.size == 0:
        return None
    src = F.reshape(-1)[h]
    if len(np.unique(src)) != len(src):
        return None  # a vertex met twice: the cut is pinched there
    nxt = {int(s): int(i) for i, s in enumerate(src.tolist())}
    dst = F[:, [1, 2, 0]].reshape(-1)[h]
    seen = np.zeros(len(h), dtype=bool)
    cycles = []
    for start in range(len(h)):  # a loop over cycles, then along each one
        if seen[start]:
            continue
        cyc = []
        i = start
        while not seen[i]:
            seen[i] = True
            cyc.append(i)
            j = nxt.get(int(dst[i]))
            if j is None:
                return None
            i = j
        if i != start:
            return None
        cycles.append(h[np.array(cyc)])
    return cycles


def _separator(P, ring: np.ndarray, normal, sizes: _Sizes):
    """Triangles (global ids, counter-clockwise about ``normal``) meshing a cycle, new points.

    ``ring`` lists the cycle's global point ids in order. Returns (triangles
    over ``P`` extended by the new points, new points (k, 3)) or None when the
    projected cycle is not a simple polygon.
    """
    n = normal / np.linalg.norm(normal)
    u = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    X = P[ring]
    c = X.mean(axis=0)
    xy = np.column_stack([(X - c) @ u, (X - c) @ v])
    try:
        parse_domain({"type": "Polygon", "coordinates": [xy]})
    except InputError:
        return None
    area = 0.5 * float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))
    if area == 0.0:
        return None
    loop = np.arange(len(ring)) if area > 0 else np.arange(len(ring))[::-1]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    if sizes.tree is None:
        smap = SizeMap(np.array([[float(sizes.size)]]), np.zeros(4))
    else:
        g = _FIELD_SAMPLES
        gx, gy = np.linspace(lo[0], hi[0], g), np.linspace(lo[1], hi[1], g)
        xx, yy = np.meshgrid(gx, gy)
        H = sizes(c + xx.reshape(-1, 1) * u + yy.reshape(-1, 1) * v).reshape(g, g)
        span = np.maximum(hi - lo, 1e-300)
        smap = SizeMap(H, np.array([lo[0], lo[1], span[0] / (g - 1), span[1] / (g - 1)]))
    try:
        pts, tri, _ = partition_polygon(xy, [loop], np.array([0]), smap, quad=False)
    except MeshcoreError:
        return None
    if tri is None:
        return None
    extra = c + pts[len(ring) :, :1] * u + pts[len(ring) :, 1:2] * v
    ids = np.concatenate([ring, len(P) + np.arange(len(extra))])
    return ids[tri], extra


def _split(P, poly: _Poly, gF, twin, plane, sizes: _Sizes):
    """Two valid children and the new points for one candidate plane, or None."""
    X = poly.surf.points
    F = poly.surf.triangles
    n, off = plane
    below = X[F].mean(axis=1) @ n < off
    if below.all() or not below.any():
        return None
    cycles = _cycles(F, twin, below)
    if cycles is None:
        return None
    # The two parts of the surface cut along every cycle edge.
    m = len(F)
    h = np.arange(3 * m)
    cut = np.zeros(3 * m, dtype=bool)
    for cyc in cycles:
        cut[cyc] = True
        cut[twin[cyc]] = True
    keep = ~cut
    g = sp.csr_matrix((np.ones(int(keep.sum())), (h[keep] // 3, twin[keep] // 3)), shape=(m, m))
    count, label = connected_components(g, directed=False)
    if count != 2:
        return None
    P_ext = P
    seps = []
    for cyc in cycles:
        ring = gF.reshape(-1)[cyc]  # the cycle as the below faces run it
        res = _separator(P_ext, ring, n, sizes)
        if res is None:
            return None
        tri, extra = res
        P_ext = np.concatenate([P_ext, extra])
        # Orientation against the below faces: they run ring[i] -> ring[i + 1].
        a, b = int(ring[0]), int(ring[1])
        runs_ab = ((tri == a) & (np.roll(tri, -1, axis=1) == b)).any()
        below_part = int(label[cyc[0] // 3])
        above_part = int(label[twin[cyc[0]] // 3])
        if below_part == above_part:
            return None
        if (label[cyc // 3] != below_part).any() or (label[twin[cyc] // 3] != above_part).any():
            return None
        seps.append((tri[:, ::-1] if runs_ab else tri, below_part))
    # the separators against every face of the parent and each other (exact tests)
    sep = np.concatenate([t for t, _ in seps])
    _, X2, U = _compact(P_ext, np.concatenate([gF, sep]))
    if not added_triangles_fit(X2, U, len(gF)):
        return None
    children = []
    for part in (0, 1):
        faces = [gF[label == part]]
        for tri_below, below_part in seps:
            faces.append(tri_below if part == below_part else tri_below[:, ::-1])
        child = _child(P_ext, np.concatenate(faces), poly.depth + 1)
        if child is None:
            return None
        children.append(child)
    return children, P_ext[len(P) :], sum(len(t) for t, _ in seps)


def _worst_shape(X: np.ndarray, T: np.ndarray) -> float:
    """Least volume over cubed longest edge of tetrahedra (kernel order), float."""
    a = X[T[:, 0]]
    vol = np.einsum("ij,ij->i", np.cross(X[T[:, 1]] - a, X[T[:, 2]] - a), X[T[:, 3]] - a)
    e = X[T[:, [0, 0, 0, 1, 1, 2]]] - X[T[:, [1, 2, 3, 2, 3, 3]]]
    L = np.sqrt(np.einsum("ijk,ijk->ij", e, e).max(axis=1))
    return float((np.abs(vol) / L**3).min())


def _vertex_cone(X: np.ndarray, F: np.ndarray) -> np.ndarray | None:
    """Tetrahedra (kernel order) of the best cone from a vertex seeing every other face."""
    # one exact orient3d call for every (vertex, face not at it) pair
    v, t = np.nonzero(~(F[None, :, :] == np.arange(len(X))[:, None, None]).any(axis=2))
    sees = orient3d(X[F[t, 0]], X[F[t, 1]], X[F[t, 2]], X[v]) > 0
    blind = np.bincount(v[~sees], minlength=len(X))
    best, best_q = None, -1.0
    for u in np.flatnonzero(blind == 0).tolist():  # a loop over the leaf's cone apexes
        far = F[t[v == u]]
        T = np.column_stack([far, np.full(len(far), u)])
        q = _worst_shape(X, T)
        if q > best_q:
            best, best_q = T, q
    return best


def _search(P, poly: _Poly, gF, strategy: str, sizes: _Sizes, *, more: bool):
    """The first candidate plane that splits ``poly`` validly: (children, new points, k)."""
    F = poly.surf.triangles
    twin = _twins(F)
    for plane in _planes(poly.surf.points, F, twin, strategy, more):
        found = _split(P, poly, gF, twin, plane, sizes)
        if found is not None:
            return found
    return None


def _leaf(poly: _Poly) -> tuple[np.ndarray, np.ndarray, str] | None:
    """Tetrahedra of a polyhedron by a meshable pattern: (local tetra, Steiner points, pattern).

    Local tetra (meshio order) index the polyhedron's points, then the Steiner
    points. None when the polyhedron is not star-shaped and not Delaunay.
    """
    s = poly.surf
    X, F = s.points, s.triangles
    none = np.zeros((0, 3))
    if len(F) == 4:
        d = int(np.setdiff1d(np.arange(4), F[0])[0])
        return _tet_order(np.array([[*F[0], d]])), none, "tetrahedron"
    try:
        r = tetrahedralize(s, keep_boundary=True)
    except (AlgorithmError, InputError):
        # InputError: the 3D kernel refuses coordinates spanning over 2**100 (a separator
        # point rounded to 1e-33 beside others near 1); the cones below still apply.
        r = None
    options = []  # (worst shape, tetra in meshio order, Steiner points, pattern)
    if r is not None:
        K = r.mesh.cells[0].data
        name = "delaunay" if r.interior_points_added == 0 else "steiner"
        options.append((_worst_shape(r.mesh.points, K), K, r.mesh.points[len(X) :], name))
    cone = _vertex_cone(X, F)
    if cone is not None:
        options.append((_worst_shape(X, cone), _tet_order(cone), none, "vertex_cone"))
    if not options:
        return None
    _, K, S, name = max(options, key=lambda o: o[0])
    return K, S, name


def _size_class(k: int) -> str:
    return "1" if k == 1 else "2-3" if k <= 3 else "4-7" if k <= 7 else "8+"


def recursive_partition_3d(
    surface,
    *,
    size: float | None = None,
    size_field=None,
    strategy: str = "balanced",
    progress: Callable[[float, str], None] | None = None,
) -> PartitionResult:
    """Tetrahedra of a closed surface by recursive partition into two (§8.7.2).

    Parameters
    ----------
    surface : Surface or dict
        ``{"points": (n, 3), "triangles": (m, 3)}`` or a parsed
        :class:`~meshcore.domain.surface.Surface`; bodies, no cavity.
    size : float, optional
        Target edge length of the separators (and the leaf bound).
    size_field : dict, optional
        ``{"points": (k, 3), "values": (k,)}`` (Remark 8.10); ``size``
        bounds it.
    strategy : {"balanced", "angle"}
        Order of the cutting planes (module docstring).
    progress : callable, optional
        ``progress(fraction, message)``; may raise to cancel.

    Returns
    -------
    PartitionResult
        ``mesh``: the surface's vertices first (increasing input index), then
        the separator points, then the Steiner points; one ``tetra`` block,
        every tetrahedron positive by exact ``orient3d``; their volumes add
        up to the enclosed volume; every input triangle is a face of exactly
        one tetrahedron and the mesh is conforming (no face held by more
        than two). ``stats``: ``depth``, ``separators`` by triangle count,
        ``separator_triangles``, ``patterns`` (leaves by pattern:
        tetrahedron, delaunay, vertex_cone, steiner), ``steiner_points``,
        ``oversized_leaves`` (leaves wider than the leaf bound that no
        candidate plane split), ``seconds``.

    Raises
    ------
    InputError
        Bad surface, size or strategy (``loc`` names it); a cavity
        (``code="unsupported"``).
    AlgorithmError
        ``unmeshable``: a part with no valid separator that is not
        star-shaped.

    References
    ----------
    Methods text §8.7.2, Remark 8.10; module docstring.
    """
    t0 = time.perf_counter()
    s = as_surface(surface)
    if strategy not in ("balanced", "angle"):
        raise InputError(
            f"strategy must be 'balanced' or 'angle', got {strategy!r}",
            loc=("strategy",),
            code="bad_parameter",
        )
    size = positive_parameter(size, "size")
    sizes = _Sizes(size, size_field)
    if (s.shell_depth % 2 == 1).any():
        raise InputError(
            "recursive_partition does not take surfaces with cavities",
            loc=("surface",),
            code="unsupported",
        )
    verts = s.vertices
    P = s.points[verts]
    remap = np.full(len(s.points), -1, dtype=np.int64)
    remap[verts] = np.arange(len(verts))
    stack = []
    for r in range(s.region_count):
        F = remap[s.triangles[s.triangle_region == r]]
        used, X, Fl = _compact(P, F)
        stack.append(_Poly(used, parse_surface(X, Fl), 0))
    total = s.volume
    done = 0.0
    tets: list[np.ndarray] = []
    steiner: list[np.ndarray] = []
    n_steiner = 0
    stats_sep = {"1": 0, "2-3": 0, "4-7": 0, "8+": 0}
    patterns = {"tetrahedron": 0, "delaunay": 0, "vertex_cone": 0, "steiner": 0}
    depth = 0
    oversized = 0
    wide_searches = 0
    sep_tris = 0
    t_split = t_leaf = 0.0
    while stack:  # a loop over the polyhedra of the recursion (a stack)
        poly = stack.pop()
        depth = max(depth, poly.depth)
        X, F = poly.surf.points, poly.surf.triangles
        gF = poly.gid[F]
        e = X[F] - X[F[:, [1, 2, 0]]]
        longest = float(np.sqrt(np.einsum("ijk,ijk->ij", e, e).max()))
        reach = LEAF * max(float(sizes(X).min()), longest)
        wide = len(F) > 4 and (X.max(axis=0) - X.min(axis=0)).max() > reach
        found = None
        t1 = time.perf_counter()
        if wide:
            found = _search(P, poly, gF, strategy, sizes, more=False)
        t_split += time.perf_counter() - t1
        if found is None:
            t1 = time.perf_counter()
            leaf = _leaf(poly)
            t_leaf += time.perf_counter() - t1
            if leaf is None and len(F) > 4:
                t1 = time.perf_counter()
                found = _search(P, poly, gF, strategy, sizes, more=True)
                t_split += time.perf_counter() - t1
                wide_searches += 1
            if leaf is None and found is None:
                raise AlgorithmError(
                    f"a part of {len(F)} faces has no valid separator and is not star-shaped",
                    code="unmeshable",
                )
        if found is not None:
            children, extra, k = found
            P = np.concatenate([P, extra])
            stats_sep[_size_class(k)] += 1
            sep_tris += k
            stack.extend(children)
            continue
        oversized += int(wide)
        T, S, pattern = leaf
        patterns[pattern] += 1
        ids = np.concatenate(
            [poly.gid, -1 - n_steiner - np.arange(len(S))]
        )  # Steiner points numbered after the recursion's points, negative until then
        n_steiner += len(S)
        steiner.append(S)
        tets.append(ids[T])
        done += poly.surf.volume
        if progress is not None:
            progress(min(0.9, 0.9 * done / total), f"{sum(patterns.values())} parts meshed")
    K = np.concatenate(tets) if tets else np.zeros((0, 4), dtype=np.int64)
    K = np.where(K < 0, len(P) - 1 - K, K)
    P = np.concatenate([P, *steiner])
    ok = orient3d(P[K[:, 0]], P[K[:, 1]], P[K[:, 2]], P[K[:, 3]]) < 0
    if not ok.all():
        raise AlgorithmError(
            f"{int((~ok).sum())} tetrahedra are not positive", code="inverted_cells"
        )
    mesh = Mesh(P, (CellBlock("tetra", K),))
    t1 = time.perf_counter()
    q = quality.report(mesh)
    stats = {
        "depth": depth,
        "separators": stats_sep,
        "separator_triangles": sep_tris,
        "patterns": patterns,
        "steiner_points": n_steiner,
        "oversized_leaves": oversized,
        "wide_searches": wide_searches,
        "cells": int(len(K)),
        "points": int(len(P)),
        "input_triangles": int(len(s.triangles)),
        "volume": s.volume,
        "seconds": {
            "split": t_split,
            "leaves": t_leaf,
            "quality": time.perf_counter() - t1,
            "total": time.perf_counter() - t0,
        },
    }
    if progress is not None:
        progress(1.0, "done")
    return PartitionResult(mesh, q, stats)
