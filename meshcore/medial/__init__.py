"""The medial axis and its applications (§9.4, §9.6, §9.7).

:func:`medial_axis` approximates the axis from the Delaunay triangulation of
boundary samples (§9.4), :func:`medial_transform` rebuilds the domain from
it (§9.6), :func:`partition` and :func:`quad_medial` cut the domain into
regions and mesh them with quads (§9.7.1, §9.7.2), :func:`simplify`
removes small features (§9.7.4).
"""

from meshcore.medial.axis import MedialAxis, medial_axis
from meshcore.medial.partitioning import Partition, QuadMedial, partition, quad_medial
from meshcore.medial.simplification import Simplification, simplify
from meshcore.medial.transform import MedialTransform, checked_axis, medial_transform

__all__ = [
    "MedialAxis",
    "MedialTransform",
    "Partition",
    "QuadMedial",
    "Simplification",
    "checked_axis",
    "medial_axis",
    "medial_transform",
    "partition",
    "quad_medial",
    "simplify",
]
