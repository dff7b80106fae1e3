"""Fill numba's disk cache before pytest-xdist's workers start (``tests/conftest.py``).

On a fresh clone the cache is empty, and every worker that reaches a kernel
before it is cached compiles it again: four workers starting on the same
kernels made the suite's compile work about four times larger. The
controller runs ``python -m tests.warmup PART PARTS`` in PARTS processes at
once and waits: part ``k`` runs every PARTS-th method example of the
service's registry (through the job runner, as a job would), and part 0
also the job fork server's own warm-up steps (:mod:`service.executors.preload`)
and the 3D methods on small surfaces. A kernel no part reaches is compiled by
the first test that calls it, as before; nothing here is asserted.
"""

from __future__ import annotations

import json
import sys

from service.methods.registry import default_registry
from service.runner import run_job


def _examples(part: int, parts: int) -> None:
    specs = sorted(default_registry().values(), key=lambda spec: spec.name)
    for spec in specs[part::parts]:
        try:
            run_job(spec, json.dumps(spec.example).encode(), lambda *_: None, ("vtu",))
        except Exception as exc:  # a warm-up: the tests say what is wrong
            print(f"warm-up: {spec.name}: {type(exc).__name__}: {exc}", file=sys.stderr)


def _fork_server_steps_and_3d() -> None:
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


if __name__ == "__main__":
    part, parts = int(sys.argv[1]), int(sys.argv[2])
    if part == 0:
        _fork_server_steps_and_3d()
    _examples(part, parts)
