"""Extrusion side by side with Gmsh: wall time, cells per second, peak memory.

The base is the unit square meshed by Gmsh (``Mesh.MeshSizeMax = 0.0048``:
about 100k triangles); both sides sweep the very same triangles:

- ``translate x10`` and ``translate x100``: 1 unit along z in 10 and 100
  layers (about 1M and 10M wedges);
- ``rotate 360 x100``: the square moved to x in [1, 2], a full turn about the
  y axis in 100 layers. Gmsh's built-in kernel needs rotations under 180°
  per extrusion, so it revolves four times by 90° with 25 layers each; we
  take 360° in one call (the ring closes).

Gmsh: ``gmsh.model.geo.extrude`` / ``revolve`` with ``numElements`` and
``recombine=True`` (prisms), after ``generate(2)`` (not timed); the time is
that of ``generate(3)``, which builds the layers. Ours:
:func:`meshcore.product.extrusion` on the base arrays, with its validity checks
on (the default) and, as a second figure, ``validate=False``. Each side runs
in its own process; the peak memory is that process's maximum resident set
(interpreter and libraries included). Ours is the best of three runs,
Gmsh's a single run.

Run with ``.venv/bin/python benchmarks/extrude.py`` (Gmsh from
``pip install -e .[bench]``; skipped with a note when absent). ``--quick``
drops the two 10M-cell cases.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

SIZE = 0.0048  # Gmsh mesh size giving ~100k triangles on the unit square

CASES = {
    "translate x10": ("translate", 10),
    "translate x100": ("translate", 100),
    "rotate 360 x100": ("rotate", 100),
}


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _gmsh_square(x0: float):
    import gmsh

    g = gmsh.model.geo
    p = [
        g.addPoint(x0, 0, 0),
        g.addPoint(x0 + 1, 0, 0),
        g.addPoint(x0 + 1, 1, 0),
        g.addPoint(x0, 1, 0),
    ]
    lines = [g.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
    return g.addPlaneSurface([g.addCurveLoop(lines)])


def make_base(path: str) -> None:
    """Mesh the unit square with Gmsh and save its nodes and triangles."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        s = _gmsh_square(0.0)
        gmsh.model.geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
        gmsh.option.setNumber("Mesh.MeshSizeMin", SIZE)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes(2, s, includeBoundary=True)
        order = np.argsort(tags)
        tags, coords = tags[order], coords.reshape(-1, 3)[order]
        _, nodes = gmsh.model.mesh.getElementsByType(2, s)
        tri = np.searchsorted(tags, nodes).reshape(-1, 3)
        np.savez(path, points=coords[:, :2], triangles=tri)
    finally:
        gmsh.finalize()


def run_gmsh(kind: str, layers: int) -> dict:
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        g = gmsh.model.geo
        if kind == "translate":
            s = _gmsh_square(0.0)
            g.extrude([(2, s)], 0, 0, 1, numElements=[layers], recombine=True)
        else:
            s = cur = _gmsh_square(1.0)
            for _ in range(4):
                out = g.revolve(
                    [(2, cur)],
                    0,
                    0,
                    0,
                    0,
                    1,
                    0,
                    math.pi / 2,
                    numElements=[layers // 4],
                    recombine=True,
                )
                cur = out[0][1]
        g.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
        gmsh.option.setNumber("Mesh.MeshSizeMin", SIZE)
        gmsh.model.mesh.generate(2)
        base = len(gmsh.model.mesh.getElementsByType(2, s)[0])
        t0 = time.perf_counter()
        gmsh.model.mesh.generate(3)
        seconds = time.perf_counter() - t0
        cells = len(gmsh.model.mesh.getElementsByType(6)[0])  # prisms
    finally:
        gmsh.finalize()
    return {"seconds": seconds, "cells": cells, "base": base, "peak_mb": peak_mb()}


def run_ours(kind: str, layers: int, base_path: str, validate: bool) -> dict:
    from meshcore.mesh import Mesh
    from meshcore.product.extrusion import Rotate, Translate, extrude

    data = np.load(base_path)
    points = data["points"] + ([1.0, 0.0] if kind == "rotate" else [0.0, 0.0])
    base = Mesh(points, [("triangle", data["triangles"])])
    path = (
        Translate([0, 0, 1], layers=layers)
        if kind == "translate"
        else Rotate([0, 0, 0], [0, 1, 0], 360, layers)
    )
    best, cells = math.inf, 0
    for _ in range(3):
        t0 = time.perf_counter()
        result = extrude(base, path, validate=validate)
        best = min(best, time.perf_counter() - t0)
        cells = sum(len(b) for b in result.mesh.cells if b.type == "wedge")
        del result
    return {"seconds": best, "cells": cells, "base": len(data["triangles"]), "peak_mb": peak_mb()}


def worker(args: list[str]) -> dict:
    """Run one measurement in this process (called through a subprocess)."""
    side, case, base_path = args
    kind, layers = CASES[case]
    if side == "gmsh":
        return run_gmsh(kind, layers)
    return run_ours(kind, layers, base_path, validate=side == "ours")


def measure(side: str, case: str, base_path: str) -> dict:
    here = os.path.abspath(__file__)
    root = os.path.dirname(os.path.dirname(here))
    out = subprocess.run(
        [sys.executable, here, "--worker", side, case, base_path],
        capture_output=True,
        text=True,
        cwd=root,
        check=True,
        env={**os.environ, "PYTHONPATH": root},
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the 10M-cell cases")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--base", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker)))
        return
    if args.base:
        make_base(args.base)
        return
    try:
        import gmsh  # noqa: F401
    except ImportError:
        print(
            "gmsh is not installed (pip install -e .[bench]): it makes the base mesh and is "
            "the peer, so this benchmark is skipped"
        )
        return
    cases = [c for c in CASES if not (args.quick and CASES[c][1] == 100)]
    with tempfile.TemporaryDirectory() as tmp:
        base_path = os.path.join(tmp, "base.npz")
        subprocess.run([sys.executable, os.path.abspath(__file__), "--base", base_path], check=True)
        head = (
            f"{'case':<16} {'wedges':>10} | {'ours s':>7} {'Mcell/s':>7} {'MB':>6} | "
            f"{'no-check s':>10} | {'gmsh s':>7} {'Mcell/s':>7} {'MB':>6} | "
            f"{'speed x':>7} {'memory x':>8}"
        )
        print(head)
        print("-" * len(head))
        for case in cases:
            ours = measure("ours", case, base_path)
            fast = measure("ours-nocheck", case, base_path)
            peer = measure("gmsh", case, base_path)
            rate_o = ours["cells"] / ours["seconds"] / 1e6
            rate_g = peer["cells"] / peer["seconds"] / 1e6
            print(
                f"{case:<16} {ours['cells']:>10,} | {ours['seconds']:>7.2f} {rate_o:>7.2f} "
                f"{ours['peak_mb']:>6.0f} | {fast['seconds']:>10.2f} | {peer['seconds']:>7.2f} "
                f"{rate_g:>7.2f} {peer['peak_mb']:>6.0f} | {rate_o / rate_g:>7.1f} "
                f"{peer['peak_mb'] / ours['peak_mb']:>8.1f}"
            )
            if peer["cells"] != ours["cells"]:
                print(f"  (gmsh made {peer['cells']:,} prisms on its {peer['base']:,} triangles)")


if __name__ == "__main__":
    main()
