"""Optimization-based meshing, mesh correction and optimization (Coupez, §8.3).

One method, three uses named by §8.3 and §8.3.5:

1. **Generation** from a boundary discretization (Figure 8.10): the initial
   mesh topology is Op(P, δ𝒮) with P the boundary vertex nearest the
   centroid of δ𝒮 (joined to every boundary edge not incident to it), then
   sub-topologies are replaced until the topology is a valid mesh.
2. **Correction** of a tangled mesh (the forming-process use): the input
   triangles or tetrahedra, some inverted, are the initial topology; the
   boundary stays as given.
3. **Optimization** of a valid mesh: the same loop on a positive mesh only
   replaces a sub-topology when its worst quality rises, so the least
   quality never decreases.

Generation of tetrahedra from one closed surface (Figure 8.11) is in
:mod:`.coupez3d`: the same initialization Op(P, δ𝒮), then fans on vertex
balls, edge shells and larger sets (:func:`.kernel3d.fan_sweep`).

The loop (the synthetic algorithm of §8.3.2) is in :mod:`.kernel2d` and
:mod:`.kernel3d`: balls of vertices first; when a pass changes nothing,
pairs of adjacent triangles (2D); when that changes nothing either and an
element is still non-positive, unions of balls (the "larger connected
sets"). Passes repeat until none changes anything or ``max_sweeps`` passes
ran. ``stats["sur"]`` is Sur(𝒯), the sum of unsigned areas (volumes), after
the start and after every pass: it never increases, and it equals the
domain's area (volume) exactly when every element is positive.

Choices where the text leaves freedom
-------------------------------------
* **G.** The centroid of the vertices of δℬ_P; when moving P there leaves an
  element non-positive, also the centroid of the kernel of δℬ_P (2D), the
  region of positions from which all of δℬ_P is seen, i.e. where
  Sur(Op(G, δℬ_P)) is least. In 3D, G and, failing it, a point of the
  kernel found by relaxation (:mod:`.kernel3d`).
* **Barycentric move** (correction only). Before the passes, the free
  vertices within ``BARYCENTRIC_RINGS`` rings of the non-positive cells go
  at once to the fixed point of the moves to G (one sparse solve of the
  graph Laplacian, every other vertex kept), taken when Sur drops
  (:func:`barycentric`): what passes of ball moves approach slowly.
* **Removal.** A fan Op(Q, δℬ_P) with Q on δℬ_P removes the free vertex P.
  It is a candidate only where the ball is not positive and no move of P
  makes Sur smaller (a correction, never a quality move), and only when
  ``insert_points`` is true: with ``insert_points=false`` the point set is
  kept.
* **Restarts.** When the first stage ends stable but invalid, generation
  starts again from Op(P', δ𝒮), P' the next vertex by distance to the
  centroid (the text: "any point in δ𝒮 could be used"), up to ``RESTARTS``
  initial vertices; ``stats["restarts"]`` lists the stuck attempts.
* **Initialization with insertion.** With ``insert_points`` and one ring,
  when the centroid G of the boundary vertices sees every segment (exact
  orient2d: the domain is star-shaped from G), the initial topology is
  Op(G, δ𝒮), the operator's second case (Figure 8.8 ii), a valid mesh at
  once, handed to the second stage without passes; otherwise the text's
  Op(P, δ𝒮) from a boundary vertex. (From a
  boundary vertex, a 10k-point five-petal flower stays stuck with 157
  inverted triangles after 1,000 passes.)
* **Stages** (§8.3.3): a first stage without insertion; then, for generation
  with ``insert_points``, a second stage (:mod:`.refine2d`): pairs of
  adjacent triangles replaced by their Delaunay diagonal (the larger least
  angle), then points G at the circumcentre (or Üngör's off-centre) of
  every triangle whose least angle is under ``min_angle`` or whose
  circumradius exceeds ``0.8 size``, each by Op(G, δ𝒮) with 𝒮 the triangles
  whose circumcircle holds G (a connected set). Never on a boundary
  segment: a point that would encroach one is replaced by the apex of the
  equilateral triangle on it, or the triangle is given up
  (``stats["insertion"]["given_up"]``). ``size`` defaults to the median
  boundary segment.
* **keep_boundary=false** (generation only): the boundary segments are first
  split evenly to at most ``size``; boundary vertices never move.
* **Quality** (8.2): ``shape`` (4√3 A / Σl², 1 for the equilateral
  triangle; 12 (3V)^(2/3) / Σl² for tetrahedra) or ``radius_ratio`` (2r/R
  in 2D, 3r/R in 3D), from the unsigned measure as the text says.

Guarantees: on return, every element is positive by the exact predicates,
the topology is a mesh topology (every edge, face in 3D, in one or two
elements, consistently oriented) whose boundary is exactly the input
boundary. When the loop stops short of that, :class:`AlgorithmError` says
how many elements are still inverted and where; no invalid mesh is returned.

References
----------
Methods text §8.3.1-§8.3.5 (Definition 8.1, Op(P, δ𝒯), (8.1)-(8.2), the
synthetic algorithm, the validity condition of §8.3.3 and Figure 8.9,
Figures 8.10-8.11); T. Coupez, "Génération de maillage et adaptation de
maillage par optimisation locale", Revue européenne des éléments finis 9
(2000).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from meshcore.domain.planar import Domain, parse_domain
from meshcore.domain.surface import as_surface
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates import WORK_SIZE, orient2d
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.tetstore import N_PTS, N_ROWS, CellStore
from meshcore.mesh.topology import edge_keys, unique_ints
from meshcore.optimize import kernel2d as k2
from meshcore.optimize import refine2d as r2
from meshcore.triangulation import MAX_POINTS

Progress = Callable[[float, str], None] | None

MEASURES = ("shape", "radius_ratio")


@dataclass(frozen=True)
class _Tolerances:
    """Decisions of the loop that are not signs.

    Attributes
    ----------
    sur_tie : float
        Two non-positive configurations whose Sur differ by less than this
        fraction of the current one tie on (8.1); the quality decides.
    quality_gain : float
        A replacement on quality alone must raise the worst quality of the
        sub-topology by at least this much (it stops endless tiny moves).
    distance_tie : float
        Values closer than this fraction of the largest magnitude tie
        (:func:`near_order`: the squared distances to a centroid of
        :func:`by_distance`, the edge lengths of the 3D insertion stage):
        above the rounding a translation by 1e6 puts on the coordinates of a
        unit-sized input (about 1e-10).
    flat : float
        A tetrahedron whose exact orient3d says positive but whose 6 V is at most
        this fraction of D times the sum of its squared edges (D the diagonal of
        the input's bounding box, :func:`flatness`) counts as flat, not positive:
        rounding the coordinates of a unit-sized input translated by 1e6 moves a
        volume by about 1e-10 D that sum, so where the input lies never decides
        whether a tet is valid (four coplanar surface points make a flat tet
        wherever the input lies, not one positive by 1e-18 at the origin and
        exactly zero at 1e6).
    """

    sur_tie: float = 1e-12
    quality_gain: float = 1e-4
    distance_tie: float = 1e-9
    flat: float = 1e-9


TOL = _Tolerances()

#: Rings of cells around the non-positive ones whose free vertices :func:`barycentric` moves.
BARYCENTRIC_RINGS = 3

#: Initial topologies tried in turn by generation (2D and 3D) while the first stage ends stable
#: but invalid: Op(P, δ𝒮) from the vertices nearest the centroid, in order (§8.3.2's footnote:
#: "any point in δ𝒮 could be used").
RESTARTS = 8


@dataclass(frozen=True, eq=False)
class OptimizationResult:
    """A valid mesh, its quality report and the figures of the run.

    Attributes
    ----------
    mesh : Mesh
        Triangles (2D) or tetrahedra (3D), every one positive.
    stats : dict
        ``use`` (generation, correction or optimization), ``sur`` (Sur(𝒯)
        at the start and after each pass), ``measure`` (the area or volume
        the series tends to), ``sweeps`` (passes), ``inverted_before`` and
        ``inverted_after`` (non-positive elements), ``points_inserted``,
        ``points_removed``, ``operators`` (replacements by sub-topology and
        operator), ``least_quality_before`` / ``least_quality_after`` (the
        measure of (8.2)), ``stages``.
    quality : dict
        :func:`meshcore.mesh.quality.report` of the mesh, made on first use
        (it costs as much as the second stage on large meshes).
    """

    mesh: Mesh
    stats: dict = field(default_factory=dict)

    @cached_property
    def quality(self) -> dict:
        """:func:`meshcore.mesh.quality.report` of the mesh."""
        return quality.report(self.mesh)


# ----------------------------------------------------------------------------- input checks


def _cell_loc(mesh: Mesh, c: int) -> list:
    for b, block in enumerate(mesh.cells):
        if c < len(block):
            return ["mesh", "cells", b, "data", int(c)]
        c -= len(block)
    return ["mesh", "cells"]


def _refuse(mesh: Mesh, cells: np.ndarray, what: str, code: str) -> None:
    cells = np.unique(cells)
    listed = ", ".join(str(int(i)) for i in cells[:10])
    more = f" (and {len(cells) - 10} more)" if len(cells) > 10 else ""
    msg = f"{len(cells)} cell(s) {what}: {listed}{more}"
    errors = [{"loc": _cell_loc(mesh, int(i)), "msg": msg, "type": code} for i in cells[:10]]
    raise InputError(msg, code=code, errors=errors)


def _mesh_cells(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Points and the one cell type's rows (triangles in the plane, or tetrahedra)."""
    if not isinstance(mesh, Mesh):
        raise InputError("mesh must be a Mesh", loc=("mesh",), code="bad_shape")
    try:
        mesh.check()
    except InputError as exc:
        raise exc.prefixed("mesh") from None
    want = "triangle" if mesh.dim == 2 else "tetra"
    for b, block in enumerate(mesh.cells):
        if block.type != want and len(block):
            raise InputError(
                f"cell block {b} holds {block.type} cells; with {mesh.dim}D points the method "
                f"takes {want} cells only",
                loc=("mesh", "cells", b, "type"),
                code="unsupported_cell_type",
            )
    blocks = [b.data for b in mesh.cells if b.type == want]
    cells = np.concatenate(blocks) if len(blocks) > 1 else blocks[0]
    return mesh.points, np.ascontiguousarray(cells, dtype=np.int64)


_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])  # outward for a positive tet


def _facets(cells: np.ndarray) -> np.ndarray:
    """Oriented facets ``(m * f, d)``: triangle edges, or tet faces seen from outside."""
    if cells.shape[1] == 3:
        return np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2)
    return cells[:, _FACES].reshape(-1, 3)


def check_topology(mesh: Mesh, cells: np.ndarray | None = None) -> np.ndarray:
    """Refuse a cell set that is not a mesh topology (Definition 8.1); its boundary facets.

    Every edge (2D) or face (3D) must be held by one or two cells, and two
    cells sharing one must run through it in opposite directions (a
    consistent orientation). Returns the oriented boundary facets, sorted
    rows ``(k, 2)`` or ``(k, 3)`` as they appear in the cells.

    Raises
    ------
    InputError
        ``nonmanifold_edge`` / ``nonmanifold_face`` or
        ``inconsistent_orientation``, naming the cells.
    """
    if cells is None:
        cells = _mesh_cells(mesh)[1]
    f = _facets(cells)
    per = 3 if cells.shape[1] == 3 else 4
    key = np.sort(f, axis=1)
    n = int(cells.max()) + 1
    if n ** key.shape[1] < 2**62:
        flat = key[:, 0] * n + key[:, 1]
        if key.shape[1] == 3:
            flat = flat * n + key[:, 2]
        _, inv, count = np.unique(flat, return_inverse=True, return_counts=True)
    else:
        _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    word = "edge" if per == 3 else "face"
    many = count[inv] > 2
    if many.any():
        _refuse(
            mesh,
            np.flatnonzero(many) // per,
            f"share an {word} with two or more others (not a mesh topology, Definition 8.1)",
            f"nonmanifold_{word}",
        )
    two = np.flatnonzero(count[inv] == 2)
    order = two[np.argsort(inv[two], kind="stable")]
    h1, h2 = order[0::2], order[1::2]
    # the same facet with the same orientation in both cells
    if per == 3:
        same = f[h1, 0] == f[h2, 0]
    else:
        r1 = np.roll(f[h2], 1, axis=1)
        r2 = np.roll(f[h2], 2, axis=1)
        same = (f[h1] == f[h2]).all(1) | (f[h1] == r1).all(1) | (f[h1] == r2).all(1)
    if same.any():
        _refuse(
            mesh,
            np.r_[h1[same], h2[same]] // per,
            "are oriented against a neighbour (a shared " + word + " runs the same way in both)",
            "inconsistent_orientation",
        )
    return f[count[inv] == 1]


def check_input(mesh=None, domain=None, *, surface=None, keep_boundary=True) -> None:
    """Raise the InputError :func:`optimize` would raise for these inputs (before running)."""
    _inputs(mesh, domain, keep_boundary, surface)


def _inputs(mesh, domain, keep_boundary, surface=None):
    if sum(x is not None for x in (mesh, domain, surface)) != 1:
        raise InputError("give exactly one of mesh, domain or surface", loc=(), code="bad_input")
    if surface is not None:
        if not keep_boundary:
            raise InputError(
                "keep_boundary=false goes with domain input",
                loc=("keep_boundary",),
                code="bad_input",
            )
        surf = as_surface(surface)
        if surf.shell_count != 1:
            raise InputError(
                f"the surface has {surf.shell_count} shells; generation takes one closed shell "
                "(no cavities, one body)",
                loc=("surface", "triangles"),
                code="unsupported_input",
            )
        return "surface", surf
    if mesh is not None:
        if not keep_boundary:
            raise InputError(
                "keep_boundary=false goes with domain input (the boundary is split first)",
                loc=("keep_boundary",),
                code="bad_input",
            )
        P, cells = _mesh_cells(mesh)
        bnd = check_topology(mesh, cells)
        if P.shape[1] == 2:
            total = float(np.sum(quality.signed_area(P, cells)))
        else:
            total = float(np.sum(quality.signed_volume(P, cells)))
        if not total != 0.0:
            raise InputError(
                "the cells enclose no area or volume (their signed measures sum to zero)",
                loc=("mesh", "cells"),
                code="degenerate_mesh",
            )
        return "mesh", (P, cells, bnd, total)
    dom = domain if isinstance(domain, Domain) else parse_domain(domain)
    if len(dom.constraints):
        raise InputError(
            "interior constraint segments are not supported by this method",
            loc=("segments",),
            code="unsupported_input",
        )
    return "domain", dom


# ----------------------------------------------------------------------------- the loop state


class LoopState(CellStore):
    """The store of a compiled loop (:class:`meshcore.mesh.tetstore.CellStore`) with its
    kernel: :mod:`.kernel2d` (triangles) or :mod:`.kernel3d` (tetrahedra).

    Adds Sur(𝒯) (:meth:`sur`, criterion (8.1) of §8.3.1) and the count of
    non-positive cells (:meth:`inverted`, exact predicates). ``flat`` is the
    flat rule of :func:`signs`: 0 for triangles and for a given tet mesh
    (judged by the exact orient3d alone), :func:`flatness` of the points in
    tet generation, where the kernel's loops use the same value.
    """

    def __init__(self, kernel, P, cells, fixed, spare_points: int = 0, flat: float = 0.0):
        self.k = kernel
        self.flat = flat
        super().__init__(P, cells, fixed, spare_points)

    def sur(self) -> float:
        """Sur(𝒯): the sum of the unsigned areas (volumes) of the live cells."""
        return float(self.k.sur(self.P, self.T, self.alive, int(self.cnt[N_ROWS])))

    def inverted(self) -> int:
        """Cells that are not positive (exact orient2d / orient3d; flat tets count)."""
        return int(np.sum(signs(self.points(), self.cells(), self.flat) <= 0))


def flatness(P: np.ndarray) -> float:
    """``TOL.flat`` times the diagonal of the bounding box of ``P``: the ``flat`` of
    :func:`signs` and of the 3D kernel's signs, the same wherever the input lies."""
    P = np.asarray(P, dtype=float)
    return TOL.flat * float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))) if len(P) else 0.0


def signs(P: np.ndarray, cells: np.ndarray, flat: float = 0.0) -> np.ndarray:
    """Orientation of every triangle (orient2d) or tetrahedron (-orient3d); > 0 is positive.

    A tetrahedron positive by the exact sign but with 6 V at most ``flat`` times
    the sum of its squared edges gets 0 (flat, :func:`flatness`): the kernels' rule
    (:func:`meshcore.mesh.tetstore.solid`, the same compiled function).
    """
    if cells.shape[1] == 3:
        return orient2d(P[cells[:, 0]], P[cells[:, 1]], P[cells[:, 2]])
    sign = -orient3d(*(P[cells[:, i]] for i in range(4)))
    if flat > 0.0:
        from meshcore.optimize.coupez3d import solid_tets

        # copies, writable: one compiled signature whatever the input's flags
        P = np.array(P, dtype=np.float64, order="C")
        cells = np.array(cells, dtype=np.int64, order="C")
        sign = np.where((sign > 0) & ~solid_tets(P, cells, float(flat)), 0.0, sign)
    return sign


def measure_q(P: np.ndarray, cells: np.ndarray, measure: str) -> np.ndarray:
    """The (8.2) measure of every cell from its unsigned area or volume (as the loops see it)."""
    if cells.shape[1] == 3:
        # copies, writable: one compiled signature whatever the input's flags
        P, cells = np.array(P, dtype=np.float64, order="C"), np.ascontiguousarray(cells)
        return k2.qualities(P, cells, np.int64(MEASURES.index(measure)))
    q = _shape3(P, cells) if measure == "shape" else quality.tetra_radius_ratio(P, cells)
    return np.abs(q)


def _shape3(P, C):
    V = np.abs(quality.signed_volume(P, C))
    e = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    s = sum(np.sum((P[C[:, i]] - P[C[:, j]]) ** 2, axis=1) for i, j in e)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s > 0, 12.0 * (3.0 * V) ** (2.0 / 3.0) / s, 0.0)


def _loop2d(
    state: LoopState,
    allow_remove: bool,
    measure: int,
    max_sweeps: int,
    sweeps: list,
    sur: list,
    ops: dict,
    progress: Progress,
    frac: tuple[float, float],
) -> None:
    """Passes of the synthetic algorithm until stable or ``max_sweeps`` (shared count)."""
    cap = len(state.P)
    todo_ball = np.ones(cap, np.uint8)
    todo_pair = np.ones(cap, np.uint8)
    counters = np.zeros(6, np.int64)
    for _ in range(max_sweeps):
        changed = 0
        for kind, todo in ((k2.BALL, todo_ball), (k2.PAIR, todo_pair), (k2.UNION, todo_ball)):
            if kind == k2.UNION and state.inverted() == 0:
                break
            dirty = np.zeros(cap, np.uint8)
            while True:
                changed, status = k2.sweep(
                    state.P,
                    state.T,
                    state.alive,
                    state.head,
                    state.nxt,
                    state.prv,
                    state.free,
                    state.cnt,
                    state.fixed,
                    todo,
                    dirty,
                    kind,
                    allow_remove,
                    measure,
                    TOL.sur_tie,
                    TOL.quality_gain,
                    counters,
                )
                if status != 2:
                    break
                state.grow_rows()
                todo[:] = 1
            todo_ball |= dirty
            todo_pair |= dirty
            if changed:
                break
        sweeps[0] += 1
        sur.append(state.sur())
        if progress is not None:
            progress(
                frac[0] + (frac[1] - frac[0]) * min(1.0, sweeps[0] / max_sweeps),
                f"pass {sweeps[0]}",
            )
        if not changed:
            break
    for name, c in (
        ("ball_fan", k2.C_FAN),
        ("ball_move", k2.C_MOVE),
        ("ball_kernel_move", k2.C_KERNEL),
        ("pair_flip", k2.C_FLIP),
        ("union_fan", k2.C_UNION),
        ("removed", k2.C_REMOVED),
    ):
        ops[name] = ops.get(name, 0) + int(counters[c])


def barycentric(state: LoopState, sweeps: list, sur: list, ops: dict) -> None:
    """Every free vertex moved at once to the fixed point of the moves to G (§8.3.2).

    The ball move puts a free vertex at G, the centroid of the vertices of
    δℬ_P (its neighbours); passes of it are Gauss-Seidel on the graph
    Laplacian, whose fixed point (the barycentric, Tutte, embedding with
    the rest as given) they approach in a number of passes that grows with
    the tangled region's diameter. The sub-topology is the larger connected
    set of the text: the cells within ``BARYCENTRIC_RINGS`` rings of the
    non-positive ones; its free vertices go to the fixed point at once (one
    sparse factorization, coordinates relative to the fixed vertices'
    centroid), every other vertex stays, and the move is taken only when it
    lowers Sur (8.1); free vertices with no path to a fixed one keep their
    place. Used on a tangled mesh only (correction), before the passes,
    which finish what it leaves: when the set is the whole mesh and the
    boundary convex, Tutte's theorem makes the fixed point valid in the plane.
    """
    P, C = state.points(), state.cells()
    n, per = len(P), C.shape[1]
    i, j = np.triu_indices(per, 1)
    a, b = C[:, i].ravel(), C[:, j].ravel()
    key = unique_ints(edge_keys(a, b, n))
    a, b = key // n, key % n
    adj = coo_matrix((np.ones(2 * len(a)), (np.r_[a, b], np.r_[b, a])), shape=(n, n)).tocsr()
    free = state.fixed[:n] == 0
    free &= np.bincount(C.ravel(), minlength=n) > 0
    near = np.zeros(n, bool)
    near[C[signs(P, C, state.flat) <= 0].ravel()] = True
    for _ in range(BARYCENTRIC_RINGS):
        grown = np.zeros(n, bool)
        grown[C[near[C].any(axis=1)].ravel()] = True
        if (grown == near).all():
            break
        near = grown
    free &= near
    if not free.any():
        return
    ff = adj[free][:, free]
    _, comp = connected_components(ff, directed=False)
    anchored = np.zeros(comp.max() + 1, bool)
    anchored[comp[np.asarray(adj[free][:, ~free].sum(axis=1)).ravel() > 0]] = True
    idx = np.flatnonzero(free)[anchored[comp]]
    if len(idx) == 0:
        return
    solve = np.zeros(n, bool)
    solve[idx] = True
    origin = P[~free].mean(axis=0) if (~free).any() else np.zeros(P.shape[1])
    deg = np.asarray(adj[solve].sum(axis=1)).ravel()
    lap = coo_matrix((deg, (np.arange(len(idx)), np.arange(len(idx))))) - adj[solve][:, solve]
    rhs = adj[solve][:, ~solve] @ (P[~solve] - origin)
    Q = P.copy()
    Q[solve] = splu(lap.tocsc()).solve(np.ascontiguousarray(rhs)) + origin
    if not np.isfinite(Q).all():
        return
    before = state.sur()
    old = state.P[:n].copy()
    state.P[:n] = Q
    after = state.sur()
    if not after < before:
        state.P[:n] = old
        return
    sweeps[0] += 1
    sur.append(after)
    ops["barycentric_move"] = ops.get("barycentric_move", 0) + 1


def by_distance(X: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Row indices of ``X`` by distance to ``c``, nearest first, near ties in index order.

    Squared distances within ``TOL.distance_tie`` of the largest (chained
    from one to the next) tie: the vertices of a symmetric boundary (a
    circle, a ring of polygons) are equidistant from their centroid, and
    only rounding, which a translation or scaling changes, would order them.
    The initial vertex of Op(P, δ𝒮) (§8.3.2, "any point in δ𝒮 could be
    used") then does not depend on where the input lies.
    """
    return near_order(np.sum((X - c) ** 2, axis=1))


def near_order(d: np.ndarray) -> np.ndarray:
    """Indices sorting ``d`` ascending, values within ``TOL.distance_tie`` of the largest
    magnitude of each other (chained) tied and taken in index order: equal values of a
    symmetric input that only rounding, which a translation or scaling changes, would order."""
    order = np.argsort(d, kind="stable")
    ds = d[order]
    if not len(ds):
        return order
    group = np.cumsum(np.diff(ds, prepend=ds[:1]) > TOL.distance_tie * np.abs(ds).max())
    return order[np.lexsort((order, group))]


def _initial_topology(
    P: np.ndarray, S: np.ndarray, seg_ring: np.ndarray, dom: Domain, attempt: int = 0
) -> np.ndarray:
    """The initial mesh topology: Op(P, δ𝒮) per polygon, each hole zipped into it.

    For each polygon, P is the vertex of its outer ring nearest the ring's
    centroid (the ``attempt``-th nearest on a restart), joined to every
    segment of the ring not incident to it (§8.3.2, "Initialization"). A
    hole cannot come from the same operator (P joined to a hole's segments
    would make a cone pinched at P, not an annulus, and no replacement of a
    disk by a disk changes that), so each hole replaces the
    triangle of the current topology whose centroid is nearest the hole's
    centroid by the annulus between the two, zipped spoke by spoke: a mesh
    topology with the right boundary, left to the optimization to untangle.
    """
    tris = []
    holes = []
    for r in range(dom.ring_count):
        ring_segs = S[seg_ring == r]
        if dom.ring_is_hole[r]:
            holes.append(ring_segs)
            continue
        ring = ring_segs[:, 0]
        order = by_distance(P[ring], P[ring].mean(axis=0))
        p = int(ring[order[min(attempt, len(ring) - 1)]])
        keep = (ring_segs[:, 0] != p) & (ring_segs[:, 1] != p)
        s = ring_segs[keep]
        tris.append(np.column_stack([s[:, 0], s[:, 1], np.full(len(s), p)]))
    T = np.concatenate(tris)
    # one short loop per hole (rings, not cells)
    for hs in holes:
        # the hole's vertices along its segments (clockwise: the domain on the left); a
        # reversed ring lists its segments backwards
        hv = hs[:, 0] if hs[0, 1] == hs[1 % len(hs), 0] else hs[::-1, 0]
        c = P[hv].mean(axis=0)
        t = int(by_distance(P[T].mean(axis=1), c)[0])
        T = np.concatenate([np.delete(T, t, axis=0), _zipper(P, T[t], hv[::-1])])
    return T


def _centre_fan(P: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Op(G, δ𝒮) with G the centroid of the boundary vertices, when that is a valid mesh.

    The operator's second case (Figure 8.8 ii, P inside 𝒯): G joined to every
    segment. Valid when G sees every segment from its inner side (exact
    orient2d), i.e. the domain is star-shaped from G. Returns the points
    (G last) and triangles, or None.
    """
    g = P[S[:, 0]].mean(axis=0)
    T = np.column_stack([S, np.full(len(S), len(P))])
    Q = np.vstack([P, g])
    if (orient2d(Q[T[:, 0]], Q[T[:, 1]], Q[T[:, 2]]) > 0).all():
        return Q, T
    return None


def _zipper(P: np.ndarray, outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """Triangles of the annulus between a counter-clockwise triangle and a CCW ring inside it."""
    k = len(inner)
    b0 = int(np.argmin(np.sum((P[inner] - P[outer[0]]) ** 2, axis=1)))
    inner = np.roll(inner, -b0)
    rows = []
    a = b = 0
    # a short loop over the k + 3 spokes of one annulus
    while a < 3 or b < k:
        if b >= k or (a < 3 and a / 3 <= b / k):
            rows.append((outer[a % 3], outer[(a + 1) % 3], inner[b % k]))
            a += 1
        else:
            rows.append((inner[(b + 1) % k], inner[b % k], outer[a % 3]))
            b += 1
    return np.array(rows, np.int64)


def _split_counts(dom: Domain, size: float) -> np.ndarray:
    """Pieces of each boundary segment split evenly to at most ``size``."""
    P, S = dom.points, dom.segments
    pieces = np.ceil(np.linalg.norm(P[S[:, 1]] - P[S[:, 0]], axis=1) / size)
    if not (pieces < 2**40).all():
        raise InputError(
            f"size {size:.6g} would split a boundary segment into {pieces.max():.6g} pieces",
            loc=("size",),
            code="too_many_points",
        )
    return np.maximum(1, pieces.astype(np.int64))


def _split_boundary(dom: Domain, size: float) -> tuple[np.ndarray, np.ndarray]:
    """The domain's points and segments with each segment split evenly to at most ``size``."""
    P, S = dom.points, dom.segments
    a, b = P[S[:, 0]], P[S[:, 1]]
    k = _split_counts(dom, size)
    extra = k - 1
    n = len(P)
    start = n + np.r_[0, np.cumsum(extra)[:-1]]
    seg_id = np.repeat(np.arange(len(S)), extra)
    step = np.arange(extra.sum()) - np.repeat(start - n, extra) + 1
    t = (step / k[seg_id])[:, None]
    newP = a[seg_id] * (1 - t) + b[seg_id] * t
    chain_first = S[:, 0]
    rows = []
    for_ids = np.repeat(np.arange(len(S)), k)
    j = np.arange(k.sum()) - np.repeat(np.r_[0, np.cumsum(k)[:-1]], k)
    base = start[for_ids] + j - 1
    u = np.where(j == 0, chain_first[for_ids], base)
    v = np.where(j == k[for_ids] - 1, S[for_ids, 1], base + 1)
    rows = np.column_stack([u, v])
    return np.vstack([P, newP]), rows


def _check_point_count(kind: str, data, size: float) -> None:
    """Refuse a ``size`` whose insertion stage would exceed :data:`MAX_POINTS` points
    (about 1.25 area / size² in 2D, measured; volume / size³ in 3D), before anything
    is allocated for them."""
    if kind == "domain":
        extent, expected = data.area, 1.25 * data.area / size / size
    else:
        extent, expected = data.volume, data.volume / size / size / size
    if expected > MAX_POINTS:
        raise InputError(
            f"size {size:.6g} would insert about {expected:.3g} points in "
            f"{'an area' if kind == 'domain' else 'a volume'} of {extent:.6g}; at most "
            f"{MAX_POINTS:,}: ask for a larger size",
            loc=("size",),
            code="too_many_points",
        )


def _insert_stage(
    state: LoopState, size: float, min_angle: float, area: float, sweeps: list, sur: list, ops: dict
) -> dict:
    """Second stage (§8.3.3): pairs made Delaunay, then points at bad triangles (:mod:`.refine2d`).

    Bad: least angle under ``min_angle``, or a circumradius over ``0.8 size`` (not on a
    boundary segment longer than that allows).
    Returns the stage's counts (pair replacements, circumcentres or off-centres,
    segment apexes, triangles given up, whether the point budget stopped it).
    """

    def neighbours():
        return r2.neighbours(state.T, state.alive, int(state.cnt[N_ROWS]), len(state.P))

    n0 = int(state.cnt[N_PTS])
    # about 1.1 area / size² interior points come out at the circumradius bound (measured)
    expected = int(1.25 * area / size / size) + n0  # at most MAX_POINTS (_check_point_count)
    budget = n0 + r2.BUDGET_FACTOR * expected + 64
    if len(state.P) < expected:
        state.grow_points(expected - n0)
    if state.T.shape[0] < 2 * len(state.P) + 64:
        state.grow_rows(2 * len(state.P) + 64 - 2 * state.T.shape[0])
    counts = np.zeros(4, np.int64)
    N = neighbours()
    counts[r2.K_FLIP] = r2.delaunay_pairs(
        state.P,
        state.T,
        N,
        state.alive,
        state.head,
        state.nxt,
        state.prv,
        state.cnt,
        np.empty(WORK_SIZE),
    )
    ver = np.zeros(state.T.shape[0], np.int64)
    stack = np.empty((2, state.T.shape[0]), np.int64)
    prm = np.array(
        [
            math.sin(math.radians(min_angle)) ** 2,
            (r2.CIRCUMRADIUS * size) * (r2.CIRCUMRADIUS * size),
            r2.OFFCENTRE / math.tan(math.radians(min_angle) / 2.0),
            size,
        ]
    )
    while True:
        status = r2.refine(
            state.P,
            state.T,
            N,
            state.alive,
            state.head,
            state.nxt,
            state.prv,
            state.free,
            state.cnt,
            state.fixed,
            ver,
            stack,
            prm,
            budget,
            counts,
        )
        if status in (r2.DONE, r2.BUDGET):
            break
        if status == r2.NEED_POINTS:
            n = int(state.cnt[N_PTS])
            state.grow_points(min(budget, 2 * n) - n + 2)
        elif status == r2.NEED_ROWS:
            state.grow_rows()
        elif status == r2.NEED_STACK:
            stack = np.empty((2, 2 * stack.shape[1]), np.int64)
        ver = np.zeros(state.T.shape[0], np.int64)
        N = neighbours()
    sweeps[0] += 1
    sur.append(state.sur())
    names = ("delaunay_pair", "steiner_point", "segment_apex", "given_up")
    for name, c in zip(names, counts, strict=True):
        ops[name] = ops.get(name, 0) + int(c)
    return {"budget_reached": status == r2.BUDGET, "given_up": int(counts[r2.K_GIVEN_UP])}


# ----------------------------------------------------------------------------- the method


def _failure(P: np.ndarray, cells: np.ndarray, bad: np.ndarray, use: str, sweeps: int) -> None:
    """Raise the AlgorithmError of a run that did not reach a valid mesh."""
    idx = np.flatnonzero(bad)
    where = "; ".join(
        f"cell {int(i)} at ({', '.join(f'{x:.6g}' for x in P[cells[i]].mean(axis=0))})"
        for i in idx[:10]
    )
    more = f" (and {len(idx) - 10} more)" if len(idx) > 10 else ""
    lo, hi = (
        P[cells[idx]].reshape(-1, P.shape[1]).min(0),
        P[cells[idx]].reshape(-1, P.shape[1]).max(0),
    )
    raise AlgorithmError(
        f"{use}: no valid mesh reached after {sweeps} passes: {len(idx)} element(s) still "
        f"inverted or flat, within the box {lo.tolist()} - {hi.tolist()}: {where}{more}",
        code="not_converged",
    )


def compact(P: np.ndarray, cells: np.ndarray, n_keep: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Points referenced by ``cells`` (or among the first ``n_keep``), in order; cells renumbered.

    Returns the points, the cells and how many points were dropped (removed by fans).
    """
    used = np.zeros(len(P), bool)
    used[cells.ravel()] = True
    used[:n_keep] = True
    new = np.cumsum(used) - 1
    return P[used], new[cells], int(len(P) - used.sum())


def optimize(
    mesh: Mesh | None = None,
    *,
    domain=None,
    surface=None,
    insert_points: bool | None = None,
    size: float | None = None,
    quality: str = "shape",
    max_sweeps: int = 200,
    keep_boundary: bool = True,
    min_angle: float = 25.0,
    progress: Progress = None,
) -> OptimizationResult:
    """Generate, correct or optimize a simplicial mesh by local sub-topology replacement (§8.3).

    Parameters
    ----------
    mesh : Mesh, optional
        Triangles with ``(n, 2)`` points, or tetrahedra with ``(n, 3)``
        points: a mesh topology (Definition 8.1), possibly tangled. Its
        boundary vertices, edges and faces stay as given.
    domain : Domain or dict, optional
        Or a planar domain (GeoJSON polygon, holes allowed): a triangle mesh
        is generated from its boundary discretization (Figure 8.10).
    surface : Surface or {"points": ..., "triangles": ...}, optional
        Or one closed triangulated surface (a single shell): tetrahedra are
        generated from it (Figure 8.11), its vertices and triangles kept.
    insert_points : bool, optional
        Domain input (default true): the second stage of §8.3.3 adds interior
        points until no circumradius exceeds ``0.8 size`` and every least
        angle reaches ``min_angle`` (but where a point would encroach a
        boundary segment); false keeps the boundary points only. Surface
        input (default true): where the first stage is stuck, Op(G, δ𝒮)
        adds a point G around what is still inverted, then interior edges
        over ``size`` are bisected (their shell joined to the midpoint);
        false keeps the surface's points only. Mesh input (default false):
        true lets a fan remove a free vertex where its ball is inverted;
        false keeps the point set.
    size : float, optional
        Domain or surface input: target edge length (default: the median
        boundary segment or surface edge).
    quality : {"shape", "radius_ratio"}
        The measure of (8.2), from the unsigned area or volume.
    max_sweeps : int
        Most passes over the sub-topologies (per stage).
    keep_boundary : bool
        True: the boundary as given. False (domain input only): its
        segments are first split evenly to at most ``size``.
    min_angle : float
        Degrees: the quality target of the insertion stage (every triangle
        under it gets a point).
    progress : callable(fraction, message), optional
        May raise to cancel.

    Returns
    -------
    OptimizationResult
        Every element positive by the exact predicates (generated
        tetrahedra also not flat to the input's placement, :data:`TOL`
        ``flat``; a given mesh is judged by the exact sign alone); boundary
        facets exactly the input's (the domain's segments, split evenly
        when ``keep_boundary`` is false; the surface's triangles; the
        mesh's boundary); area or volume preserved; ``stats["sur"]``
        non-increasing within each stage; the least quality not lowered
        on a valid mesh.

    Raises
    ------
    InputError
        Not exactly one input (``bad_input``); a mesh that is not a mesh
        topology (an edge or face in three or more cells, a neighbour
        oriented against another), mixed or unsupported cell types, NaN,
        cells enclosing no area (``degenerate_mesh``); a bad domain or
        surface, interior constraints or a surface of several shells
        (``unsupported_input``); a bad ``quality``, ``max_sweeps`` or
        ``size``; ``keep_boundary`` false without a domain;
        ``too_many_points`` when ``size`` would insert more than
        :data:`~meshcore.triangulation.MAX_POINTS` points or split a
        segment into 2**40 pieces or more. Each named by ``loc``.
    AlgorithmError
        ``not_converged`` when no valid mesh is reached (how many elements
        are still inverted and where); ``topology_broken`` or
        ``boundary_changed`` if the result fails the final check (never a
        wrong mesh returned).

    References
    ----------
    Methods text §8.3.1-§8.3.5.
    """
    if quality not in MEASURES:
        raise InputError(
            f"quality must be one of {', '.join(MEASURES)}", loc=("quality",), code="bad_choice"
        )
    if not (isinstance(max_sweeps, int) and max_sweeps >= 1):
        raise InputError(
            "max_sweeps must be a positive integer", loc=("max_sweeps",), code="bad_value"
        )
    if size is not None and not (math.isfinite(size) and size > 0):
        raise InputError("size must be a positive number", loc=("size",), code="bad_value")
    kind, data = _inputs(mesh, domain, keep_boundary, surface)
    if size is not None and insert_points is not False and kind != "mesh":
        _check_point_count(kind, data, size)
    measure = MEASURES.index(quality)
    if kind == "surface":
        from meshcore.optimize.coupez3d import generate3d

        return generate3d(data, insert_points is not False, size, measure, max_sweeps, progress)
    if kind == "mesh":
        P, cells, bnd, total = data
        if P.shape[1] == 3:
            from meshcore.optimize.coupez3d import optimize3d

            return optimize3d(
                mesh, P, cells, bnd, total, bool(insert_points), measure, max_sweeps, progress
            )
        return _mesh2d(P, cells, bnd, total, bool(insert_points), measure, max_sweeps, progress)
    return _generate2d(
        data,
        insert_points is not False,
        size,
        measure,
        max_sweeps,
        keep_boundary,
        min_angle,
        progress,
    )


def make_result(P, cells, measure, stats):
    """The :class:`OptimizationResult` of the final points and cells; ``stats`` gains the
    least quality after (the (8.2) measure, §8.3.1)."""
    mesh = Mesh(P, (CellBlock("triangle" if cells.shape[1] == 3 else "tetra", cells),))
    stats["least_quality_after"] = float(measure_q(P, cells, MEASURES[measure]).min())
    return OptimizationResult(mesh, stats)


def _mesh2d(P, T, bnd, total, allow_remove, measure, max_sweeps, progress):
    if total < 0:  # clockwise throughout: normalized to counter-clockwise
        T = T[:, ::-1].copy()
        bnd = bnd[:, ::-1]
    n = len(P)
    fixed = np.zeros(n, np.uint8)
    fixed[bnd.ravel()] = 1
    sign = orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]])
    inverted = int(np.sum(sign <= 0))
    use = "correction" if inverted else "optimization"
    q0 = float(measure_q(P, T, MEASURES[measure]).min())
    state = LoopState(k2, P, T, fixed)
    sweeps, sur, ops = [0], [state.sur()], {}
    if inverted:
        barycentric(state, sweeps, sur, ops)
    _loop2d(state, allow_remove, measure, max_sweeps, sweeps, sur, ops, progress, (0.0, 1.0))
    Pn, Tn = state.points(), state.cells()
    verify(Pn, Tn, bnd, use, sweeps[0])
    Pn, Tn, removed = compact(Pn, Tn, 0)
    stats = {
        "use": use,
        "sur": sur,
        "measure": abs(total),
        "sweeps": sweeps[0],
        "inverted_before": inverted,
        "inverted_after": 0,
        "points_inserted": 0,
        "points_removed": removed,
        "operators": ops,
        "least_quality_before": q0,
        "stages": 1,
    }
    return make_result(Pn, Tn, measure, stats)


def verify(P, cells, bnd, use, sweeps, flat=0.0):
    """Every cell positive (exact; no tet flat to ``flat``, :func:`signs`), a mesh topology,
    boundary facets exactly ``bnd``."""
    if cells.shape[1] == 3 and len(cells):
        # a writable copy: one compiled signature whether bnd is read-only or not
        if k2.check_mesh(P, cells, np.array(bnd, dtype=np.int64, order="C")):
            return
    sign = signs(P, cells, flat)
    if (sign <= 0).any():
        _failure(P, cells, sign <= 0, use, sweeps)
    try:
        got = check_topology(
            Mesh(P, (CellBlock("triangle" if cells.shape[1] == 3 else "tetra", cells),)), cells
        )
    except InputError as exc:  # the loop broke the topology: a failure, never a bad mesh
        raise AlgorithmError(
            f"{use}: the result is not a mesh topology ({exc.message}); no mesh is returned",
            code="topology_broken",
        ) from None

    def canon(f):
        if f.shape[1] == 2:
            return np.unique(f, axis=0)
        r = np.argmin(f, axis=1)
        f = np.stack([f[np.arange(len(f)), (r + i) % 3] for i in range(3)], axis=1)
        return np.unique(f, axis=0)

    a, b = canon(got), canon(bnd)
    if a.shape != b.shape or not (a == b).all():
        raise AlgorithmError(
            f"{use}: the boundary changed ({len(got)} boundary facets for {len(bnd)} given); "
            "no mesh is returned",
            code="boundary_changed",
        )
    if cells.shape[1] == 3 and len(cells):  # check_mesh refused what the above let through
        raise AlgorithmError(
            f"{use}: the result is not a mesh bounded by the input's edges; no mesh is returned",
            code="topology_broken",
        )


def _generate2d(dom: Domain, insert, size, measure, max_sweeps, keep_boundary, min_angle, progress):
    seglen = np.linalg.norm(dom.points[dom.segments[:, 1]] - dom.points[dom.segments[:, 0]], axis=1)
    h = float(size) if size is not None else float(np.median(seglen))
    if keep_boundary:
        P, S = dom.points, dom.segments
    else:
        P, S = _split_boundary(dom, h)
    if keep_boundary:
        seg_ring = dom.segment_ring
    else:
        seg_ring = np.repeat(dom.segment_ring, _split_counts(dom, h))
    restarts = []
    centre = _centre_fan(P, S) if insert and dom.ring_count == 1 else None
    for attempt in range(RESTARTS):
        if centre is not None:
            P0, T = centre
            fixed = np.r_[np.ones(len(P), np.uint8), np.uint8(0)]
        else:
            P0, T = P, _initial_topology(P, S, seg_ring, dom, attempt)
            fixed = np.ones(len(P), np.uint8)
        state = LoopState(k2, P0, T, fixed, spare_points=len(P) if insert else 0)
        inverted = state.inverted()
        sweeps, sur, ops = [0], [state.sur()], {}
        if inverted or not insert:  # valid at once: the second stage takes over
            _loop2d(state, False, measure, max_sweeps, sweeps, sur, ops, progress, (0.0, 0.5))
        left = state.inverted()
        if not left:
            break
        restarts.append({"attempt": attempt, "inverted": left, "sweeps": sweeps[0]})
    stages = 1
    insertion = None
    Pn, Tn = state.points(), state.cells()
    verify(Pn, Tn, S, "generation", sweeps[0])
    if insert:
        stages = 2
        if progress is not None:
            progress(0.5, "insertion")
        insertion = _insert_stage(state, h, min_angle, float(dom.area), sweeps, sur, ops)
        Pn, Tn = state.points(), state.cells()
        verify(Pn, Tn, S, "generation", sweeps[0])
    stats = {
        "use": "generation",
        "sur": sur,
        "measure": float(dom.area),
        "sweeps": sweeps[0],
        "inverted_before": inverted,
        "inverted_after": 0,
        "points_inserted": int(len(Pn) - len(P)),
        "points_removed": 0,
        "operators": ops,
        "least_quality_before": float(measure_q(P0, T, MEASURES[measure]).min()),
        "stages": stages,
        "boundary_points": int(len(P)),
        "restarts": restarts,
    }
    if insertion is not None:
        stats["insertion"] = insertion
    return make_result(Pn, Tn, measure, stats)
