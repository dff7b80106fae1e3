"""Quality triangle meshes of planar domains by Delaunay refinement (§9.1, DESIGN.md).

:func:`triangulate` meshes a validated domain so that every input segment
is a chain of edges and the angle, area and size bounds hold.
"""

from meshcore.triangulation.refinement import (
    MAX_POINTS,
    Estimate,
    TriangulationResult,
    check_thinness,
    estimated_triangles,
    triangulate,
)

__all__ = [
    "MAX_POINTS",
    "Estimate",
    "TriangulationResult",
    "check_thinness",
    "estimated_triangles",
    "triangulate",
]
