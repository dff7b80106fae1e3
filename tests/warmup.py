"""Fill numba's disk cache on the second core while the suite runs (``tests/conftest.py``).

On a fresh clone the cache is empty and the first test to call each compiled
kernel compiles it: minutes in all, on the one core pytest runs on. This
process, started in the background at the session's start, runs the service's
own warm-up steps (:mod:`service.executors.preload`: triangulation, medial
axis, quad combination, the 3D Delaunay kernel, the writers), then the 3D
methods' kernels on small surfaces. A kernel a test reaches first is compiled
by that test, exactly as without this process; nothing here is asserted.
"""

from __future__ import annotations

import service.executors.preload  # noqa: F401  (runs the fork server's steps on import)
from meshcore.delaunay.admissible3d import make_admissible_surface
from meshcore.optimize import optimize
from meshcore.tets import tetrahedralize
from tests.meshcore.domain.shapes import box, icosphere

points, triangles = box()
surface = {"points": points.tolist(), "triangles": triangles.tolist()}
tetrahedralize(surface, max_radius_edge=2.0, min_dihedral=15.0, size=0.5)
make_admissible_surface(surface)
sphere_points, sphere_triangles = icosphere(1)
optimize(surface={"points": sphere_points.tolist(), "triangles": sphere_triangles.tolist()})
