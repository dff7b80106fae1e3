"""How often the 3D methods fail on valid random surfaces: star polyhedra, drawn by seed.

Run from the repository root::

    .venv/bin/python benchmarks/robustness3d.py                      # 300 seeds, every method
    .venv/bin/python benchmarks/robustness3d.py --seeds 1 20000 --methods admissible
    .venv/bin/python benchmarks/robustness3d.py --seeds 4 5 --methods tetrahedralize

Each seed draws the family of the tests' ``star_polyhedra``
(``tests/meshcore/delaunay/test_admissible3d.py``): 6 to 30 random
directions plus the six axes, radii uniform in [0.5, 1.5], the convex hull's
triangles moved out to those radii (a valid closed surface, star-shaped
from the origin, with sharp edges where neighbouring radii differ).
``admissible`` runs :func:`meshcore.delaunay.admissible3d.make_admissible_surface`,
``tetrahedralize`` :func:`meshcore.tets.tetrahedralize` on its defaults
(radius-edge 2), ``optimize`` :func:`meshcore.optimize.optimize` (Coupez's
generation from the surface, on its defaults) and ``recursive_partition``
:func:`meshcore.partition.recursive.recursive_partition` (``size`` 0.3:
about a fifth of the radii). Every run is limited to ``--limit`` CPU
seconds (``ITIMER_PROF``: the count does not depend on the machine's load;
checked when a compiled kernel returns), after a warm-up on a cube that
compiles the kernels (a limit firing inside numba's compiler breaks it).
Prints, per method, the seeds that raised (with the error), timed out or
gave a tetrahedron that is not positive by the exact ``orient3d``, and the
counts: every valid surface should succeed, so every line but ``ok`` is a
defect to fix.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from collections import Counter

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from meshcore.delaunay.admissible3d import make_admissible_surface  # noqa: E402
from meshcore.geometry.predicates3d import orient3d  # noqa: E402
from meshcore.optimize import optimize  # noqa: E402
from meshcore.partition.recursive import recursive_partition  # noqa: E402
from meshcore.tets import tetrahedralize  # noqa: E402
from tests.meshcore.domain import shapes  # noqa: E402


class TimedOut(Exception):
    pass


def star_polyhedron(seed: int) -> dict:
    """The surface of ``seed``: ``{"points", "triangles"}``."""
    first = np.random.default_rng(seed)
    n, inner = int(first.integers(6, 31)), int(first.integers(0, 2**31 - 1))
    rng = np.random.default_rng(inner)
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(n, 3))])
    P, T = shapes.star(rng.uniform(0.5, 1.5, size=len(d)), d)
    return {"points": P.tolist(), "triangles": T.tolist()}


def _positive(mesh) -> bool:
    X, K = mesh.points, mesh.cells[0].data  # meshio's order: (0, 1, 3, 2) in ours
    return bool((orient3d(X[K[:, 0]], X[K[:, 1]], X[K[:, 3]], X[K[:, 2]]) > 0).all())


METHODS = {
    "admissible": lambda s: _positive(make_admissible_surface(s).mesh),
    "optimize": lambda s: _positive(optimize(surface=s).mesh),
    "recursive_partition": lambda s: _positive(recursive_partition(surface=s, size=0.3).mesh),
    "tetrahedralize": lambda s: _positive(tetrahedralize(s).mesh),
}


def _on_alarm(*_):
    raise TimedOut


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 300], metavar=("FIRST", "LAST"))
    ap.add_argument("--methods", nargs="*", choices=sorted(METHODS), default=sorted(METHODS))
    ap.add_argument("--limit", type=float, default=20, help="CPU seconds per run")
    args = ap.parse_args()
    signal.signal(signal.SIGPROF, _on_alarm)
    P, T = shapes.box()
    cube = {"points": P.tolist(), "triangles": T.tolist()}
    for name in args.methods:
        METHODS[name](cube)  # compiles (or loads) the kernels outside the limit
        counts: Counter = Counter()
        started = time.perf_counter()
        for seed in range(args.seeds[0], args.seeds[1] + 1):
            surface = star_polyhedron(seed)
            signal.setitimer(signal.ITIMER_PROF, args.limit)
            try:
                outcome = "ok" if METHODS[name](surface) else "not positive"
            except TimedOut:
                outcome = f"over {args.limit:g} CPU s"
            except Exception as exc:  # every failure is reported, none stops the run
                outcome = type(exc).__name__
                print(f"{name} seed {seed}: {outcome}: {str(exc)[:160]}", flush=True)
            finally:
                signal.setitimer(signal.ITIMER_PROF, 0)
            if outcome in ("not positive", f"over {args.limit:g} CPU s"):
                print(f"{name} seed {seed}: {outcome}", flush=True)
            counts[outcome] += 1
        total = sum(counts.values())
        print(
            f"\n{name}: {total} surfaces in {time.perf_counter() - started:.0f} s: "
            + ", ".join(f"{k} {v} ({100 * v / total:.2f} %)" for k, v in counts.most_common())
            + "\n",
            flush=True,
        )


if __name__ == "__main__":
    main()
