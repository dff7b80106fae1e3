"""Imported last by the job fork server: load numba kernels once, then freeze the heap.

Jobs run in processes forked from the fork server, so whatever the server
has loaded, every job has for free. numba compiles (or loads from its disk
cache) a kernel on its first call; running the kernels once here on a tiny
domain moves that cost (about 0.3 s per kernel family from the cache, up
to a minute in all on a fresh clone's empty cache) from every job to the
service start. The service answers meanwhile: the fork server warms up in
the background, and jobs queue until it is done (see
:mod:`service.executors.local`).

The steps (:data:`STEPS`): triangulating a square with a hole, with and
without keeping its boundary, runs the domain checks, the Delaunay kernel,
the admissible boundary, the constrained triangulation and the refinement;
a quad mesh on the medial-axis partition runs the medial-axis kernels;
quad combination by each algorithm, optimized, runs the combination and
optimization kernels; a cube's corners run the 3D Delaunay kernel; the text
writers and the preview's edge kernels (which run in the API process) are
compiled into numba's disk cache here too. Each step is logged as
``compiling kernels 4/12: triangulate`` and,
when ``MESHSERVICE_WARMUP_STATUS`` names a file, recorded there as JSON
(``{"done", "total", "current", "left"}``) for ``/readyz``; once that file's
folder is gone (the service removes it as it stops, and a service started again on
the same data directory removes the one a killed service left), the warm-up stops
before its next step. With the
``warmup`` setting false (``MESHSERVICE_WARMUP=0``) no step runs: each job
then loads, from numba's cache, the kernels it uses.
"""

from __future__ import annotations

import gc
import json
import os
import sys
import time
from collections.abc import Callable

from service.executors import WARMUP_ENV, WARMUP_STATUS_ENV


def _square_with_hole():
    from meshcore.domain.planar import parse_domain

    return parse_domain(
        {
            "type": "Polygon",
            "coordinates": [
                [[0, 0], [1, 0], [1, 1], [0, 1]],
                [[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]],
            ],
        }
    )


def _triangulate(keep: bool) -> Callable[[], None]:
    def step() -> None:
        from meshcore.triangulation.refinement import triangulate

        triangulate(_square_with_hole(), min_angle=30, size=0.2, keep_boundary=keep)

    return step


def _quad_medial() -> None:
    from meshcore.medial.partitioning import quad_medial

    quad_medial(_square_with_hole(), levels=0, h=0.05)


def _medial_axis() -> None:
    from meshcore.medial.axis import medial_axis

    medial_axis(points=[[0, 0], [1, 0], [1, 1], [0, 1]])


def _delaunay3d() -> None:
    from meshcore.delaunay import delaunay3d

    delaunay3d([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])


def _combine(algorithm: str) -> Callable[[], None]:
    def step() -> None:
        from meshcore.quads.combination import combine

        combine(domain=_square_with_hole(), size=0.2, algorithm=algorithm, optimize=True)

    return step


def _writers() -> None:
    import numpy as np

    from meshcore.mesh import CellBlock, Mesh, io

    mesh = Mesh(np.array([[0, 0], [1, 0], [0, 1.0]]), (CellBlock("triangle", [[0, 1, 2]]),))
    io.to_bytes(mesh, "obj")


def _previews() -> None:
    import numpy as np

    from meshcore.mesh import CellBlock, Mesh
    from service import preview

    mesh = Mesh(np.array([[0, 0], [1, 0], [0, 1.0]]), (CellBlock("triangle", [[0, 1, 2]]),))
    preview.render_svg({}, mesh)


#: The warm-up, in order: (name, function).
STEPS: list[tuple[str, Callable[[], None]]] = [
    ("triangulate", _triangulate(False)),
    ("triangulate (boundary kept)", _triangulate(True)),
    ("quad_medial", _quad_medial),
    ("medial_axis (points)", _medial_axis),
    ("delaunay3d (co-spherical ties)", _delaunay3d),
    *[(f"quad_combine ({a})", _combine(a)) for a in ("stack", "heap", "frontal", "matching")],
    ("download writers", _writers),
    ("previews", _previews),
]


def _record(path: str | None, done: int, current: str) -> bool:
    """Write the status into ``path`` (if given); False when its folder is gone: the
    service removes it as it stops (:meth:`~service.executors.local.LocalExecutor.close`),
    and a warm-up no one waits for is abandoned."""
    if not path:
        return True
    status = {
        "done": done,
        "total": len(STEPS),
        "current": current,
        "left": [name for name, _ in STEPS[done:]],
    }
    tmp = f"{path}.tmp"
    try:
        with open(tmp, "w") as f:
            json.dump(status, f)
        os.replace(tmp, path)
    except FileNotFoundError:
        return False
    return True


def warm(log: Callable[[str], None], status_path: str | None = None) -> None:
    """Run every step of :data:`STEPS`, logging and recording progress.

    A step that fails is logged and skipped: its kernels then compile in
    the first job that needs them. The warm-up stops before its next step once
    ``status_path``'s folder is gone (the service stopped).
    """
    started = time.monotonic()
    for i, (name, step) in enumerate(STEPS):
        if not _record(status_path, i, name):
            log("warm-up abandoned: the service stopped")
            return
        log(f"compiling kernels {i + 1}/{len(STEPS)}: {name}")
        try:
            step()
        except Exception as exc:  # a warm-up step must not stop the server
            log(f"warm-up step {name!r} failed ({type(exc).__name__}: {exc}); skipped")
    _record(status_path, len(STEPS), "")
    log(f"kernels ready in {time.monotonic() - started:.1f} s")


def _log(message: str) -> None:
    print(f"INFO:     {message}", file=sys.stderr, flush=True)


if os.environ.get(WARMUP_ENV) != "0":
    warm(_log, os.environ.get(WARMUP_STATUS_ENV))

# Jobs are forked from here: keep the collector off what is loaded by now, so
# a job's garbage collections do not touch (and copy) these pages.
gc.collect()
gc.freeze()
