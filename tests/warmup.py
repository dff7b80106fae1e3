"""Fill numba's disk cache while the first tests run (``tests/conftest.py``).

``python -m tests.warmup N`` runs, in N forked processes that each take the
next task as soon as they are free, every step of the job fork server's
warm-up (:data:`service.executors.preload.STEPS`), the 3D methods on small
surfaces, and every method example of the service's registry through the job
runner, as a job would. The two largest families of kernels come first, one
per process: the 2D triangulation and the 3D ones. A kernel no task reaches
is compiled by the first test that calls it, as before; nothing here is
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


def _tasks() -> list[str]:
    steps = [name for name, _ in STEPS]
    examples = sorted(default_registry())
    return [steps[0], "3d", *steps[1:], *examples]


def _run(task: str) -> None:
    steps = dict(STEPS)
    try:
        if task in steps:
            steps[task]()
        elif task == "3d":
            _three_d()
        else:
            spec = default_registry()[task]
            run_job(spec, json.dumps(spec.example).encode(), lambda *_: None, ("vtu",))
    except Exception as exc:  # a warm-up: the tests say what is wrong
        print(f"warm-up: {task}: {type(exc).__name__}: {exc}", file=sys.stderr)


if __name__ == "__main__":
    processes = int(sys.argv[1])
    with multiprocessing.get_context("fork").Pool(processes, initializer=die_with_parent) as pool:
        for _ in pool.imap_unordered(_run, _tasks(), chunksize=1):
            pass
