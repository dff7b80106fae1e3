"""Tetrahedral meshes of closed surfaces (§9.2, §9.3, §9.5; Shewchuk's Delaunay refinement).

:func:`tetrahedralize` recovers the surface in our 3D Delaunay kernel
(conforming, points added on the surface) and refines the tetrahedra to a
radius-edge, volume and size bound; :func:`tetra_dihedral_angles` measures
slivers, :func:`tetra_radius_edge` the ratio that bound holds.
"""

from meshcore.tets.refinement import (
    TetrahedralizationResult,
    tetra_dihedral_angles,
    tetra_radius_edge,
    tetrahedralize,
)

__all__ = [
    "TetrahedralizationResult",
    "tetra_dihedral_angles",
    "tetra_radius_edge",
    "tetrahedralize",
]
