"""Fill numba's disk cache while the first tests run (``tests/conftest.py``).

``python -m tests.warmup N [API_READY]`` runs, in N forked processes that
each take the next task as soon as they are free: the kernels the API process
runs on a request (the domain checks of a submit, the big-body parser, the
previews and download writers), then every step of the job fork server's
warm-up (:data:`service.executors.preload.STEPS`), the 3D methods on small
surfaces, Coupez's 2D generation, and every method example of the service's registry through the job
runner, as a job would. The API kernels come first, and the file named
``API_READY`` is created as soon as they are in the cache: the service tests
that run no method kernel wait only for them (every pytest worker compiled
them at once otherwise, four copies of the same work). The 3D family, the
largest, starts at once in the other process. A kernel no task reaches is
compiled by the first test that calls it, as before; nothing here is
asserted.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys

from service.executors import WARMUP_ENV
from service.executors.child import die_with_parent

os.environ[WARMUP_ENV] = "0"  # importing the fork server's steps must not run them all
from service.executors.preload import STEPS  # noqa: E402
from service.methods.registry import default_registry  # noqa: E402
from service.runner import run_job  # noqa: E402


def _api() -> None:
    from meshcore.domain.planar import parse_domain
    from service import bodies

    steps = dict(STEPS)
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    parse_domain({"type": "Polygon", "coordinates": [square]}, [[[0.2, 0.2], [0.8, 0.7]]])
    ring = ",".join(f"[{i % 97}.5,{i // 97}.25]" for i in range(bodies.MIN_BODY // 8))
    bodies.extract_coordinates(f'{{"coordinates":[[{ring}]]}}'.encode())
    steps["download writers"]()
    steps["previews"]()


def _three_d() -> None:
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


def _optimize_2d() -> None:
    """Coupez's 2D generation, with and without insertion (the registry's example is 3D):
    the tests of four workers compiled its kernels at once otherwise."""
    from meshcore.domain.planar import parse_domain
    from meshcore.optimize import optimize

    rings = [[[0, 0], [4, 0], [4, 4], [0, 4]], [[1, 1], [1, 2], [2, 2], [2, 1]]]
    domain = parse_domain({"type": "Polygon", "coordinates": rings})
    optimize(domain=domain, insert_points=False)
    optimize(domain=domain, size=0.4, keep_boundary=False)


def _tasks() -> list[str]:
    steps = [name for name, _ in STEPS]
    examples = sorted(default_registry())
    return ["api", "3d", *steps, "optimize 2d", *examples]


def _run(task: str) -> str:
    steps = dict(STEPS)
    try:
        if task in steps:
            steps[task]()
        elif task == "api":
            _api()
        elif task == "3d":
            _three_d()
        elif task == "optimize 2d":
            _optimize_2d()
        else:
            spec = default_registry()[task]
            run_job(spec, json.dumps(spec.example).encode(), lambda *_: None, ("vtu",))
    except Exception as exc:  # a warm-up: the tests say what is wrong
        print(f"warm-up: {task}: {type(exc).__name__}: {exc}", file=sys.stderr)
    return task


if __name__ == "__main__":
    processes = int(sys.argv[1])
    api_ready = sys.argv[2] if len(sys.argv) > 2 else None
    with multiprocessing.get_context("fork").Pool(processes, initializer=die_with_parent) as pool:
        for done in pool.imap_unordered(_run, _tasks(), chunksize=1):
            if done == "api" and api_ready:
                open(api_ready, "a").close()
