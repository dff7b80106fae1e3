"""Imported last by the job fork server: load numba kernels once, then freeze the heap.

Jobs run in processes forked from the fork server, so whatever the server
has loaded, every job has for free. numba compiles (or loads from its disk
cache) a kernel on its first call; running the kernels once here on a tiny
domain moves that cost (about 0.3 s per kernel family) from every job to
the service start. Triangulating a square with a hole, with and without
keeping its boundary, runs the domain checks, the Delaunay kernel, the
admissible boundary, the constrained triangulation and the refinement; a
quad mesh on the medial-axis partition runs the medial-axis kernels; quad
combination by each algorithm, optimized, runs the combination and
optimization kernels; a cube's corners run the 3D Delaunay kernel.
"""

import gc

from meshcore.delaunay import delaunay3d
from meshcore.domain.planar import parse_domain
from meshcore.medial.axis import medial_axis
from meshcore.medial.partitioning import quad_medial
from meshcore.quads.combination import combine
from meshcore.triangulation.refinement import triangulate

_SQUARE_WITH_HOLE = parse_domain(
    {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [1, 0], [1, 1], [0, 1]],
            [[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]],
        ],
    }
)
for _keep in (False, True):
    triangulate(_SQUARE_WITH_HOLE, min_angle=30, size=0.2, keep_boundary=_keep)
# the medial axis kernels (polygon and point cloud), the partition's faces
quad_medial(_SQUARE_WITH_HOLE, levels=0, h=0.05)
medial_axis(points=[[0, 0], [1, 0], [1, 1], [0, 1]])
# the 3D Delaunay kernel, co-spherical ties included
delaunay3d([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
# the quad combination kernels: the four selection algorithms and the optimizer
for _alg in ("stack", "heap", "frontal", "matching"):
    combine(domain=_SQUARE_WITH_HOLE, size=0.2, algorithm=_alg, optimize=True)

# Jobs are forked from here: keep the collector off what is loaded by now, so
# a job's garbage collections do not touch (and copy) these pages.
gc.collect()
gc.freeze()
