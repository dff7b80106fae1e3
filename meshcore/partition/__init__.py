"""Recursive partition (divide and conquer, §8.7.2): :func:`recursive_partition` (2D, and 3D
with ``surface=``, :func:`recursive_partition_3d`).

:mod:`.boundary` holds the size map (Remark 8.10) and the boundary
resampling with even ring counts (Remark 8.9) that the direct quad methods
share; :func:`partition_polygon` meshes point loops keeping their vertices.
"""

from meshcore.partition.boundary import BoundaryResampling, SizeMap, resample_boundary, size_map
from meshcore.partition.recursive import (
    PartitionResult,
    partition_polygon,
    recursive_partition,
    split_triangles,
)
from meshcore.partition.recursive3d import recursive_partition_3d
from meshcore.partition.smoothing import (
    boundary_edges,
    boundary_points,
    smooth_quads,
    square_corners,
)

__all__ = [
    "BoundaryResampling",
    "PartitionResult",
    "SizeMap",
    "boundary_edges",
    "boundary_points",
    "partition_polygon",
    "recursive_partition",
    "recursive_partition_3d",
    "resample_boundary",
    "size_map",
    "smooth_quads",
    "split_triangles",
    "square_corners",
]
