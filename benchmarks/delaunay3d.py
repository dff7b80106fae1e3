"""Side by side: our 3D Delaunay kernel, TetGen, CGAL, Gmsh (Delaunay, HXT) and scipy's Qhull.

Run from the repository root::

    .venv/bin/python benchmarks/delaunay3d.py                  # the three inputs below
    .venv/bin/python benchmarks/delaunay3d.py --inputs random:100000 --timeout 60

Inputs: uniform random points in the unit cube (seed 0: Qhull's 6,749,025
tetrahedra at 1M), and points uniformly on the unit sphere (nearly
co-spherical: every insphere test is close to zero, the exact stage runs
often). Each run is a child process (its own peak resident memory, a time
limit); the time is that of the tetrahedralization call alone, after a
warm-up call that loads numba's cache (wall and CPU seconds: on a loaded
machine the CPU time is the steadier figure; ratios are of wall times). Qhull runs only where asked
(``random:100000:qhull`` by default): it takes minutes at 1M and does not
finish on the sphere. Where it ran, our tetrahedra are compared with its
own as sets (sorted rows). Peers: ``tetgen`` (its low-level
``PyTetgen.tetrahedralize(plc=0)``: the high-level wrapper refuses a bare
point set and its ``switches="Q"`` path segfaults) and ``gmsh``
(``gmsh.algorithm.tetrahedralize`` with ``Mesh.Algorithm3D`` 1, Delaunay,
and 10, HXT) and ``cgal`` (the CGAL SWIG bindings, ``pip install cgal``:
``Delaunay_triangulation_3`` on the exact-predicates kernel, one thread; the
list of ``Point_3`` is built before the timer and inserted by CGAL's range
``insert``, which sorts the points spatially (Hilbert/BRIO) before inserting
them; the bindings do not give vertex indices back cheaply, so CGAL is checked
by its number of finite cells against Qhull's, and its peak memory includes
that Python list, ``input MB`` below); a missing peer is reported as n/a. ``--baseline FILE`` adds a
copy of an earlier ``kernel3d.py`` as peer ``baseline`` (before/after in one
run), ``--rounds N`` repeats each input so that the rounds alternate and
ends with the medians of the rounds (ratios of ours' medians to each peer's,
wall and CPU).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")

_CHILD = r"""
import json, resource, sys, time
import numpy as np
sys.path.insert(0, sys.argv[3])
peer, path = sys.argv[1], sys.argv[2]
p = np.load(path)
out = None
extra = {}
if peer in ("ours", "baseline"):
    from meshcore.delaunay import delaunay3d
    if peer == "baseline":
        import importlib.util, os
        spec = importlib.util.spec_from_file_location("kernel3d_baseline", os.environ["BASELINE"])
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        delaunay3d = mod.delaunay3d
    delaunay3d(np.random.default_rng(1).random((100, 3)))
    t = time.perf_counter(); c = time.process_time()
    out = delaunay3d(p).tetra
    dt = time.perf_counter() - t; cpu = time.process_time() - c
elif peer == "tetgen":
    from tetgen import _tetgen
    g = _tetgen.PyTetgen()
    t = time.perf_counter(); c = time.process_time()
    g.load_mesh(p, np.empty((0, 3), np.int32))
    g.tetrahedralize(plc=0, quality=0, quiet=1)
    out = g.return_tets()
    dt = time.perf_counter() - t; cpu = time.process_time() - c
elif peer == "cgal":
    import resource
    from CGAL.CGAL_Kernel import Point_3
    from CGAL.CGAL_Triangulation_3 import Delaunay_triangulation_3
    pts = [Point_3(x, y, z) for x, y, z in p.tolist()]
    extra["input_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    dt3 = Delaunay_triangulation_3()
    t = time.perf_counter(); c = time.process_time()
    dt3.insert(pts)
    dt = time.perf_counter() - t; cpu = time.process_time() - c
    extra["cells"] = dt3.number_of_finite_cells()
elif peer.startswith("gmsh"):
    import gmsh
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.Algorithm3D", 10 if peer == "gmsh-hxt" else 1)
    flat = p.ravel()
    t = time.perf_counter(); c = time.process_time()
    tets, _ = gmsh.algorithm.tetrahedralize(flat)
    dt = time.perf_counter() - t; cpu = time.process_time() - c
    out = np.asarray(tets, np.int64).reshape(-1, 4) - 1
elif peer == "qhull":
    from scipy.spatial import Delaunay
    t = time.perf_counter(); c = time.process_time()
    out = Delaunay(p).simplices
    dt = time.perf_counter() - t; cpu = time.process_time() - c
if len(sys.argv) > 4 and out is not None:
    np.save(sys.argv[4], np.asarray(out))
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
tetra = extra.pop("cells") if out is None else int(len(out))
print(json.dumps({"seconds": dt, "cpu": cpu, "tetra": tetra, "peak_mb": rss, **extra}))
"""

PEERS = ["ours", "tetgen", "cgal", "gmsh-hxt", "gmsh-delaunay", "qhull"]


def random_cube(n: int) -> np.ndarray:
    return np.random.default_rng(0).random((n, 3))


def sphere(n: int) -> np.ndarray:
    x = np.random.default_rng(0).normal(size=(n, 3))
    return x / np.linalg.norm(x, axis=1)[:, None]


MAKERS = {"random": random_cube, "sphere": sphere}


def available(peer: str) -> bool:
    mod = {"tetgen": "tetgen", "cgal": "CGAL", "gmsh-hxt": "gmsh", "gmsh-delaunay": "gmsh"}.get(
        peer
    )
    if mod is None:
        return True
    try:
        __import__(mod)
    except ImportError:
        return False
    return True


def run(
    peer: str, path: str, timeout: float, save: str | None, baseline: str | None = None
) -> dict | str:
    cmd = [sys.executable, "-c", _CHILD, peer, path, ROOT]
    if save:
        cmd.append(save)
    env = dict(os.environ, BASELINE=baseline or "")
    try:
        out = subprocess.run(
            cmd, capture_output=True, text=True, timeout=timeout, check=False, env=env
        )
    except subprocess.TimeoutExpired:
        return f">{timeout:g} s"
    if out.returncode != 0:
        tail = (out.stderr.strip().splitlines() or [f"exit {out.returncode}"])[-1]
        return "error: " + tail[:40]
    return json.loads(out.stdout.strip().splitlines()[-1])


def canon(t: np.ndarray) -> np.ndarray:
    t = np.sort(t, axis=1)
    return t[np.lexsort(t.T[::-1])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--inputs",
        nargs="+",
        default=["random:100000:qhull", "random:1000000", "sphere:1000000"],
        help="name:n[:qhull] with name in " + ", ".join(MAKERS),
    )
    parser.add_argument("--peers", nargs="+", default=PEERS[:-1], choices=PEERS[:-1])
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument(
        "--baseline",
        help="a copy of an earlier kernel3d.py (e.g. `git show main:meshcore/delaunay/"
        "kernel3d.py > /tmp/base.py`), run as peer 'baseline' before ours in each round",
    )
    parser.add_argument("--rounds", type=int, default=1, help="repeat each input (load varies)")
    args = parser.parse_args()
    if args.baseline:
        args.peers = ["baseline"] + list(args.peers)

    header = (
        f"{'input':<8} {'n':>8} {'peer':<14} {'seconds':>8} {'cpu s':>7} {'tetra':>10} "
        f"{'peak MB':>8} "
        f"{'ours/peer':>9} {'= qhull':>8} {'load':>5}"
    )
    print(header)
    print("-" * len(header))
    runs: dict[tuple[str, int, str], list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for spec in [s for s in args.inputs for _ in range(args.rounds)]:
            name, n, *flags = spec.split(":")
            p = MAKERS[name](int(n))
            path = os.path.join(tmp, "points.npy")
            np.save(path, p)
            peers = list(args.peers) + (["qhull"] if "qhull" in flags else [])
            results: dict[str, dict | str] = {}
            saved: dict[str, str] = {}
            for peer in peers:
                if not available(peer):
                    results[peer] = "n/a"
                    continue
                save = os.path.join(tmp, f"{peer}.npy") if "qhull" in peers else None
                results[peer] = run(peer, path, args.timeout, save, args.baseline)
                if save and isinstance(results[peer], dict) and os.path.exists(save):
                    saved[peer] = save
            ref = canon(np.load(saved["qhull"])) if "qhull" in saved else None
            ours = results.get("ours")
            for peer in peers:
                r = results[peer]
                if isinstance(r, str):
                    print(f"{name:<8} {len(p):>8} {peer:<14} {r:>8}", flush=True)
                    continue
                ratio = (
                    f"{ours['seconds'] / r['seconds']:.2f}"
                    if isinstance(ours, dict) and peer != "ours"
                    else ""
                )
                same = ""
                if ref is not None and peer in saved:
                    same = "yes" if np.array_equal(canon(np.load(saved[peer])), ref) else "no"
                elif ref is not None and peer == "cgal":  # cells counted, not listed
                    same = "count" if r["tetra"] == len(ref) else "no"
                runs.setdefault((name, len(p), peer), []).append(r)
                load = open("/proc/loadavg").read().split()[0]
                print(
                    f"{name:<8} {len(p):>8} {peer:<14} {r['seconds']:>8.2f} {r['cpu']:>7.2f} "
                    f"{r['tetra']:>10} "
                    f"{r['peak_mb']:>8.0f} {ratio:>9} {same:>8} {load:>5}"
                    + (f"  input MB {r['input_mb']:.0f}" if "input_mb" in r else ""),
                    flush=True,
                )
    if args.rounds > 1:
        medians(runs)


def medians(runs: dict[tuple[str, int, str], list[dict]]) -> None:
    """Per input and peer: medians over the rounds, ratios of ours' medians to the peer's."""
    print("\nmedians of the rounds")
    print(
        f"{'input':<8} {'n':>8} {'peer':<14} {'seconds':>8} {'cpu s':>7} {'peak MB':>8} "
        f"{'ours/peer wall':>14} {'cpu':>5}"
    )
    fields = ("seconds", "cpu", "peak_mb")
    med = {k: {f: float(np.median([r[f] for r in v])) for f in fields} for k, v in runs.items()}
    for (name, n, peer), m in med.items():
        ours = med.get((name, n, "ours"))
        wall = cpu = ""
        if ours and peer != "ours":
            wall = f"{ours['seconds'] / m['seconds']:.2f}"
            cpu = f"{ours['cpu'] / m['cpu']:.2f}"
        print(
            f"{name:<8} {n:>8} {peer:<14} {m['seconds']:>8.2f} {m['cpu']:>7.2f} "
            f"{m['peak_mb']:>8.0f} {wall:>14} {cpu:>5}  ({len(runs[(name, n, peer)])} runs)"
        )


if __name__ == "__main__":
    main()
