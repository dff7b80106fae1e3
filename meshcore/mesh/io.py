"""The only module that knows file formats: meshio and the JSON mesh shape.

JSON shape (DESIGN.md)::

    {"points": [[x, y(, z)], ...],
     "cells": [{"type": "triangle", "data": [[0, 1, 2], ...]}, ...],
     "point_data": {name: [...]}, "cell_data": {name: [[...] per block]},
     "cell_sets": {name: [[ids in block 0], [ids in block 1], ...]}}

A cell set spanning dimensions (quads and lines, say) keeps one physical tag
in Gmsh files; ``$PhysicalNames`` names it for its highest dimension only,
as a Gmsh physical group has one dimension, and :func:`from_meshio` matches
the tag in every dimension so the set round-trips whole.

Downloads go through meshio, which cannot write to buffers, so
:func:`to_bytes` writes a temporary file and reads it back. Cell sets become
Gmsh physical groups (``gmsh:physical`` cell data with named ``field_data``;
a cell in several sets takes the first set's tag, and cells in no set get
tag 0), Abaqus ``*ELSET``\\ s, and for the other formats one 0/1 cell data
array per set named ``set:<name>``.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import meshio
import numpy as np

from meshcore.errors import InputError
from meshcore.mesh.mesh import CELL_TYPES, CellBlock, Mesh


@dataclass(frozen=True)
class FileFormat:
    """A download format: meshio's writer name, file suffix, media type and fitting cells."""

    meshio_name: str
    suffix: str
    media_type: str
    cell_types: frozenset[str] | None = None  # None: every type
    binary: bool = True


FORMATS: dict[str, FileFormat] = {
    "vtu": FileFormat("vtu", ".vtu", "application/vnd.vtk.vtu+xml"),
    "gmsh": FileFormat("gmsh", ".msh", "model/x-gmsh"),
    "gmsh22": FileFormat("gmsh22", ".msh", "model/x-gmsh"),
    "xdmf": FileFormat(  # meshio cannot read vertex cells back from mixed XDMF
        "xdmf",
        ".xdmf",
        "application/xml",
        frozenset({"line", "triangle", "quad", "tetra", "pyramid", "wedge", "hexahedron"}),
    ),
    "abaqus": FileFormat(
        "abaqus",
        ".inp",
        "text/plain",
        frozenset({"line", "triangle", "quad", "tetra", "wedge", "hexahedron"}),  # meshio's
        binary=False,
    ),
    "obj": FileFormat("obj", ".obj", "model/obj", frozenset({"triangle", "quad"}), False),
    "stl": FileFormat("stl", ".stl", "model/stl", frozenset({"triangle"})),
    "ply": FileFormat("ply", ".ply", "application/vnd.ply", frozenset({"triangle", "quad"})),
}


def to_meshio(mesh: Mesh) -> meshio.Mesh:
    """The same mesh as a ``meshio.Mesh`` (arrays shared, not copied)."""
    return meshio.Mesh(
        mesh.points,
        [(b.type, b.data) for b in mesh.cells],
        point_data=dict(mesh.point_data),
        cell_data={k: list(v) for k, v in mesh.cell_data.items()},
        cell_sets={k: list(v) for k, v in mesh.cell_sets.items()},
    )


def from_meshio(m: meshio.Mesh) -> Mesh:
    """A :class:`Mesh` from a ``meshio.Mesh``, keeping only the known cell types.

    Gmsh physical groups become cell sets and other Gmsh bookkeeping data
    (``gmsh:*``) is dropped; point data, other cell data and cell sets are
    kept. Points are cut to 2D when every z is zero and the cells are all at
    most two-dimensional.
    """
    keep = [i for i, c in enumerate(m.cells) if c.type in CELL_TYPES]
    if "gmsh:physical" in m.cell_data:  # Gmsh physical groups, matched by tag in every dimension
        cell_sets = {
            name: [np.flatnonzero(t == tag) for t in m.cell_data["gmsh:physical"]]
            for name, (tag, _dim) in m.field_data.items()
        }
    else:
        cell_sets = {k: v for k, v in m.cell_sets.items() if not k.startswith("gmsh:")}
    points = np.asarray(m.points, dtype=np.float64)
    if (
        points.shape[1] == 3
        and not np.any(points[:, 2])
        and all(CELL_TYPES[m.cells[i].type][1] <= 2 for i in keep)
    ):
        points = points[:, :2]
    return Mesh(
        points,
        tuple(CellBlock(m.cells[i].type, m.cells[i].data) for i in keep),
        point_data={k: v for k, v in m.point_data.items() if not k.startswith("gmsh:")},
        cell_data={
            k: [v[i] for i in keep] for k, v in m.cell_data.items() if not k.startswith("gmsh:")
        },
        cell_sets={
            k: [np.asarray(v[i], dtype=np.int64) for i in keep] for k, v in cell_sets.items()
        },
    )


def to_json(mesh: Mesh) -> dict:
    """The JSON mesh shape of DESIGN.md (plain lists, ready for ``json.dumps``)."""
    out: dict = {
        "points": mesh.points.tolist(),
        "cells": [{"type": b.type, "data": b.data.tolist()} for b in mesh.cells],
    }
    if mesh.point_data:
        out["point_data"] = {k: v.tolist() for k, v in mesh.point_data.items()}
    if mesh.cell_data:
        out["cell_data"] = {k: [a.tolist() for a in v] for k, v in mesh.cell_data.items()}
    if mesh.cell_sets:
        out["cell_sets"] = {k: [a.tolist() for a in v] for k, v in mesh.cell_sets.items()}
    return out


def _array(value: object, dtype: type, loc: tuple, what: str) -> np.ndarray:
    """``value`` as a rectangular array, or an InputError located at ``loc``."""
    try:
        return np.asarray(value, dtype=dtype)
    except (ValueError, TypeError, OverflowError) as exc:
        where = " ".join(str(p) for p in loc)
        raise InputError(f"{where} must be {what}", loc=loc, code="bad_shape") from exc


def from_json(obj: dict) -> Mesh:
    """A checked :class:`Mesh` from the JSON mesh shape.

    Raises
    ------
    InputError
        naming the field, block, cell and index at fault (see :meth:`Mesh.check`).
    """
    numbers, indices = "a rectangular list of numbers", "a list of integer indices"
    points = _array(obj["points"], np.float64, ("points",), numbers)
    blocks = [
        CellBlock(cell["type"], _array(cell["data"], np.int64, ("cells", b, "data"), indices))
        for b, cell in enumerate(obj.get("cells", []))
    ]
    point_data = {
        name: _array(v, np.float64, ("point_data", name), numbers)
        for name, v in (obj.get("point_data") or {}).items()
    }
    cell_data = {
        name: [_array(a, np.float64, ("cell_data", name, b), numbers) for b, a in enumerate(v)]
        for name, v in (obj.get("cell_data") or {}).items()
    }
    cell_sets = {
        name: [_array(a, np.int64, ("cell_sets", name, b), indices) for b, a in enumerate(v)]
        for name, v in (obj.get("cell_sets") or {}).items()
    }
    return Mesh(
        points, tuple(blocks), point_data=point_data, cell_data=cell_data, cell_sets=cell_sets
    ).check()


def _gmsh_mesh(mesh: Mesh, split: bool) -> meshio.Mesh:
    """The mesh as Gmsh wants it, cell sets as physical tags.

    MSH 2.2 tags each element. MSH 4.1 (``split``) attaches physical tags to
    entities, not elements, so each block is split by set tag into one entity
    each (cells then come out grouped by set); each node is classified on the
    lowest-dimensional entity holding it (Gmsh's own convention).
    """
    tags = [np.zeros(len(b), dtype=np.int64) for b in mesh.cells]
    field_data = {}
    for tag, (name, ids) in enumerate(mesh.cell_sets.items(), start=1):
        dim = max(
            (CELL_TYPES[b.type][1] for b, a in zip(mesh.cells, ids, strict=True) if len(a)),
            default=0,
        )
        field_data[name] = np.array([tag, dim])
        for t, a in zip(tags, ids, strict=True):
            t[a[t[a] == 0]] = tag
    cells, physical, entity = [], [], []
    node_dim = np.full(len(mesh.points), 4, dtype=np.int64)
    node_entity = np.zeros(len(mesh.points), dtype=np.int64)
    for block, t in zip(mesh.cells, tags, strict=True):
        dim = CELL_TYPES[block.type][1]
        for tag in np.unique(t) if split else [None]:
            data = block.data if tag is None else block.data[t == tag]
            cells.append((block.type, data))
            physical.append(t if tag is None else np.full(len(data), tag, dtype=np.int64))
            entity.append(np.full(len(data), len(cells), dtype=np.int64))
            nodes = np.unique(data)
            lower = nodes[node_dim[nodes] > dim]
            node_dim[lower], node_entity[lower] = dim, len(cells)
    if split:  # MSH 4.1 lists an entity only when it holds a node: lend one to any that holds none
        owned = np.bincount(node_entity, minlength=len(cells) + 1)
        for e, (ctype, data) in enumerate(cells, start=1):
            nodes = np.unique(data)
            spare = nodes[owned[node_entity[nodes]] > 1]
            if owned[e] == 0 and len(spare):
                owned[node_entity[spare[0]]] -= 1
                owned[e] += 1
                node_dim[spare[0]], node_entity[spare[0]] = CELL_TYPES[ctype][1], e
    unused = node_dim == 4
    node_dim[unused], node_entity[unused] = 0, 0
    points = mesh.points
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    return meshio.Mesh(
        points,
        cells,
        point_data={**mesh.point_data, "gmsh:dim_tags": np.column_stack([node_dim, node_entity])},
        cell_data={"gmsh:physical": physical, "gmsh:geometrical": entity},
        field_data=field_data,
    )


def _meshio_for(mesh: Mesh, fmt: str) -> meshio.Mesh:
    """The meshio mesh to write in ``fmt``, cell sets translated as the module says."""
    if fmt in ("gmsh", "gmsh22"):
        return _gmsh_mesh(mesh, split=fmt == "gmsh")
    m = to_meshio(mesh)
    if fmt != "abaqus":
        for name, ids in mesh.cell_sets.items():
            flags = []
            for block, a in zip(mesh.cells, ids, strict=True):
                f = np.zeros(len(block), dtype=np.int32)
                f[a] = 1
                flags.append(f)
            m.cell_data[f"set:{name}"] = flags
    m.cell_sets = {}  # Abaqus: written by _abaqus_elsets
    if m.points.shape[1] == 2 and fmt != "abaqus":
        m.points = np.column_stack([m.points, np.zeros(len(m.points))])
    if fmt in ("obj", "stl"):
        m.point_data, m.cell_data = {}, {}
    return m


def to_bytes(mesh: Mesh, fmt: str) -> bytes:
    """The mesh written in format ``fmt`` (a key of :data:`FORMATS`).

    Raises
    ------
    InputError
        ``unknown_format`` for a format not in :data:`FORMATS`;
        ``format_mismatch`` when the format cannot hold the mesh's cell types.
    """
    spec = FORMATS.get(fmt)
    if spec is None:
        raise InputError(
            f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}",
            loc=("format",),
            code="unknown_format",
        )
    types = {b.type for b in mesh.cells}
    if spec.cell_types is not None and not types <= spec.cell_types:
        raise InputError(
            f"format {fmt!r} holds only {', '.join(sorted(spec.cell_types))} cells; "
            f"this mesh has {', '.join(sorted(types - spec.cell_types))}",
            loc=("format",),
            code="format_mismatch",
        )
    m = _meshio_for(mesh, fmt)
    with tempfile.TemporaryDirectory(prefix="meshcore-") as tmp:
        path = os.path.join(tmp, "mesh" + spec.suffix)
        try:
            if fmt == "xdmf":  # heavy data inline, so that the download is one file
                meshio.xdmf.write(path, m, data_format="XML")
            elif fmt in ("stl", "ply", "gmsh", "gmsh22"):
                meshio.write(path, m, file_format=spec.meshio_name, binary=True)
            else:
                meshio.write(path, m, file_format=spec.meshio_name)
        except (meshio.WriteError, meshio.ReadError, ValueError, KeyError, TypeError) as exc:
            # what the table above cannot foresee (data meshio cannot store): a 4xx, not a 500
            raise InputError(
                f"format {fmt!r} cannot hold this mesh: {exc}",
                loc=("format",),
                code="format_mismatch",
            ) from None
        with open(path, "rb") as f:
            data = f.read()
    return data + _abaqus_elsets(mesh).encode() if fmt == "abaqus" else data


def _abaqus_elsets(mesh: Mesh) -> str:
    """One ``*ELSET`` per cell set, with 1-based element ids counted over all blocks.

    meshio writes one ``*ELSET`` per set and block, and its reader keeps only
    the last of equally named sets, so a set spanning blocks would lose cells.
    """
    offsets = np.cumsum([0] + [len(b) for b in mesh.cells])
    out = []
    for name, ids in mesh.cell_sets.items():
        parts = [a + 1 + off for a, off in zip(ids, offsets[:-1], strict=True)]
        els = np.concatenate(parts).tolist() if parts else []
        if els:
            rows = (",".join(map(str, els[i : i + 8])) for i in range(0, len(els), 8))
            out.append(f"*ELSET, ELSET={name}\n" + ",\n".join(rows) + "\n")
    return "".join(out)


def from_bytes(data: bytes, fmt: str) -> Mesh:
    """Read a mesh written by :func:`to_bytes` (used to check round trips)."""
    spec = FORMATS[fmt]
    with tempfile.TemporaryDirectory(prefix="meshcore-") as tmp:
        path = os.path.join(tmp, "mesh" + spec.suffix)
        with open(path, "wb") as f:
            f.write(data)
        reader = "gmsh" if fmt.startswith("gmsh") else spec.meshio_name
        return from_meshio(meshio.read(path, file_format=reader))
