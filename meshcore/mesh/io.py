"""The file-format module (with its writers, :mod:`meshcore.mesh.writers`): meshio and JSON.

JSON shape (DESIGN.md)::

    {"points": [[x, y(, z)], ...],
     "cells": [{"type": "triangle", "data": [[0, 1, 2], ...]}, ...],
     "point_data": {name: [...]}, "cell_data": {name: [[...] per block]},
     "cell_sets": {name: [[ids in block 0], [ids in block 1], ...]}}

A cell set spanning dimensions (quads and lines, say) keeps one physical tag
in Gmsh files; ``$PhysicalNames`` names it for its highest dimension only,
as a Gmsh physical group has one dimension, and :func:`from_meshio` matches
the tag in every dimension so the set round-trips whole.

Downloads are written by the fast writers of :mod:`meshcore.mesh.writers`
(numpy, binary wherever the format has it; meshio's own writers take
seconds per million cells) and read back through meshio. Cell sets become
Gmsh physical groups (a cell in several sets takes the first set's tag, and
cells in no set get tag 0), Abaqus ``*ELSET``\\ s, and for the other formats
one 0/1 cell data array per set named ``set:<name>``. XDMF downloads are a
zip archive of ``mesh.xdmf`` and its heavy data ``mesh.h5``.
:func:`to_npz` / :func:`from_npz` keep a job's mesh as raw arrays for the
service's later downloads and previews.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from dataclasses import dataclass
from io import BytesIO

import meshio
import numpy as np

from meshcore.errors import InputError
from meshcore.mesh import writers
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
    "xdmf": FileFormat(  # a zip of mesh.xdmf and mesh.h5; no vertex cells in mixed XDMF
        "xdmf",
        ".xdmf.zip",
        "application/zip",
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


#: Components of point data each format stores (None: any).
_COMPONENTS = {"gmsh": {1, 3, 9}, "gmsh22": {1, 3, 9}, "xdmf": {1, 3, 9}}


def to_bytes(mesh: Mesh, fmt: str) -> bytes:
    """The mesh written in format ``fmt`` (a key of :data:`FORMATS`) by its fast writer.

    Raises
    ------
    InputError
        ``unknown_format`` for a format not in :data:`FORMATS`;
        ``format_mismatch`` when the format cannot hold the mesh's cell types
        or its point data.
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
    allowed = _COMPONENTS.get(fmt)
    for name, values in mesh.point_data.items():
        k = 1 if values.ndim == 1 else int(np.prod(values.shape[1:]))
        if allowed is not None and k not in allowed:
            raise InputError(
                f"format {fmt!r} stores point data of {sorted(allowed)} components; "
                f"{name!r} has {k}",
                loc=("format",),
                code="format_mismatch",
            )
    return writers.to_bytes(mesh, fmt)


def to_npz(mesh: Mesh) -> bytes:
    """The mesh's arrays as an uncompressed ``.npz`` (read back by :func:`from_npz`).

    The job's own copy of its mesh: loading it takes milliseconds where
    parsing the result's JSON takes seconds.
    """
    arrays = {"points": mesh.points}
    layout = {"cells": [], "point_data": list(mesh.point_data), "cell_data": [], "cell_sets": []}
    for b, block in enumerate(mesh.cells):
        layout["cells"].append(block.type)
        arrays[f"cells{b}"] = block.data
    for i, v in enumerate(mesh.point_data.values()):
        arrays[f"point_data{i}"] = v
    for kind in ("cell_data", "cell_sets"):
        for i, (name, per_block) in enumerate(getattr(mesh, kind).items()):
            layout[kind].append(name)
            for b, a in enumerate(per_block):
                arrays[f"{kind}{i}_{b}"] = np.asarray(a)
    arrays["layout"] = np.frombuffer(json.dumps(layout).encode(), dtype=np.uint8)
    buf = BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def from_npz(source: str | os.PathLike | bytes) -> Mesh:
    """The mesh saved by :func:`to_npz` (a path or the bytes)."""
    with np.load(BytesIO(source) if isinstance(source, bytes) else source) as z:
        layout = json.loads(z["layout"].tobytes())
        nblocks = len(layout["cells"])

        def per_block(kind: str, i: int) -> list[np.ndarray]:
            return [z[f"{kind}{i}_{b}"] for b in range(nblocks)]

        return Mesh(
            z["points"],
            tuple(CellBlock(t, z[f"cells{b}"]) for b, t in enumerate(layout["cells"])),
            point_data={k: z[f"point_data{i}"] for i, k in enumerate(layout["point_data"])},
            cell_data={k: per_block("cell_data", i) for i, k in enumerate(layout["cell_data"])},
            cell_sets={k: per_block("cell_sets", i) for i, k in enumerate(layout["cell_sets"])},
        )


def from_bytes(data: bytes, fmt: str) -> Mesh:
    """Read a mesh written by :func:`to_bytes` (used to check round trips)."""
    spec = FORMATS[fmt]
    with tempfile.TemporaryDirectory(prefix="meshcore-") as tmp:
        path = os.path.join(tmp, "mesh" + spec.suffix)
        with open(path, "wb") as f:
            f.write(data)
        if fmt == "xdmf":  # the archive of mesh.xdmf and mesh.h5
            with zipfile.ZipFile(path) as z:
                z.extractall(tmp)
            path = os.path.join(tmp, "mesh.xdmf")
        reader = "gmsh" if fmt.startswith("gmsh") else spec.meshio_name
        return from_meshio(meshio.read(path, file_format=reader))
