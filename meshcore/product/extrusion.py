r"""Product (extrusion) meshes: a base mesh times a generation line (§8.1).

:func:`extrude` sweeps a base mesh of ``vertex``, ``line``, ``triangle`` and
``quad`` cells through the *sections* of a path (the "semi-manual" method of
§8.1.2); :func:`sweep` computes the sections between a source and a target
section first (the "semi-automatic" method of §8.1.2, after Staten et al.).
Both number the vertices section by section and enumerate the cells layer by
layer with index grids (§8.1.2, "Implementation remarks").

A point gives lines, a line quads, a triangle wedges (pentahedra) and a quad
hexahedra (§8.1.1, Figure 8.1)::

    section k+1   3-------4        wedge (meshio / Gmsh prism numbering)
                  |\     /|        0 1 2: the base triangle on section k,
                  | \   / |        3 4 5: the same triangle on section k+1
                  |  \ /  |        (3 above 0, 4 above 1, 5 above 2)
                  |   5   |
    section k     0---|---1        hexahedron: 0 1 2 3 on section k,
                   \  |  /                     4 5 6 7 above them
                    \ | /
                      2

Choices the text leaves open, and ours:

- **Sections.** Every path is turned into the positions of every base vertex
  on every section, ``(layers + 1, n, 3)``: translation (constant or
  variable steps), rotation, helix (rotation and translation together,
  Figure 8.5 left), one affine map per section ("a function that associates a
  vertex position for each section"), or explicit positions.
- **Degeneracies** (§8.1.1, Figure 8.2). A base vertex whose positions on all
  sections coincide (within :class:`Tolerances`; a vertex on a rotation axis)
  is numbered once. Cells touching such vertices become the admissible type:
  a quad from a line becomes a triangle, a wedge a pyramid (one vertex fixed)
  or a tetrahedron (two), a hexahedron a wedge (an edge of the quad fixed). A
  degeneracy that leaves no admissible cell (a fixed point, a fixed line or
  triangle, a quad with one or two opposite fixed vertices) is an error
  naming the base cell, or dropped and counted with ``on_degenerate="drop"``.
  With ``simplices=True`` the quad with one fixed vertex is fine: its
  tetrahedra simply lose the collapsed ones. No output cell repeats a point.
- **Closed rings.** When the last section coincides with the first (a 360°
  rotation), it *is* the first: no duplicate points, no ``bottom``/``top``.
- **Orientation.** A base in the plane (points ``(n, 2)``) has its clockwise
  cells turned counterclockwise first. Then the whole base is reversed when
  the first layer's total signed volume is negative (a sweep towards -z), so
  that positive cells have positive volume (:mod:`meshcore.mesh.topology`'s
  numbering). A base given in 3D is taken as oriented.
- **Simplices.** ``simplices=True`` splits quads of the base by their shorter
  diagonal, then every wedge into three tetrahedra and every side quad into
  two triangles with the rule of Dompierre et al.: each quad face is cut by
  the diagonal from its lower-numbered base vertex on section k to the other
  one on section k+1. The choice depends on the face alone, so both cells on
  a face cut it alike and the mesh stays conforming.
- **Output.** The swept cells (one block per cell type, layer by layer), then
  the boundary facets of the top-dimensional cells as their own blocks, in
  the cell sets ``bottom`` (section 0, facing outward), ``top`` (last section)
  and ``side`` (the swept boundary of the base), which Gmsh and FEniCS read
  as physical groups. Every block has cell data ``layer`` (the layer of the
  cell, or of the cell a facet bounds) and ``source_cell`` (the base cell it
  comes from, counted over the base's blocks in order). The base's own cell
  data, cell sets and point data are carried along.
- **Validity** (§8.1.3: "must be checked explicitly"). The signed volume of
  every cell (:func:`meshcore.mesh.quality.signed_volume`) must be positive. For a
  translation, a rotation or a helix along its axis the first layer decides
  every other one (a translated prism's volume is linear in its positive
  step; the other paths move the first layer rigidly), so only the first
  layer is computed; other paths compute every cell. Then the swept solid
  must not overlap itself. Where the path and the base prove it cannot (a
  planar base translated; a planar base on one side of a rotation or helix
  axis lying in its plane, turned by at most 360°), no further test runs; a
  rotation past 360° of such a base reports the cells past 360° exactly.
  Otherwise (helices of a full turn or more, affine maps, explicit sections,
  sweeps, non-planar bases) sample points inside every cell (its centroid
  and a point near each corner) are tested against the face planes of the
  cells of non-adjacent layers whose bounding boxes hold them: a sample
  strictly inside such a cell is an overlap. An overlap thinner than about a
  quarter of the local cell size may escape that test; a fold between
  adjacent layers is left to the volume check. For bases of lines and
  vertices (surfaces and curves) the check is the cell measure and the
  rotation angle only.

References
----------
Methods text §8.1.1 (correspondences and degeneracies, Figures 8.1, 8.2),
§8.1.2 (computing the intermediate vertices; implementation remarks), §8.1.3
(validity must be checked explicitly), §8.1.4 (Figure 8.5). J. Dompierre, P.
Labbé, M.-G. Vallet, R. Camarero, "How to subdivide pyramids, prisms and
hexahedra into tetrahedra", 8th International Meshing Roundtable (1999).
M. L. Staten, S. A. Canann, S. J. Owen, "BMSweep: locating interior nodes
during sweeping", Engineering with Computers 15 (1999).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from meshcore.delaunay.kernel2d import delaunay
from meshcore.errors import InputError
from meshcore.geometry import orient2d
from meshcore.geometry.tolerances import TOLERANCES, Tolerances
from meshcore.mesh import CELL_TYPES, CellBlock, Mesh, quality, topology
from meshcore.product.paths import (
    Helix,
    Path,
    Rotate,
    Sections,
    Transforms,
    Translate,
    _finite_sections,
    _layers,
    _vector,
)
from meshcore.product.validity import (
    _along_axis,
    _check_measures,
    _check_overlap,
    _local,
    _plane,
    _report,
)

__all__ = [
    "Helix",
    "Path",
    "ProductResult",
    "Rotate",
    "Sections",
    "Transforms",
    "Translate",
    "check_extrude",
    "check_sweep",
    "extrude",
    "sweep",
    "sweep_boundary",
]

Progress = Callable[[float, str], None] | None

_BASE_TYPES = ("vertex", "line", "triangle", "quad")


# ----------------------------------------------------------------------------- the base


@dataclass(frozen=True, eq=False)
class _Base:
    """A checked base: 3D points and blocks of vertex/line/triangle/quad cells."""

    points: np.ndarray  # (n, 3)
    blocks: tuple[CellBlock, ...]
    offsets: np.ndarray  # global index of each block's first cell
    mesh: Mesh

    @property
    def dim(self) -> int:
        return max(CELL_TYPES[b.type][1] for b in self.blocks)


def _base(mesh: Mesh, loc: tuple = ("mesh",)) -> _Base:
    if not isinstance(mesh, Mesh):
        raise InputError("the base must be a Mesh", loc=loc, code="bad_type")
    try:
        mesh.check()
    except InputError as exc:
        raise exc.prefixed(*loc) from None
    for b, block in enumerate(mesh.cells):
        if block.type not in _BASE_TYPES:
            raise InputError(
                f"cell block {b} has {block.type} cells; a base mesh holds only "
                f"{', '.join(_BASE_TYPES)} cells",
                loc=(*loc, "cells", b, "type"),
                code="unsupported_cell_type",
            )
    pts = mesh.points
    planar = pts.shape[1] == 2
    if planar:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    blocks = []
    for block in mesh.cells:
        data = block.data
        if planar and block.type in ("triangle", "quad") and len(data):
            cw = _clockwise(mesh.points, data)
            if cw.any():
                data = data.copy()
                data[cw] = data[cw][:, ::-1]
        blocks.append(CellBlock(block.type, data))
    offsets = np.cumsum([0] + [len(b) for b in blocks])
    return _Base(np.ascontiguousarray(pts), tuple(blocks), offsets, mesh)


def _clockwise(pts: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Triangles or quads of the plane that turn clockwise, by exact orientation tests.

    A quad's sense is that of its halves 0 1 2 and 0 2 3; when they disagree
    (a non-convex or flat quad) the sign of its area decides.
    """
    p = [pts[cells[:, j]] for j in range(cells.shape[1])]
    sense = orient2d(p[0], p[1], p[2]).astype(np.int64)
    if cells.shape[1] == 4:
        sense += orient2d(p[0], p[2], p[3])
        unsure = np.flatnonzero(np.abs(sense) < 2)
        if len(unsure):
            sense[unsure] = np.sign(quality.signed_area(pts, cells[unsure], "quad"))
    return sense < 0


def _reversed(blocks: Sequence[CellBlock]) -> tuple[CellBlock, ...]:
    """The blocks with every triangle and quad turned the other way."""
    return tuple(
        CellBlock(b.type, b.data[:, ::-1]) if b.type in ("triangle", "quad") else b for b in blocks
    )


# ----------------------------------------------------------------------------- cell templates

# A template lists, for each node of an output cell, (layer offset, base column):
# the node is base vertex ``cell[column]`` on section ``k + offset``.
_T = tuple[tuple[int, int], ...]

_VERTEX_LINE: _T = ((0, 0), (1, 0))
_LINE_QUAD: _T = ((0, 0), (0, 1), (1, 1), (1, 0))
_LINE_TRI = {0: ((0, 0), (0, 1), (1, 1)), 1: ((0, 0), (0, 1), (1, 0))}  # by the fixed column
_WEDGE: _T = ((0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2))
_PYRAMID: _T = ((1, 1), (1, 2), (0, 2), (0, 1), (0, 0))  # column 0 fixed: the apex
_TETRA: _T = ((0, 0), (0, 1), (0, 2), (1, 0))  # columns 1 and 2 fixed
_HEX: _T = ((0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (1, 1), (1, 2), (1, 3))
_QUAD_WEDGE: _T = ((0, 0), (0, 3), (1, 3), (0, 1), (0, 2), (1, 2))  # columns 0 and 1 fixed

# Wedge -> 3 tetrahedra, base rolled so that column 0 has the least vertex
# number (p); q, r = columns 1, 2. Each tetrahedron holds exactly one
# vertical edge, named by its column: it collapses when that vertex is fixed.
_WEDGE_TETS = {
    True: (  # q < r: face q-r cut from q (section k) to r (k+1)
        (((0, 0), (0, 1), (0, 2), (1, 2)), 2),
        (((0, 0), (0, 1), (1, 2), (1, 1)), 1),
        (((0, 0), (1, 1), (1, 2), (1, 0)), 0),
    ),
    False: (  # r < q: face q-r cut from r (section k) to q (k+1)
        (((0, 0), (0, 1), (0, 2), (1, 1)), 1),
        (((0, 0), (1, 1), (0, 2), (1, 2)), 2),
        (((0, 0), (1, 1), (1, 2), (1, 0)), 0),
    ),
}
# Side quad a0 b0 b1 a1 -> 2 triangles, by which of a, b has the lesser number.
_QUAD_TRIS = {
    True: ((((0, 0), (0, 1), (1, 1)), 1), (((0, 0), (1, 1), (1, 0)), 0)),  # a < b
    False: ((((0, 0), (0, 1), (1, 0)), 0), (((0, 1), (1, 1), (1, 0)), 1)),  # b < a
}


@dataclass
class _Group:
    """Base cells (rolled) that give one output cell type by one template."""

    type: str
    template: _T
    cells: np.ndarray  # (m, k) rolled base cells
    source: np.ndarray  # (m,) global base cell ids


@dataclass
class _Plan:
    groups: list[_Group] = field(default_factory=list)
    dropped: int = 0

    def add(self, cell_type: str, template: _T, cells: np.ndarray, source: np.ndarray) -> None:
        if len(cells):
            self.groups.append(_Group(cell_type, template, cells, source))


def _roll(cells: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Each row turned cyclically so that column ``start[i]`` comes first."""
    k = cells.shape[1]
    cols = (start[:, None] + np.arange(k)) % k
    return np.take_along_axis(cells, cols, axis=1)


def _split_quads(cells: np.ndarray, pts: np.ndarray, fixed: np.ndarray):
    """Quads as two triangles each: (triangles (2m, 3), quad of each triangle (2m,)).

    The shorter diagonal, or the one through a fixed vertex when a quad has
    exactly one (so that both halves keep their tetrahedra admissible).
    """
    d02 = np.sum((pts[cells[:, 2]] - pts[cells[:, 0]]) ** 2, axis=1)
    d13 = np.sum((pts[cells[:, 3]] - pts[cells[:, 1]]) ** 2, axis=1)
    use13 = d13 < d02
    f = fixed[cells]
    one = f.sum(axis=1) == 1
    use13[one] = f[one][:, 1] | f[one][:, 3]
    rolled = np.where(use13[:, None], np.roll(cells, -1, axis=1), cells)
    tris = np.concatenate([rolled[:, [0, 1, 2]], rolled[:, [0, 2, 3]]])
    owner = np.concatenate([np.arange(len(cells))] * 2)
    return tris, owner


def _plan(base_blocks, offsets, fixed, pts, simplices: bool) -> tuple[_Plan, list]:
    """How each base cell is swept; and the inadmissible cells as (block, cell) pairs."""
    plan = _Plan()
    bad: list[tuple[int, np.ndarray]] = []
    for b, block in enumerate(base_blocks):
        data = block.data
        src = offsets[b] + np.arange(len(data))
        f = fixed[data]
        nf = f.sum(axis=1)
        if block.type == "vertex":
            plan.add("line", _VERTEX_LINE, data[nf == 0], src[nf == 0])
            bad.append((b, np.flatnonzero(nf == 1)))
        elif block.type == "line":
            if simplices:
                for less in (True, False):
                    sel = (data[:, 0] < data[:, 1]) == less
                    for tmpl, vertical in _QUAD_TRIS[less]:
                        keep = sel & ~f[:, vertical]
                        plan.add("triangle", tmpl, data[keep], src[keep])
            else:
                plan.add("quad", _LINE_QUAD, data[nf == 0], src[nf == 0])
                for col in (0, 1):
                    sel = (nf == 1) & f[:, col]
                    plan.add("triangle", _LINE_TRI[col], data[sel], src[sel])
            bad.append((b, np.flatnonzero(nf == 2)))
        elif block.type == "triangle" or (block.type == "quad" and simplices):
            if block.type == "quad":
                tris, owner = _split_quads(data, pts, fixed)
                tsrc, ff = src[owner], fixed[tris]
                bad.append(
                    (
                        b,
                        np.flatnonzero(
                            np.bincount(owner, ff.sum(axis=1) == 3, minlength=len(data)) == 2
                        ),
                    )
                )
            else:
                tris, tsrc, ff = data, src, f
            if simplices:
                _plan_tets(plan, tris, tsrc, fixed)
                if block.type == "triangle":
                    bad.append((b, np.flatnonzero(ff.sum(axis=1) == 3)))
            else:
                nt = ff.sum(axis=1)
                plan.add("wedge", _WEDGE, tris[nt == 0], tsrc[nt == 0])
                one = nt == 1
                plan.add(
                    "pyramid", _PYRAMID, _roll(tris[one], np.argmax(ff[one], axis=1)), tsrc[one]
                )
                two = nt == 2
                plan.add("tetra", _TETRA, _roll(tris[two], np.argmin(ff[two], axis=1)), tsrc[two])
                bad.append((b, np.flatnonzero(nt == 3)))
        else:  # quad, not split
            plan.add("hexahedron", _HEX, data[nf == 0], src[nf == 0])
            pair = f & np.roll(f, -1, axis=1)  # columns i and i+1 both fixed
            edge = (nf == 2) & pair.any(axis=1)
            plan.add(
                "wedge", _QUAD_WEDGE, _roll(data[edge], np.argmax(pair[edge], axis=1)), src[edge]
            )
            bad.append((b, np.flatnonzero((nf > 0) & ~(nf == 0) & ~edge)))
    return plan, bad


def _plan_tets(plan: _Plan, tris: np.ndarray, src: np.ndarray, fixed: np.ndarray) -> None:
    rolled = _roll(tris, np.argmin(tris, axis=1))
    f = fixed[rolled]
    for less in (True, False):
        sel = (rolled[:, 1] < rolled[:, 2]) == less
        for tmpl, vertical in _WEDGE_TETS[less]:
            keep = sel & ~f[:, vertical]
            plan.add("tetra", tmpl, rolled[keep], src[keep])


# ----------------------------------------------------------------------------- numbering


@dataclass(frozen=True, eq=False)
class _Numbering:
    """Point ids of base vertex ``v`` on section ``k``: ``idx[k, v]``, ``(layers + 1, n)``.

    Sections are numbered one after the other, each listing its own (not
    fixed) base vertices in base order; a fixed vertex keeps its section-0
    id, and a closed ring's last section is its first. Without fixed
    vertices the numbering is *plain*: ``idx[k, v] = k n + v`` (but for a
    closed ring's last row), and the points are a view of the sections.
    """

    idx: np.ndarray
    points: np.ndarray
    free: np.ndarray  # base vertices numbered on every section
    stored: int  # sections holding points of their own
    plain: bool
    closed: bool

    @property
    def layers(self) -> int:
        return len(self.idx) - 1

    def point_source(self) -> np.ndarray:
        """The base vertex of each output point."""
        n = self.idx.shape[1]
        return np.concatenate([np.arange(n), np.tile(self.free, self.stored - 1)])


def _numbering(X: np.ndarray, fixed: np.ndarray, closed: bool) -> _Numbering:
    S, n = X.shape[:2]
    stored = S - 1 if closed else S
    free = np.flatnonzero(~fixed)
    nf = len(free)
    if nf == n:
        idx = np.arange(S * n, dtype=np.int64).reshape(S, n)
        if closed:
            idx[-1] = idx[0]
        return _Numbering(idx, X[:stored].reshape(-1, 3), free, stored, True, closed)
    idx = np.empty((S, n), dtype=np.int64)
    idx[:] = np.arange(n)
    if stored > 1:
        idx[1:stored, free] = n + np.arange((stored - 1) * nf).reshape(stored - 1, nf)
    if closed:
        idx[-1] = idx[0]
    points = np.concatenate([X[0], X[1:stored][:, free].reshape(-1, 3)])
    return _Numbering(idx, points, free, stored, False, closed)


def _gather(num: _Numbering, template: _T, cells: np.ndarray, layers=None) -> np.ndarray:
    """Output cells ``(len(layers) * m, k)``, layer-major, from a template (all layers by default).

    A plain numbering needs no lookup: the first layer's cells plus ``k n``
    (§8.1.2: "the element vertex enumeration is trivial"). Otherwise each
    layer looks its two sections up in ``idx``.
    """
    idx, L = num.idx, num.layers
    n = idx.shape[1]
    offs = np.array([o for o, _ in template])
    cols = np.array([c for _, c in template])
    first = cells[:, cols]  # (m, k) base vertices
    layers = np.arange(L) if layers is None else np.asarray(layers)
    out = np.empty((len(layers), len(cells), len(template)), dtype=np.int64)
    if num.plain:
        np.add(first + offs * n, (layers * n)[:, None, None], out=out)
        last = np.flatnonzero(layers == L - 1)
        if len(last) and num.closed:  # the last section is the first
            up = offs == 1
            out[last[0]][:, up] = first[:, up]
    else:
        for i, k in enumerate(layers):
            out[i] = idx[k + offs, first]
    return out.reshape(-1, len(template))


# ----------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class ProductResult:
    """The product mesh and what happened on the way.

    Attributes
    ----------
    mesh : Mesh
        3D points; swept cells then boundary facets (see the module docstring).
    layers : int
        Layers of cells (sections minus one).
    closed : bool
        The last section was the first (a closed ring).
    fixed_vertices : int
        Base vertices numbered once because they stay put along the path (on
        the rotation axis).
    dropped : int
        Degenerate base cells dropped (``on_degenerate="drop"``).
    validated : bool
        Whether the validity checks ran (all passed, or an error was raised).
    boundary_vertices : (nb,) int64 or None
        For :func:`sweep`: the source's boundary vertices, in the order of
        ``target`` (when it holds them only) and of each ``sides`` section.
    """

    mesh: Mesh
    layers: int
    closed: bool
    fixed_vertices: int
    dropped: int
    validated: bool
    boundary_vertices: np.ndarray | None = None

    def stats(self) -> dict:
        """Plain-JSON figures: counts by cell type and the fields above."""
        counts: dict[str, int] = {}
        for block in self.mesh.cells:
            counts[block.type] = counts.get(block.type, 0) + len(block)
        return {
            "points": len(self.mesh.points),
            "cells": counts,
            "layers": self.layers,
            "closed": self.closed,
            "fixed_vertices": self.fixed_vertices,
            "dropped": self.dropped,
            "validated": self.validated,
        }


# ----------------------------------------------------------------------------- the product


def _fixed_and_closed(X: np.ndarray, tol: float) -> tuple[np.ndarray, bool]:
    """Base vertices whose positions coincide on all sections; whether the last is the first."""
    tol2 = tol * tol
    closed = bool(len(X) > 2 and np.all(np.sum((X[-1] - X[0]) ** 2, axis=1) <= tol2))
    worst = np.zeros(X.shape[1])
    for k in range(1, len(X)):
        np.maximum(worst, np.sum((X[k] - X[0]) ** 2, axis=1), out=worst)
    return worst <= tol2, closed


def _volume_sign(pts: np.ndarray, plan: _Plan, num: _Numbering) -> float:
    """Total signed volume of the first layer of the 3D cells."""
    total = 0.0
    zero = np.zeros(1, dtype=np.int64)
    for g in plan.groups:
        if CELL_TYPES[g.type][1] == 3:
            sub, cells = _local(pts, _gather(num, g.template, g.cells, zero))
            total += float(quality.signed_volume(sub, cells, g.type).sum())
    return total


def _boundary_plan(base_blocks, offsets, fixed, dim: int, simplices: bool, pts: np.ndarray):
    """The side facets of the top-dimensional base cells: groups like :func:`_plan`'s.

    Also returns the base top-cell blocks for bottom and top (quads split
    into the triangles of the tetrahedra when ``simplices``).
    """
    top = [(b, blk) for b, blk in enumerate(base_blocks) if CELL_TYPES[blk.type][1] == dim]
    sides = _Plan()
    caps: list[tuple[str, np.ndarray, np.ndarray]] = []
    for b, blk in top:
        src = offsets[b] + np.arange(len(blk))
        if simplices and blk.type == "quad":
            tris, owner = _split_quads(blk.data, pts, fixed)
            caps.append(("triangle", tris, src[owner]))
        else:
            caps.append((blk.type, blk.data, src))
    if dim == 0:
        return sides, caps
    holder = np.concatenate([offsets[b] + np.arange(len(blk)) for b, blk in top])
    bnd = topology.boundary(Mesh(pts, tuple(blk for _, blk in top)))
    for fblock, held in zip(bnd.cells, bnd.cell_data["cell"], strict=True):
        data, src = fblock.data, holder[held]
        f = fixed[data]
        if dim == 1:  # boundary vertices of a curve: lines
            keep = ~f[:, 0]
            sides.add("line", _VERTEX_LINE, data[keep], src[keep])
            continue
        nf = f.sum(axis=1)
        if simplices:
            for less in (True, False):
                sel = (data[:, 0] < data[:, 1]) == less
                for tmpl, vertical in _QUAD_TRIS[less]:
                    keep = sel & ~f[:, vertical]
                    sides.add("triangle", tmpl, data[keep], src[keep])
        else:
            sides.add("quad", _LINE_QUAD, data[nf == 0], src[nf == 0])
            for col in (0, 1):
                sel = (nf == 1) & f[:, col]
                sides.add("triangle", _LINE_TRI[col], data[sel], src[sel])
    return sides, caps


_OUT_ORDER = ("hexahedron", "wedge", "pyramid", "tetra", "quad", "triangle", "line", "vertex")


def _assemble(groups: list[_Group], num: _Numbering):
    """Blocks by output type: (type, cells, layer, source), cells layer-major."""
    L = num.layers
    by_type: dict[str, list[_Group]] = {}
    for g in groups:
        by_type.setdefault(g.type, []).append(g)
    out = []
    for t in sorted(by_type, key=_OUT_ORDER.index):
        gs = by_type[t]
        parts = [_gather(num, g.template, g.cells) for g in gs]
        if len(parts) == 1:
            cells = parts[0]
        else:  # interleave the groups layer by layer
            k = parts[0].shape[1]
            cells = np.concatenate([p.reshape(L, -1, k) for p in parts], axis=1).reshape(-1, k)
        source = np.concatenate([g.source for g in gs])
        m = len(source)
        src = np.empty((L, m), dtype=np.int64)
        src[:] = source
        layer = np.empty((L, m), dtype=np.int64)
        layer[:] = np.arange(L)[:, None]
        out.append((t, cells, layer.reshape(-1), src.reshape(-1)))
    return out


def _product(
    base: _Base,
    X: np.ndarray,
    *,
    simplices: bool,
    on_degenerate: str,
    validate: bool,
    screw: tuple | None,
    translate: bool,
    fault: tuple,
    progress: Progress,
    tolerances: Tolerances,
    boundary_vertices: np.ndarray | None = None,
) -> ProductResult:
    """The product mesh of ``base`` over the sections ``X`` ``(layers + 1, n, 3)``."""
    if on_degenerate not in ("error", "drop"):
        raise InputError(
            f"on_degenerate must be 'error' or 'drop', got {on_degenerate!r}",
            loc=("on_degenerate",),
            code="bad_option",
        )
    tol = tolerances.distance(X)
    if translate:  # every vertex moves by the (nonzero) vector: nothing stays, nothing closes
        fixed, closed = np.zeros(X.shape[1], dtype=bool), False
    else:
        fixed, closed = _fixed_and_closed(X, tol)
    _report(progress, 0.1, "numbering the sections")
    num = _numbering(X, fixed, closed)
    pts = num.points
    blocks = base.blocks
    plan, bad = _plan(blocks, base.offsets, fixed, base.points, simplices)
    dim = base.dim
    if dim == 2 and _volume_sign(pts, plan, num) < 0:
        blocks = _reversed(blocks)
        plan, bad = _plan(blocks, base.offsets, fixed, base.points, simplices)
    n_bad = sum(len(c) for _, c in bad)
    if n_bad and on_degenerate == "error":
        b, cells = next((b, c) for b, c in bad if len(c))
        c = int(cells[0])
        verts = base.blocks[b].data[c]
        hint = "" if simplices else "; simplices: true splits it into admissible tetrahedra"
        raise InputError(
            f"cell {c} of block {b} ({blocks[b].type} {verts.tolist()}) has vertices "
            f"{verts[fixed[verts]].tolist()} fixed along the path (on the axis): its product "
            f"has no admissible cell ({n_bad} such cells){hint}; or set on_degenerate: drop",
            loc=("mesh", "cells", b, "data", c),
            code="degenerate_cell",
        )
    if not plan.groups:
        raise InputError(
            "every base cell degenerates: the product has no cells", loc=fault, code="empty_mesh"
        )
    _report(progress, 0.3, "enumerating the cells")
    swept = _assemble(plan.groups, num)
    side_plan, caps = _boundary_plan(blocks, base.offsets, fixed, dim, simplices, base.points)
    facets = _assemble(side_plan.groups, num)
    L = num.layers

    out_blocks, layer_data, source_data = [], [], []
    sets: dict[str, list[int]] = {"bottom": [], "top": [], "side": []}
    for t, cells, layer, src in swept:
        out_blocks.append(CellBlock(t, cells))
        layer_data.append(layer)
        source_data.append(src)
    cap_flip = {"triangle": [0, 2, 1], "quad": [0, 3, 2, 1], "line": [1, 0], "vertex": [0]}
    if not closed:
        for name, section, layer_id in (("bottom", 0, 0), ("top", L, L - 1)):
            for t, data, src in caps:
                cells = num.idx[section][data]
                if name == "bottom":
                    cells = cells[:, cap_flip[t]]
                sets[name].append(len(out_blocks))
                out_blocks.append(CellBlock(t, cells))
                layer_data.append(np.full(len(cells), layer_id, dtype=np.int64))
                source_data.append(src)
    for t, cells, layer, src in facets:
        sets["side"].append(len(out_blocks))
        out_blocks.append(CellBlock(t, cells))
        layer_data.append(layer)
        source_data.append(src)
    nb = len(out_blocks)
    cell_sets = {
        name: [
            np.arange(len(out_blocks[i])) if i in ids else np.zeros(0, np.int64) for i in range(nb)
        ]
        for name, ids in sets.items()
    }
    cell_data = {"layer": layer_data, "source_cell": source_data}
    _carry(base.mesh, cell_data, cell_sets, source_data, nb)
    point_data = {}
    if base.mesh.point_data:
        source = num.point_source()
        point_data = {k: v[source] for k, v in base.mesh.point_data.items()}
    mesh = Mesh(
        pts, tuple(out_blocks), point_data=point_data, cell_data=cell_data, cell_sets=cell_sets
    )

    if validate:
        _report(progress, 0.5, "checking cell volumes")
        uniform = translate or (screw is not None and _along_axis(screw, tol))
        _check_measures(mesh, len(swept), fault, progress, uniform)
        _report(progress, 0.8, "checking for self-overlap")
        _check_overlap(
            mesh, len(swept), base, screw, translate, closed, tol, tolerances, fault, progress
        )
    _report(progress, 1.0, "product mesh done")
    return ProductResult(mesh, L, closed, int(fixed.sum()), int(n_bad), validate, boundary_vertices)


def _carry(base: Mesh, cell_data: dict, cell_sets: dict, sources: list, nb: int) -> None:
    """The base's cell data and cell sets, on every output cell through ``source_cell``."""
    if base.cell_data:
        for name, arrays in base.cell_data.items():
            if name in cell_data:
                continue
            values = np.concatenate(arrays) if arrays else np.zeros(0)
            cell_data[name] = [values[s] for s in sources]
    for name, ids in base.cell_sets.items():
        if name in cell_sets:
            continue
        member = np.zeros(sum(len(b) for b in base.cells), dtype=bool)
        offset = 0
        for block, a in zip(base.cells, ids, strict=True):
            member[offset + a] = True
            offset += len(block)
        cell_sets[name] = [np.flatnonzero(member[s]) for s in sources[:nb]]


# ----------------------------------------------------------------------------- extrude


def _prefixed(fn, *args, prefix: tuple):
    try:
        return fn(*args)
    except InputError as exc:
        raise exc.prefixed(*prefix) from None


def check_extrude(mesh: Mesh, path: Path) -> None:
    """Check the inputs of :func:`extrude` without building anything heavy.

    Raises
    ------
    InputError
        Located under ``("mesh", ...)`` or ``("path", ...)``.
    """
    _checked(mesh, path)


def _checked(mesh: Mesh, path: Path) -> _Base:
    base = _base(mesh)
    if not isinstance(path, Translate | Rotate | Helix | Transforms | Sections):
        raise InputError(
            "path must be a Translate, Rotate, Helix, Transforms or Sections",
            loc=("path",),
            code="bad_path",
        )
    if isinstance(path, Translate):
        _prefixed(path.offsets, prefix=("path",))
        _prefixed(
            lambda: _vector(path.vector, ("vector",), "vector", nonzero=True), prefix=("path",)
        )
    elif isinstance(path, Rotate | Helix):
        _prefixed(path._screw, prefix=("path",))
    elif isinstance(path, Transforms):
        _prefixed(path._matrices, prefix=("path",))
    else:
        _prefixed(path._positions, base.points, prefix=("path",))
    return base


def extrude(
    mesh: Mesh,
    path: Path,
    *,
    simplices: bool = False,
    on_degenerate: str = "error",
    validate: bool = True,
    tolerances: Tolerances = TOLERANCES,
    progress: Progress = None,
) -> ProductResult:
    """The product of a base mesh and a generation line (§8.1.1, §8.1.2).

    Parameters
    ----------
    mesh : Mesh
        The base: ``vertex``, ``line``, ``triangle`` and ``quad`` cells, mixed
        types allowed; points ``(n, 2)`` (lifted to z = 0) or ``(n, 3)``.
    path : Translate, Rotate, Helix, Transforms or Sections
        The generation line, as the positions of every base vertex on every
        section.
    simplices : bool
        Split the product into triangles and tetrahedra (conforming; see the
        module docstring).
    on_degenerate : {"error", "drop"}
        What to do with a base cell whose product has no admissible cell.
    validate : bool
        Check every cell's signed volume and the self-overlap of the swept
        solid (§8.1.3), raising when they fail.
    tolerances : Tolerances
    progress : callable(fraction, message), optional
        May raise to cancel.

    Returns
    -------
    ProductResult

    Raises
    ------
    InputError
        Bad base or path (located under ``mesh`` or ``path``);
        ``degenerate_cell`` (``loc = ("mesh", "cells", b, "data", c)``);
        ``inverted_cells`` or ``self_overlap`` when validation fails, with one
        error per offending cell (up to 20) naming its block, id, layer and
        source cell (``loc = ("path",)``).

    Examples
    --------
    Two triangles of the unit square, 10 layers of height 0.1: 20 wedges on
    44 points.

    >>> square = Mesh([[0, 0], [1, 0], [1, 1], [0, 1]], [("triangle", [[0, 1, 2], [0, 2, 3]])])
    >>> r = extrude(square, Translate([0, 0, 1], layers=10))
    >>> len(r.mesh.points), r.mesh.cells[0].type, len(r.mesh.cells[0])
    (44, 'wedge', 20)

    References
    ----------
    §8.1.1 (Figures 8.1, 8.2), §8.1.2, §8.1.3.
    """
    base = _checked(mesh, path)
    _report(progress, 0.0, "computing the sections")
    with np.errstate(over="ignore", invalid="ignore"):
        X = _prefixed(path._positions, base.points, prefix=("path",))
    _finite_sections(X, ("path",))
    screw = path._screw() if isinstance(path, Rotate | Helix) else None
    return _product(
        base,
        X,
        simplices=bool(simplices),
        on_degenerate=on_degenerate,
        validate=bool(validate),
        screw=screw,
        translate=isinstance(path, Translate),
        fault=("path",),
        progress=progress,
        tolerances=tolerances,
    )


# ----------------------------------------------------------------------------- sweep


def _source(source: Mesh) -> tuple[_Base, np.ndarray]:
    base = _base(source, ("source",))
    for b, block in enumerate(source.cells):
        if block.type not in ("triangle", "quad"):
            raise InputError(
                f"cell block {b} has {block.type} cells; a sweep source holds triangles and quads",
                loc=("source", "cells", b, "type"),
                code="unsupported_cell_type",
            )
    bnd = topology.boundary(Mesh(base.points, base.blocks))
    verts = np.unique(np.concatenate([blk.data.ravel() for blk in bnd.cells]))
    return base, verts


def sweep_boundary(source: Mesh) -> np.ndarray:
    """The boundary vertices of a sweep source, in the order ``target`` and ``sides`` use.

    Parameters
    ----------
    source : Mesh
        Triangles and quads.

    Returns
    -------
    (nb,) int64
        The vertices on boundary edges, in increasing index order.
    """
    return _source(source)[1]


def _points3(value, loc: tuple, name: str) -> np.ndarray:
    try:
        p = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a list of [x, y, z]", loc=loc, code="bad_shape") from exc
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(
            f"{name} must be a list of [x, y, z], got shape {p.shape}", loc=loc, code="bad_shape"
        )
    bad = ~np.isfinite(p)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise InputError(
            f"{name} point {i} has a non-finite coordinate",
            loc=(*loc, int(i), int(j)),
            code="non_finite",
        )
    return p


def _sweep_inputs(source, target, sides, layers):
    base, bverts = _source(source)
    n, nb = len(base.points), len(bverts)
    tgt = _points3(target, ("target",), "target")
    if len(tgt) not in (n, nb):
        raise InputError(
            f"target must place all {n} source vertices or its {nb} boundary vertices, "
            f"got {len(tgt)} points",
            loc=("target",),
            code="bad_shape",
        )
    if sides is not None:
        try:
            sd = np.asarray(sides, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(
                "sides must be one list of [x, y, z] per intermediate section",
                loc=("sides",),
                code="bad_shape",
            ) from exc
        if sd.size == 0:
            sd = sd.reshape(0, nb, 3)
        for k in range(len(sd)):
            _points3(sd[k] if sd.ndim == 3 else sides[k], ("sides", k), "sides")
        if sd.ndim != 3 or sd.shape[1:] != (nb, 3):
            raise InputError(
                f"each section of sides must place the {nb} boundary vertices, got shape "
                f"{sd.shape}",
                loc=("sides",),
                code="bad_shape",
            )
        if layers is not None and _layers(layers) != len(sd) + 1:
            raise InputError(
                f"layers is {layers} but sides gives {len(sd) + 1} layers",
                loc=("layers",),
                code="bad_layers",
            )
        L = len(sd) + 1
    else:
        if layers is None:
            raise InputError("give layers or sides", loc=("layers",), code="bad_layers")
        L, sd = _layers(layers), None
    return base, bverts, tgt, sd, L


def check_sweep(source: Mesh, target, sides=None, layers: int | None = None) -> None:
    """Check the inputs of :func:`sweep` (see there); raise InputError located at the argument."""
    _sweep_inputs(source, target, sides, layers)


def _frame(points: np.ndarray, loc: tuple, tol: float):
    """Best-fit plane of a section's boundary: centroid, in-plane axes (2, 3), unit normal."""
    c, axes, normal, _, s = _plane(points)
    if len(s) < 2 or s[1] <= tol:
        raise InputError(
            "the section's boundary vertices are collinear: no plane to map it to",
            loc=loc,
            code="degenerate_section",
        )
    return c, axes, normal


def _barycentric(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(m, 3)`` of 2D points ``p`` (m, 2) in triangles (m, 3, 2)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    den = np.where(den == 0, 1.0, den)
    l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
    l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    return np.column_stack([1 - l1 - l2, l1, l2])


def _locate(q: np.ndarray, uv: np.ndarray, tris: np.ndarray):
    """The background triangle of each point and its barycentric coordinates there.

    A point is given the triangle where its least barycentric coordinate is
    largest: the containing one, or the nearest in that sense for points a
    rounding error outside the hull. Candidates are the 8 triangles with the
    nearest centroids; points none of them holds are tried on all triangles.
    """
    cen = uv[tris].mean(axis=1)
    k = min(8, len(tris))
    _, cand = cKDTree(cen).query(q, k=k)
    cand = cand.reshape(len(q), k)
    best = np.zeros(len(q), dtype=np.int64)
    score = np.full(len(q), -np.inf)
    for j in range(k):
        t = cand[:, j]
        s = _barycentric(q, uv[tris[t]]).min(axis=1)
        better = s > score
        best[better], score[better] = t[better], s[better]
    lost = np.flatnonzero(score < 0)
    for start in range(0, len(lost), 256):
        sel = lost[start : start + 256]
        m = len(sel)
        lam = (
            _barycentric(np.repeat(q[sel], len(tris), axis=0), np.tile(uv[tris], (m, 1, 1)))
            .min(axis=1)
            .reshape(m, len(tris))
        )
        j = np.argmax(lam, axis=1)
        better = lam[np.arange(m), j] > score[sel]
        best[sel[better]] = j[better]
    return best, _barycentric(q, uv[tris[best]])


def _sweep_sections(base, bverts, tgt, sd, L, tol, progress):
    """Positions ``(L + 1, n, 3)`` of every source vertex on every section (§8.1.2)."""
    src = base.points
    n, nb = len(src), len(bverts)
    interior = np.setdiff1d(np.arange(n), bverts)
    B = np.empty((L + 1, nb, 3))
    B[0] = src[bverts]
    if sd is not None and len(sd):
        B[1:L] = sd
    B[L] = tgt[bverts] if len(tgt) == n else tgt
    if sd is None:  # straight sides
        t = np.arange(L + 1) / L
        B[1:L] = (1 - t[1:L, None, None]) * B[0] + t[1:L, None, None] * B[L]
    X = np.empty((L + 1, n, 3))
    X[:, bverts] = B
    X[0] = src
    if len(tgt) == n:
        X[L] = tgt
    if len(interior) == 0:
        return X
    # a background mesh of the source section in its parametric plane, on its boundary points
    frames = [
        _frame(B[k], ("sides", k - 1) if 0 < k < L else ("target",) if k else ("source",), tol)
        for k in range(L + 1)
    ]
    normals = np.array([f[2] for f in frames])
    for k in range(1, L + 1):  # orient the normals alike from section to section
        if normals[k] @ normals[k - 1] < 0:
            normals[k] = -normals[k]
    c0, ax0, _ = frames[0]
    uv = (B[0] - c0) @ ax0.T
    try:
        tris = delaunay(uv).triangles
    except InputError as exc:
        raise InputError(
            f"the source's boundary cannot carry a background mesh: {exc.message}",
            loc=("source",),
            code=exc.code,
        ) from None
    _report(progress, 0.03, "locating interior vertices in the background mesh")
    P0 = src[interior]
    tri, lam0 = _locate((P0 - c0) @ ax0.T, uv, tris)
    S = tris[tri]  # (ni, 3) indices into the boundary vertices
    d0 = np.einsum("ij,j->i", P0 - np.einsum("ij,ijk->ik", lam0, B[0][S]), normals[0])
    if len(tgt) == n:
        cL, axL, _ = frames[L]
        PL = tgt[interior]
        lamL = _barycentric((PL - cL) @ axL.T, ((B[L][S] - cL) @ axL.T))
        dL = np.einsum("ij,j->i", PL - np.einsum("ij,ijk->ik", lamL, B[L][S]), normals[L])
    else:
        lamL, dL = lam0, d0
    # the weight of the target on each section, from the sides: arc length along each side
    seg = np.linalg.norm(np.diff(B, axis=0), axis=2)  # (L, nb)
    arc = np.concatenate([np.zeros((1, nb)), np.cumsum(seg, axis=0)])
    total = arc[-1]
    even = np.arange(L + 1)[:, None] / L
    w = np.where(total > tol, arc / np.where(total > tol, total, 1.0), even)  # (L+1, nb)
    for k in range(1, L + (len(tgt) != n)):
        t = np.clip(np.einsum("ij,ij->i", lam0, w[k][S]), 0.0, 1.0)
        lam = (1 - t)[:, None] * lam0 + t[:, None] * lamL
        d = (1 - t) * d0 + t * dL
        X[k, interior] = np.einsum("ij,ijk->ik", lam, B[k][S]) + d[:, None] * normals[k]
        _report(progress, 0.03 + 0.07 * k / L, "placing interior vertices")
    return X


def sweep(
    source: Mesh,
    target,
    *,
    sides=None,
    layers: int | None = None,
    simplices: bool = False,
    on_degenerate: str = "error",
    validate: bool = True,
    tolerances: Tolerances = TOLERANCES,
    progress: Progress = None,
) -> ProductResult:
    """Sweep a source section to a target section, computing the sections between (§8.1.2).

    The semi-automatic method of §8.1.2: the boundary vertices of each
    section are given (``sides``) or interpolated linearly; the interior
    vertices are placed from a background mesh of the source section:

    1. the source's boundary vertices are mapped to their best-fit plane (the
       parametric space) and triangulated (our Delaunay kernel);
    2. each interior vertex gets the background triangle holding it and its
       barycentric coordinates ``(a, b, c)`` there, in the source section, and
       in the target section with respect to the same triangle (footnote 2:
       they may be negative there);
    3. the distortions ``d_source`` and ``d_target``: the signed distance of
       the vertex from ``a S1 + b S2 + c S3`` along the section's plane normal
       (0 for a planar section, footnote 3);
    4. on section ``k`` the vertex is ``sum(lam_k S_k) + d_k N_k`` with
       ``lam_k`` and ``d_k`` interpolated linearly between source and target
       with the weight ``t``: the normalized arc length reached along the
       sides by the triangle's three boundary vertices, combined with the
       source barycentric coordinates (the "function of the section defined
       through the points supplied in the sides"). ``S_k`` are the triangle's
       boundary vertices on section ``k`` and ``N_k`` that section's plane
       normal.

    Sections 0 and ``layers`` reproduce source and target exactly. When the
    target is an affine image of the source and the sides are straight, every
    interior vertex moves on the straight line between its two positions.

    Parameters
    ----------
    source : Mesh
        Triangles and quads, points ``(n, 2)`` (z = 0) or ``(n, 3)``.
    target : (n, 3) or (nb, 3) float64
        The positions of all source vertices on the last section, or of its
        boundary vertices only (in :func:`sweep_boundary` order); then the
        interior keeps its source barycentric coordinates and distortion.
    sides : (layers - 1, nb, 3) float64, optional
        The boundary vertices on each intermediate section.
    layers : int, optional
        Layers of cells, when ``sides`` is not given (straight sides).
    simplices, on_degenerate, validate, tolerances, progress
        As :func:`extrude`.

    Returns
    -------
    ProductResult
        With ``boundary_vertices``.

    Raises
    ------
    InputError
        Located at ``source``, ``target``, ``sides`` or ``layers``; validation
        failures as :func:`extrude`, at ``("target",)``.

    References
    ----------
    §8.1.2 ("semi-automatic" method), footnotes 2 and 3; Staten, Canann, Owen (1999).
    """
    base, bverts, tgt, sd, L = _sweep_inputs(source, target, sides, layers)
    all_pts = [base.points, tgt] + ([sd.reshape(-1, 3)] if sd is not None and sd.size else [])
    tol = tolerances.distance(np.concatenate(all_pts))
    _report(progress, 0.0, "computing the sections")
    with np.errstate(over="ignore", invalid="ignore"):
        X = _sweep_sections(base, bverts, tgt, sd, L, tol, progress)
    _finite_sections(X, ("target",))
    return _product(
        base,
        X,
        simplices=bool(simplices),
        on_degenerate=on_degenerate,
        validate=bool(validate),
        screw=None,
        translate=False,
        fault=("target",),
        progress=progress,
        tolerances=tolerances,
        boundary_vertices=bverts,
    )
