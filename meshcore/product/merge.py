"""Merging meshes along shared interfaces (§8.1.4, Figure 8.5 right).

A domain cut into parts that each suit a product method is meshed part by
part, and the parts are merged into one conforming mesh (§8.1.4: "this
partition is defined so as to permit a compatible mesh merge").
:func:`merged` does that merge:

1. points closer than ``tolerance`` become one point (k-d tree pairs, then
   connected components; each group keeps its lowest-numbered point);
2. the cells are renumbered and blocks of the same cell type concatenated,
   input mesh after input mesh;
3. the interface is checked: no facet of the top-dimensional cells may be
   shared by more than two cells, no cell may be duplicated, and no
   boundary facet of one input may meet a boundary facet of another without
   matching it exactly. That catches the hanging node (a vertex of one part
   inside a facet or edge of the other) and two faces split by different
   diagonals, and fails with the location;
4. lower-dimensional cells held by several inputs (a ``top`` facet of one
   part and a ``bottom`` facet of the next) are the duplicated interface
   facets: all copies are dropped when the facet has become interior, one
   copy is kept when it is still on the boundary.

Choices the text leaves open, and ours: the default tolerance is
:class:`meshcore.geometry.tolerances.Tolerances` ``coincident`` times the diameter of all
points; a group of merged points wider than twice the tolerance (a chain of
close points) is an error rather than a silent collapse; 2D inputs are
lifted to z = 0 when another input is 3D. Cell data present in every input,
every cell set of any input, and point data present in every input are
kept; cell data ``mesh`` gives each cell's input.

References
----------
Methods text §8.1.4 (Figure 8.5, right: three product meshes merged), §8.3.1
Definition 8.1 (conformity).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshcore.errors import InputError
from meshcore.geometry.tolerances import TOLERANCES, Tolerances
from meshcore.mesh import CELL_TYPES, CellBlock, Mesh, topology

__all__ = ["MergeResult", "merged"]

Progress = Callable[[float, str], None] | None


@dataclass(frozen=True, eq=False)
class MergeResult:
    """The merged mesh.

    Attributes
    ----------
    mesh : Mesh
    merged_points : int
        Input points minus output points.
    dropped_facets : int
        Lower-dimensional cells dropped as duplicated interface facets.
    tolerance : float
        The distance used.
    """

    mesh: Mesh
    merged_points: int
    dropped_facets: int
    tolerance: float

    def stats(self) -> dict:
        counts: dict[str, int] = {}
        for block in self.mesh.cells:
            counts[block.type] = counts.get(block.type, 0) + len(block)
        return {
            "points": len(self.mesh.points),
            "cells": counts,
            "merged_points": self.merged_points,
            "dropped_facets": self.dropped_facets,
            "tolerance": self.tolerance,
        }


def _xyz(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in p) + ")"


def _row_ids(rows: np.ndarray) -> np.ndarray:
    """One id per row of an ``(m, k)`` int array, equal exactly for equal rows.

    Ids are dense ranks, folded column by column (a 1-D sort per column is
    much faster than ``np.unique(..., axis=0)``).
    """
    if rows.shape[1] == 0 or len(rows) == 0:
        return np.zeros(len(rows), dtype=np.int64)
    ids = np.unique(rows[:, 0], return_inverse=True)[1].ravel()
    for j in range(1, rows.shape[1]):
        col = np.unique(rows[:, j], return_inverse=True)[1].ravel()
        ids = np.unique(ids * (int(col.max()) + 1) + col, return_inverse=True)[1].ravel()
    return ids


def _groups(points: np.ndarray, tol: float) -> np.ndarray:
    """The representative (lowest index) of each point's group of points within ``tol``."""
    n = len(points)
    pairs = cKDTree(points).query_pairs(tol, output_type="ndarray") if tol > 0 else None
    if pairs is None or len(pairs) == 0:
        if tol == 0:  # exact duplicates only
            _, first, inverse = np.unique(points, axis=0, return_index=True, return_inverse=True)
            return first[inverse.ravel()]
        return np.arange(n)
    graph = coo_matrix(
        (np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n)
    )
    _, label = connected_components(graph, directed=False)
    rep = np.full(label.max() + 1, n, dtype=np.int64)
    np.minimum.at(rep, label, np.arange(n))
    return rep[label]


def _facet_hits(qpts, qmesh, qids, fnodes, fmesh, points, tol):
    """Query points in a facet (closed, within ``tol``) of another input, not at its vertices.

    Facets are lines, triangles or quads (two triangles) of ``points``. Returns
    (query index, facet index) pairs.
    """
    k = fnodes.shape[1]
    if k == 4:
        tri = np.concatenate([fnodes[:, [0, 1, 2]], fnodes[:, [0, 2, 3]]])
        owner = np.concatenate([np.arange(len(fnodes))] * 2)
    else:
        tri, owner = fnodes, np.arange(len(fnodes))
    p = points[tri]
    cen = p.mean(axis=1)
    rad = np.sqrt(np.max(np.sum((p - cen[:, None]) ** 2, axis=2), axis=1)) + tol
    if len(qpts) == 0 or len(tri) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lists = cKDTree(qpts).query_ball_point(cen, rad)
    counts = np.array([len(x) for x in lists])
    if counts.sum() == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    fi = np.repeat(np.arange(len(tri)), counts)
    qi = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists if len(x)])
    keep = (qmesh[qi] != fmesh[owner[fi]]) & ~np.any(tri[fi] == qids[qi][:, None], axis=1)
    fi, qi = fi[keep], qi[keep]
    a = p[fi, 0]
    x = qpts[qi] - a
    if tri.shape[1] == 2:
        e = p[fi, 1] - a
        ee = np.einsum("ij,ij->i", e, e)
        t = np.einsum("ij,ij->i", x, e) / np.where(ee > 0, ee, 1.0)
        off = np.linalg.norm(x - t[:, None] * e, axis=1)
        length = np.sqrt(ee)
        inside = (off <= tol) & (t * length >= -tol) & ((1 - t) * length >= -tol)
    else:
        e1, e2 = p[fi, 1] - a, p[fi, 2] - a
        nrm = np.cross(e1, e2)
        area2 = np.linalg.norm(nrm, axis=1)
        unit = nrm / np.where(area2 > 0, area2, 1.0)[:, None]
        off = np.abs(np.einsum("ij,ij->i", x, unit))
        # barycentric coordinates scaled to distances from the edges
        b1 = np.einsum("ij,ij->i", np.cross(x, e2), unit) / np.where(area2 > 0, area2, 1.0)
        b2 = np.einsum("ij,ij->i", np.cross(e1, x), unit) / np.where(area2 > 0, area2, 1.0)
        b0 = 1 - b1 - b2
        scale = np.sqrt(area2)  # a length of the triangle's size
        inside = (
            (off <= tol)
            & np.all(np.column_stack([b0, b1, b2]) * scale[:, None] >= -tol, axis=1)
            & (area2 > 0)
        )
    return qi[inside], owner[fi[inside]]


def merged(
    meshes: Sequence[Mesh],
    tolerance: float | None = None,
    *,
    tolerances: Tolerances = TOLERANCES,
    progress: Progress = None,
) -> MergeResult:
    """Merge meshes into one, checking that they meet conformingly.

    Parameters
    ----------
    meshes : sequence of Mesh
        One or more meshes; points ``(n, 2)`` or ``(n, 3)``.
    tolerance : float, optional
        Points closer than this are one point. By default
        ``tolerances.coincident`` times the diameter of all points.
    tolerances : Tolerances
    progress : callable(fraction, message), optional

    Returns
    -------
    MergeResult

    Raises
    ------
    InputError
        ``loc = ("meshes", i, ...)`` for a bad input mesh; ``bad_tolerance``;
        ``tolerance_too_large`` (a group of merged points wider than twice
        the tolerance, or a cell whose points merge); ``duplicate_cells``
        (the same cell in two inputs); ``nonmanifold_interface`` (a facet
        held by three cells or more); ``nonconforming_interface`` (a hanging
        node, or boundary facets of two inputs overlapping without matching),
        located at the offending point or cell of the input and with its
        coordinates in the message.

    References
    ----------
    §8.1.4 (Figure 8.5, right); §8.3.1 Definition 8.1.
    """
    if isinstance(meshes, Mesh) or not isinstance(meshes, Sequence) or len(meshes) == 0:
        raise InputError(
            "meshes must be a non-empty list of meshes", loc=("meshes",), code="bad_shape"
        )
    for i, m in enumerate(meshes):
        if not isinstance(m, Mesh):
            raise InputError(f"item {i} is not a mesh", loc=("meshes", i), code="bad_type")
        try:
            m.check()
        except InputError as exc:
            raise exc.prefixed("meshes", i) from None
    if tolerance is not None:
        try:
            tol = float(tolerance)
        except (TypeError, ValueError):
            tol = -1.0
        if not np.isfinite(tol) or tol < 0:
            raise InputError(
                f"tolerance must be a finite number >= 0, got {tolerance!r}",
                loc=("tolerance",),
                code="bad_tolerance",
            )
    dim = max(m.dim for m in meshes)
    pts_in = [
        m.points if m.dim == dim else np.column_stack([m.points, np.zeros(len(m.points))])
        for m in meshes
    ]
    offsets = np.cumsum([0] + [len(p) for p in pts_in])
    points = np.concatenate(pts_in)
    mesh_of_point = np.repeat(np.arange(len(meshes)), np.diff(offsets))
    if tolerance is None:
        tol = tolerances.distance(points)
    if progress is not None:
        progress(0.0, "merging coincident points")

    rep = _groups(points, tol)
    spread = np.linalg.norm(points - points[rep], axis=1)
    if (spread > 2 * tol).any():
        p = int(np.argmax(spread))
        i = int(mesh_of_point[p])
        raise InputError(
            f"the tolerance {tol:g} merges a chain of points: point {p - offsets[i]} of mesh {i} "
            f"at {_xyz(points[p])} lies {spread[p]:.6g} from the point it merges with",
            loc=("meshes", i, "points", int(p - offsets[i])),
            code="tolerance_too_large",
        )
    keep = rep == np.arange(len(points))
    new_id = np.cumsum(keep) - 1
    remap = new_id[rep]
    out_points = points[keep]

    # cells of every input, renumbered
    parts = []  # (mesh, block, type, data)
    for i, m in enumerate(meshes):
        for b, block in enumerate(m.cells):
            data = remap[block.data + offsets[i]]
            if data.shape[1] > 1 and len(data):
                s = np.sort(data, axis=1)
                rep_ = np.flatnonzero((s[:, 1:] == s[:, :-1]).any(axis=1))
                if len(rep_):
                    c = int(rep_[0])
                    raise InputError(
                        f"the tolerance {tol:g} collapses cell {c} of block {b} of mesh {i} "
                        f"({block.type}): two of its points merge",
                        loc=("meshes", i, "cells", b, "data", c),
                        code="tolerance_too_large",
                    )
            parts.append((i, b, block.type, data))
    top = max(CELL_TYPES[t][1] for _, _, t, _ in parts)
    if progress is not None:
        progress(0.3, "checking the interface")

    # the top-dimensional cells: duplicates, non-manifold facets, non-conforming interface
    top_parts = [p for p in parts if CELL_TYPES[p[2]][1] == top]
    cell_mesh = np.concatenate([np.full(len(d), i) for i, _, _, d in top_parts])
    cell_block = np.concatenate([np.full(len(d), b) for _, b, _, d in top_parts])
    cell_local = np.concatenate([np.arange(len(d)) for *_, d in top_parts])
    cell_type = np.concatenate([np.full(len(d), t) for _, _, t, d in top_parts])

    def where(c: int) -> tuple:
        return (
            "meshes",
            int(cell_mesh[c]),
            "cells",
            int(cell_block[c]),
            "data",
            int(cell_local[c]),
        )

    for t in dict.fromkeys(cell_type.tolist()):
        ids = np.flatnonzero(cell_type == t)
        data = np.concatenate([d for *_, tt, d in top_parts if tt == t])
        key = np.sort(data, axis=1)
        inverse = _row_ids(key)
        counts = np.bincount(inverse)
        dup = np.flatnonzero(counts[inverse] > 1)
        if len(dup):
            twins = dup[inverse[dup] == inverse[dup[0]]]
            first, second = ids[twins[0]], ids[twins[1]]
            raise InputError(
                f"{t} cell {int(cell_local[second])} of block {int(cell_block[second])} of mesh "
                f"{int(cell_mesh[second])} duplicates cell {int(cell_local[first])} of mesh "
                f"{int(cell_mesh[first])} at {_xyz(out_points[data[dup[0]]].mean(axis=0))}: "
                "the inputs overlap",
                loc=where(second),
                code="duplicate_cells",
            )
    # topology numbers the top cells block by block, in the order given
    top_mesh = Mesh(out_points, tuple(CellBlock(t, d) for *_, t, d in top_parts))
    facets = topology.facets(top_mesh, top) if top >= 1 else {}
    for ftype, f in facets.items():
        if (f.counts > 2).any():
            j = int(np.flatnonzero(f.counts > 2)[0])
            raise InputError(
                f"the {ftype} at {_xyz(out_points[f.nodes[j]].mean(axis=0))} is shared by "
                f"{int(f.counts[j])} cells (Definition 8.1 allows two): the inputs overlap there",
                loc=where(int(f.pairs[j, 0])),
                code="nonmanifold_interface",
            )
    if top >= 2:
        _check_interface(facets, out_points, cell_mesh, where, remap, mesh_of_point, offsets, tol)
    interior = {f.type: np.sort(f.nodes[f.counts == 2], axis=1) for f in facets.values()}
    if progress is not None:
        progress(0.7, "dropping duplicated interface facets")

    # lower-dimensional cells held by several inputs
    low_keys: dict[str, list] = {}
    for pi, (i, _, t, d) in enumerate(parts):
        if CELL_TYPES[t][1] < top:
            low_keys.setdefault(t, []).append((pi, i, np.sort(d, axis=1)))
    keep_mask = [np.ones(len(d), dtype=bool) for *_, d in parts]
    dropped = 0
    for t, items in low_keys.items():
        keys = np.concatenate([k for *_, k in items])
        owner_mesh = np.concatenate([np.full(len(k), i) for _, i, k in items])
        part_of = np.concatenate([np.full(len(k), pi) for pi, _, k in items])
        local = np.concatenate([np.arange(len(k)) for *_, k in items])
        inner = interior.get(t, np.zeros((0, keys.shape[1]), np.int64))
        # group equal rows; the interior facets ride along to mark their groups
        inverse = _row_ids(np.concatenate([keys, inner]))
        n_groups = inverse.max() + 1 if len(inverse) else 0
        in_mesh = np.zeros(n_groups, dtype=bool)
        in_mesh[inverse[len(keys) :]] = True
        inverse = inverse[: len(keys)]
        meshes_per = np.zeros(n_groups, dtype=np.int64)
        pair_id = _row_ids(np.column_stack([inverse, owner_mesh]))
        _, first_of_pair = np.unique(pair_id, return_index=True)
        pair = np.column_stack([inverse, owner_mesh])[first_of_pair]
        np.add.at(meshes_per, pair[:, 0], 1)
        shared = meshes_per[inverse] > 1
        if not shared.any():
            continue
        is_interior = in_mesh[inverse[shared]]
        drop = np.zeros(len(keys), dtype=bool)
        idx_shared = np.flatnonzero(shared)
        drop[idx_shared[is_interior]] = True
        # keep the first copy of a shared facet still on the boundary
        rest = idx_shared[~is_interior]
        if len(rest):
            _, first = np.unique(inverse[rest], return_index=True)
            later = np.ones(len(rest), dtype=bool)
            later[first] = False
            drop[rest[later]] = True
        for pi in np.unique(part_of[drop]):
            keep_mask[pi][local[drop & (part_of == pi)]] = False
        dropped += int(drop.sum())

    # assemble: blocks by type, in order of first appearance, input after input
    types = list(dict.fromkeys(t for *_, t, _ in parts))
    common_cd = set.intersection(*(set(m.cell_data) for m in meshes)) if meshes else set()
    common_cd.discard("mesh")
    set_names = list(dict.fromkeys(name for m in meshes for name in m.cell_sets))
    common_pd = set.intersection(*(set(m.point_data) for m in meshes))
    blocks, cell_data, cell_sets = [], {n: [] for n in sorted(common_cd)}, {}
    cell_data["mesh"] = []
    for name in set_names:
        cell_sets[name] = []
    for t in types:
        sel = [(pi, p) for pi, p in enumerate(parts) if p[2] == t]
        datas = [p[3][keep_mask[pi]] for pi, p in sel]
        blocks.append(CellBlock(t, np.concatenate(datas)))
        cell_data["mesh"].append(
            np.concatenate([np.full(len(d), p[0]) for d, (_, p) in zip(datas, sel, strict=True)])
        )
        for name in common_cd:
            cell_data[name].append(
                np.concatenate(
                    [np.asarray(meshes[p[0]].cell_data[name][p[1]])[keep_mask[pi]] for pi, p in sel]
                )
            )
        for name in set_names:
            ids, base = [], 0
            for (pi, p), d in zip(sel, datas, strict=True):
                m = meshes[p[0]]
                if name in m.cell_sets:
                    member = np.zeros(len(p[3]), dtype=bool)
                    member[m.cell_sets[name][p[1]]] = True
                    ids.append(base + np.flatnonzero(member[keep_mask[pi]]))
                base += len(d)
            cell_sets[name].append(np.concatenate(ids) if ids else np.zeros(0, np.int64))
    point_data = {}
    for name in common_pd:
        values = np.concatenate([np.asarray(m.point_data[name]) for m in meshes])
        point_data[name] = values[keep]
    mesh = Mesh(
        out_points, tuple(blocks), point_data=point_data, cell_data=cell_data, cell_sets=cell_sets
    )
    if progress is not None:
        progress(1.0, "merged")
    return MergeResult(mesh, len(points) - len(out_points), dropped, tol)


def _check_interface(facets, points, cell_mesh, where, remap, mesh_of_point, offsets, tol) -> None:
    """Raise at a hanging node or at overlapping, unmatched boundary facets of two inputs.

    Only boundary facets (held by one cell) take part: a facet two inputs
    share exactly is interior after the merge.
    """
    bnd = []  # (nodes, input mesh, holding cell) per facet type
    for f in facets.values():
        once = np.flatnonzero(f.counts == 1)
        holder = f.pairs[once, 0]
        bnd.append((f.nodes[once], cell_mesh[holder], holder))
    # the boundary vertices of each input (a merged vertex may belong to several)
    vm = np.concatenate(
        [np.column_stack([nodes.ravel(), np.repeat(m, nodes.shape[1])]) for nodes, m, _ in bnd]
    )
    vm = vm[np.unique(_row_ids(vm), return_index=True)[1]]
    verts, vmesh = vm[:, 0], vm[:, 1]
    for nodes, fmesh, fcell in bnd:
        qi, fi = _facet_hits(points[verts], vmesh, verts, nodes, fmesh, points, tol)
        if len(qi):
            v, i = int(verts[qi[0]]), int(vmesh[qi[0]])
            src = np.flatnonzero((remap == v) & (mesh_of_point == i))[0]
            c = int(fcell[fi[0]])
            loc = where(c)
            raise InputError(
                f"the interface is not conforming: point {int(src - offsets[i])} of mesh {i} at "
                f"{_xyz(points[v])} is a hanging node on a boundary facet of cell {loc[5]} of "
                f"block {loc[3]} of mesh {loc[1]}",
                loc=("meshes", i, "points", int(src - offsets[i])),
                code="nonconforming_interface",
            )
    for nodes, fmesh, _ in bnd:
        for other_nodes, other_mesh, other_cell in bnd:
            cen = points[other_nodes].mean(axis=1)
            qi, fi = _facet_hits(cen, other_mesh, np.full(len(cen), -1), nodes, fmesh, points, tol)
            if len(qi):
                loc = where(int(other_cell[qi[0]]))
                raise InputError(
                    f"the interface is not conforming at {_xyz(cen[qi[0]])}: a boundary facet "
                    f"of cell {loc[5]} of block {loc[3]} of mesh {loc[1]} overlaps a boundary "
                    f"facet of mesh {int(fmesh[fi[0]])} without matching it",
                    loc=loc,
                    code="nonconforming_interface",
                )
