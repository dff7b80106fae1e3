"""Our Delaunay kernel, constrained Delaunay and Delaunay-admissible boundaries (§9.1).

:func:`delaunay` triangulates a point set with exact predicates;
:mod:`.cdt` holds the compiled constrained-Delaunay and refinement kernels;
:func:`make_admissible` and :func:`admissible_segments` add the Steiner
points that make every boundary segment a Delaunay edge (§9.1).
"""

from meshcore.delaunay.admissible import (
    AdmissibleBoundary,
    AdmissibleSegments,
    admissible_segments,
    circles_of,
    classify_segments,
    make_admissible,
    restricted_triangles,
)
from meshcore.delaunay.kernel2d import Triangulation, delaunay
from meshcore.delaunay.kernel3d import (
    IncrementalDelaunay3d,
    Insertion,
    Location,
    Tetrahedralization,
    delaunay3d,
)

__all__ = [
    "AdmissibleBoundary",
    "AdmissibleSegments",
    "IncrementalDelaunay3d",
    "Insertion",
    "Location",
    "Tetrahedralization",
    "Triangulation",
    "admissible_segments",
    "circles_of",
    "classify_segments",
    "delaunay",
    "delaunay3d",
    "make_admissible",
    "restricted_triangles",
]
