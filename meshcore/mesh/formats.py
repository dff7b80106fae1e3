"""The download formats by name (:data:`FORMATS`): plain data, importable without numpy.

:mod:`meshcore.mesh.io` writes them; a client (``meshservice submit
--format``) needs only their names, and importing this module costs it no
more than the standard library (the ``meshcore`` and ``meshcore.mesh``
packages load their contents on first use).
"""

from __future__ import annotations

from dataclasses import dataclass


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
    "glb": FileFormat("glb", ".glb", "model/gltf-binary"),  # written by to_glb, not meshio
}
