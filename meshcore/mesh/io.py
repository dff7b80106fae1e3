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

``glb`` (glTF 2.0 binary, for web viewers) is written here with numpy, not
through meshio, by :func:`to_glb`. glTF attributes are per vertex, so to
colour each cell by its own quality the drawn triangles do not share
vertices: every triangle has its three own vertices (``POSITION`` and
``_QUALITY``, non-indexed), the price of flat per-cell colours (48 bytes a
triangle against about 20 shared). What is drawn: triangles as they are,
quads split along their 0-2 diagonal, and of 3D cells their boundary faces
(held by one cell; quads split likewise), each with its cell's quality (the
values the quality report summarizes). The cell edges (a quad's four, not
its diagonal) are a second, indexed ``LINES`` primitive over the same
vertices (the optional wireframe layer); line cells and vertex cells are
indexed ``LINES`` and ``POINTS`` primitives over the mesh's own points (with
the point data ``radius`` as ``_RADIUS`` when present). Positions are
float32 relative to the bounding-box centre, which is the node's float64
``translation``, so a mesh far from the origin keeps its precision. Each
primitive's ``extras.layer`` names it (``cells``, ``edges``, ``lines``,
``points``); ``extras.cell_types`` of ``cells`` gives the source cell type of
each run of triangles (``[[type, first triangle], ...]``). Cell sets are not
carried.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from io import BytesIO

import meshio
import numpy as np

from meshcore.errors import InputError
from meshcore.mesh import topology, writers
from meshcore.mesh.formats import FORMATS
from meshcore.mesh.mesh import CELL_TYPES, CellBlock, Mesh
from meshcore.mesh.quality import reported_quality


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
    if fmt == "glb":
        return to_glb(mesh)
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
    """Read a mesh written by :func:`to_bytes` (used to check round trips; not ``glb``)."""
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


# ----------------------------------------------------------------------------- glb

_GLB_MAGIC, _GLB_JSON, _GLB_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942
_FLOAT32, _UINT32 = 5126, 5125
_POINTS, _LINES, _TRIANGLES = 0, 1, 4
#: The triangles a face is drawn with, as local corners.
_SPLIT = {"triangle": np.array([[0, 1, 2]]), "quad": np.array([[0, 1, 2], [0, 2, 3]])}
#: A face's own edges (not a quad's diagonal) as (triangle of the split, corner, corner).
_FACE_EDGES = {
    "triangle": np.array([[0, 0, 1], [0, 1, 2], [0, 2, 0]]),
    "quad": np.array([[0, 0, 1], [0, 1, 2], [1, 1, 2], [1, 2, 0]]),
}


def _drawn_faces(mesh: Mesh) -> list[tuple[str, np.ndarray, np.ndarray, str]]:
    """``(face type, (f, k) nodes, (f,) quality, source cell type)`` runs to draw.

    A 2D mesh's triangles and quads; a 3D mesh's boundary faces with the
    quality of the cell holding them, grouped by that cell's type.
    """
    dim = max((CELL_TYPES[b.type][1] for b in mesh.cells), default=0)
    if dim == 2:
        return [
            (b.type, b.data, reported_quality(mesh.points, b.data, b.type), b.type)
            for b in mesh.cells
            if b.type in _SPLIT and len(b)
        ]
    if dim < 3:
        return []
    top = tuple(b for b in mesh.cells if CELL_TYPES[b.type][1] == 3)
    quality = np.concatenate([reported_quality(mesh.points, b.data, b.type) for b in top])
    source = np.concatenate([np.full(len(b), i) for i, b in enumerate(top)])
    bnd = topology.boundary(Mesh(mesh.points, top))
    runs = []
    for i, b in enumerate(top):
        for face, holder in zip(bnd.cells, bnd.cell_data["cell"], strict=True):
            mine = source[holder] == i
            if np.any(mine):
                runs.append((face.type, face.data[mine], quality[holder[mine]], b.type))
    return runs


class _Bin:
    """The BIN chunk being built: buffer views and accessors over float32/uint32 arrays."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(
        self, array: np.ndarray, kind: str, target: int, bounds: np.ndarray | None = None
    ) -> int:
        """A view and an accessor over ``array``; ``bounds``: the (2, 3) min and max to state."""
        data = np.ascontiguousarray(array, dtype=np.uint32 if kind == "SCALAR_U" else np.float32)
        self.views.append(
            {"buffer": 0, "byteOffset": self.size, "byteLength": data.nbytes, "target": target}
        )
        self.parts.append(data.tobytes())
        self.size += data.nbytes  # 4-byte components: every view stays aligned
        accessor = {
            "bufferView": len(self.views) - 1,
            "componentType": _UINT32 if kind == "SCALAR_U" else _FLOAT32,
            "count": len(data),
            "type": "VEC3" if kind == "VEC3" else "SCALAR",
        }
        if bounds is not None:
            accessor["min"], accessor["max"] = bounds.tolist()
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def _bounds(local: np.ndarray, used: np.ndarray) -> np.ndarray:
    """(2, 3) min and max of the points ``used`` (indices, repeats allowed)."""
    mask = np.zeros(len(local), dtype=bool)
    mask[used] = True
    pts = local[mask]
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def to_glb(mesh: Mesh, extras: dict | None = None) -> bytes:
    """The mesh as glTF 2.0 binary (``.glb``) for web viewers; see the module docstring.

    Parameters
    ----------
    mesh : Mesh
        Checked (so it has cells); 2D points are drawn at z = 0.
    extras : dict, optional
        JSON put in the glTF's top-level ``extras`` (the service puts the
        result's quality report and stats there).

    Returns
    -------
    bytes
        A valid glb: one scene, one node (translated to the bounding-box
        centre), one mesh of up to four primitives (``cells`` triangles
        with ``_QUALITY`` in [0, 1], ``edges`` lines, ``lines`` of the line
        cells, ``points`` of the vertex cells).
    """
    points = mesh.points
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    lo, hi = (points.min(axis=0), points.max(axis=0)) if len(points) else (np.zeros(3),) * 2
    center = (lo + hi) / 2
    local = (points - center).astype(np.float32)
    out = _Bin()
    primitives = []
    runs = _drawn_faces(mesh)
    if runs:
        tris, quality, keys, edge_ends, cell_types = [], [], [], [], []
        first, n = 0, len(points)
        for ftype, nodes, q, source in runs:
            split, fe = _SPLIT[ftype], _FACE_EDGES[ftype]
            f, s = len(nodes), len(split)
            tris.append(nodes[:, split].reshape(-1))
            quality.append(np.repeat(q.astype(np.float32), 3 * s))
            # edge j of face i joins the split vertices corner + fe[j, 1] and corner + fe[j, 2]
            corner = 3 * (first + np.arange(f)[:, None] * s + fe[:, 0])  # (f, e)
            a = nodes[:, split[fe[:, 0], fe[:, 1]]].ravel()
            b = nodes[:, split[fe[:, 0], fe[:, 2]]].ravel()
            keys.append(topology.edge_keys(a, b, n))
            edge_ends.append(((corner + fe[:, 1]).ravel(), (corner + fe[:, 2]).ravel()))
            cell_types.append([source, first])
            first += f * s
        corners = np.concatenate(tris)
        position = out.add(local[corners], "VEC3", 34962, bounds=_bounds(local, corners))
        _, once = np.unique(np.concatenate(keys), return_index=True)
        ends = np.column_stack([np.concatenate([e[k] for e in edge_ends])[once] for k in (0, 1)])
        primitives.append(
            {
                "attributes": {
                    "POSITION": position,
                    "_QUALITY": out.add(np.concatenate(quality), "SCALAR", 34962),
                },
                "mode": _TRIANGLES,
                "material": 0,
                "extras": {"layer": "cells", "cell_types": cell_types},
            }
        )
        primitives.append(
            {
                "attributes": {"POSITION": position},
                "indices": out.add(ends.ravel(), "SCALAR_U", 34963),
                "mode": _LINES,
                "extras": {"layer": "edges"},
            }
        )
    for ctype, mode, layer in (("line", _LINES, "lines"), ("vertex", _POINTS, "points")):
        blocks = [b.data for b in mesh.cells if b.type == ctype and len(b)]
        if not blocks:
            continue
        indices = np.concatenate(blocks).ravel()
        every = np.arange(len(local))  # the accessor holds every point, used or not
        attributes = {"POSITION": out.add(local, "VEC3", 34962, bounds=_bounds(local, every))}
        radius = mesh.point_data.get("radius")
        if radius is not None and radius.shape == (len(points),):
            attributes["_RADIUS"] = out.add(radius, "SCALAR", 34962)
        primitives.append(
            {
                "attributes": attributes,
                "indices": out.add(indices, "SCALAR_U", 34963),
                "mode": mode,
                "extras": {"layer": layer},
            }
        )
    gltf: dict = {
        "asset": {"version": "2.0", "generator": "meshcore"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": center.tolist()}],
        "meshes": [{"primitives": primitives}],
        "materials": [
            {
                "doubleSided": True,
                "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0},
            }
        ],
        "buffers": [{"byteLength": out.size}],
        "bufferViews": out.views,
        "accessors": out.accessors,
    }
    if extras:
        gltf["extras"] = extras
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary = b"".join(out.parts)
    total = 12 + 8 + len(text) + 8 + len(binary)
    header = np.array([_GLB_MAGIC, 2, total, len(text), _GLB_JSON], dtype="<u4").tobytes()
    bin_header = np.array([len(binary), _GLB_BIN], dtype="<u4").tobytes()
    return header + text + bin_header + binary


#: Suffixes an upload may have: meshio's, less TetGen's two-file format (its reader
#: also loops forever on an empty ``.node``).
UPLOAD_SUFFIXES = frozenset(meshio.extension_to_filetypes) - {".node", ".ele"}


def from_file(data: bytes, filename: str) -> Mesh:
    """A checked :class:`Mesh` from the bytes of a file in any format meshio reads.

    The reader is chosen by the suffix of ``filename`` (as meshio does, the
    longest known suffix wins: ``.vol.gz`` before ``.gz``; TetGen's two-file
    ``.node``/``.ele`` is not taken); the mesh keeps
    the cell types of :data:`~meshcore.mesh.mesh.CELL_TYPES` as
    :func:`from_meshio` does.

    Raises
    ------
    InputError
        ``unsupported_format`` when meshio has no one-file reader for the suffix;
        ``unreadable_file`` when the reader fails on the bytes; ``no_cells``
        when the file holds no cell of a known type; and the codes of
        :meth:`Mesh.check`.
    """
    name = os.path.basename(filename).lower()
    suffixes = sorted(UPLOAD_SUFFIXES, key=len, reverse=True)
    suffix = next((s for s in suffixes if name.endswith(s)), None)
    if suffix is None:
        raise InputError(
            f"no reader for {filename!r}: name the file with one of meshio's suffixes "
            f"({', '.join(sorted(UPLOAD_SUFFIXES))}; TetGen's .node and .ele come as two files "
            "and cannot be uploaded as one)",
            loc=("filename",),
            code="unsupported_format",
        )
    with tempfile.TemporaryDirectory(prefix="meshcore-") as tmp:
        path = os.path.join(tmp, "upload" + suffix)
        with open(path, "wb") as f:
            f.write(data)
        try:
            m = meshio.read(path)
        # any reader on untrusted bytes: a 4xx, never a 500; and meshio calls
        # sys.exit(1) when every reader of the suffix refused the file
        except (Exception, SystemExit) as exc:  # noqa: BLE001
            why = (
                "refused by meshio"
                if isinstance(exc, SystemExit)
                else f"{type(exc).__name__}: {exc}"
            )
            raise InputError(
                f"the file could not be read as {suffix}: {why}"[:500],
                loc=("body",),
                code="unreadable_file",
            ) from None
    try:
        mesh = from_meshio(m)
    except (ValueError, TypeError, IndexError, KeyError) as exc:
        raise InputError(
            f"the file's mesh does not fit the mesh shape: {exc}"[:500],
            loc=("body",),
            code="unreadable_file",
        ) from None
    if not any(len(b) for b in mesh.cells):
        raise InputError(
            f"the file holds no cells of a known type ({', '.join(CELL_TYPES)})",
            loc=("body",),
            code="no_cells",
        )
    return mesh.check()
