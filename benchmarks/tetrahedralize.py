"""Side by side: ``tetrahedralize`` (ours), TetGen, Gmsh and fTetWild on the same closed surfaces.

Run from the repository root (issue 13's table: the three shapes at about
100k and 1M tetrahedra)::

    nice -n 19 .venv/bin/python benchmarks/tetrahedralize.py --sizes 100k 1M
    .venv/bin/python benchmarks/tetrahedralize.py --shapes torus --sizes 100k --repeat 3
    .venv/bin/python benchmarks/tetrahedralize.py --shapes slab --size 0.005 --tools ours tetgen

Shapes (``--shapes``; the default is the issue's three): ``cube_ball`` the
cube [-1, 1]^3 minus the ball of radius 0.5 (an icosphere, 320 triangles),
``torus`` (32 x 16 quads split, R 2, r 0.7), ``slab`` the thin plate
1 x 1 x 0.01 (aspect 100); also ``cube``, ``icosphere``, ``cavity`` (a box
with a box-shaped cavity), ``l_block``, ``schonhardt``. Every tool gets the
same points and triangles.

Sizes (``--sizes``): a target count of tetrahedra (``100k``, ``1M``, ``250k``
...). Our ``size`` for it comes from the count ours made per unit volume at
a known size (``DENSITY``, measured: tetrahedra x size^3 / volume, at 100k
and 1M), or is
given with ``--size``. Each peer is then **matched**: a pilot run at twice the
size (about an eighth of the tetrahedra) gives its own count per size^-3,
and the measured run uses the size that makes as many tetrahedra as our
default row did, or ``--match-count`` (up to three runs, see ``_matched``;
TetGen's ``-a`` is size^3 / 8.48, the volume of a regular tetrahedron of
that edge; Gmsh's ``Mesh.MeshSizeMax``; fTetWild's ``edge_length_abs``).
The pilot is not timed.

Rows (``--tools``): ``ours`` with the default ``max_radius_edge=2``, then
with ``min_dihedral`` 15 (and 20 at ``--dihedral20-below`` tetrahedra and
under; the output is then not Delaunay); ``tetgen`` with ``-pq2`` and
``-pq1.414`` (``add_hole`` for the cavity, ``steinerleft=-1``: the wrapper
otherwise stops silently at 100,000 added points); ``hxt`` Gmsh's HXT with
its optimization off and on (``Mesh.Optimize``), ``gmsh`` Gmsh's Delaunay
(``Mesh.Algorithm3D`` 1) -- Gmsh on one thread (``General.NumThreads=1``,
``Mesh.MaxNumThreads1D/2D/3D=1``), after ``classifySurfaces`` at 5 degrees
and ``createGeometry`` (every planar facet of these shapes becomes a
surface it remeshes at the size, as ours and TetGen refine the surface;
its time includes that surface meshing); ``ftetwild`` (``pytetwild``, one
thread; it remeshes the surface, its boundary is not the input's; only up
to ``--ftetwild-below`` tetrahedra, default 200k: about 1.5k tetrahedra/s).

Each row runs in a child process (its own peak memory, a CPU limit
``--cpu-limit``): CPU seconds of the meshing call alone (``time.process_time``,
after a warm-up that loads numba's cache for ours; on a shared machine wall
time mostly measures the other processes), tetrahedra, tetrahedra per CPU
second, points added, least dihedral angle (degrees), the share of
tetrahedra under 10 degrees, the largest radius-edge ratio, the peak
resident memory of the child (MB, ``ru_maxrss`` right after the call,
before the figures are computed; it includes the interpreter and the
imports, ``base`` in ``--json``), and the ratio of the row's time per
tetrahedron to TetGen ``-pq1.414``'s. ``--repeat N`` gives the median of N
runs of each row (alternating rows). ``--json FILE`` writes every run.
TetGen, Gmsh and pytetwild are bench-only dependencies, skipped with a note
when absent. ``--baseline DIR`` adds a row ``baseline + dihedral 15``: the
same run of the checkout at ``DIR`` (its own copy of this script, its
``meshcore``), for before/after figures measured in one run. ``--check``
checks every row of ours after its timed call (``_check``: positive
tetrahedra by the exact ``orient3d``, the volume to 1e-12, the boundary
tiling the input triangles, the cell sets; a failure is that row's error)
and adds a column of every row's volume error (relative, the sum of the
tetrahedra's volumes against the surface's).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from tests.meshcore.domain import shapes  # noqa: E402


def _cavity():
    P1, T1 = shapes.box((0, 0, 0), (3, 3, 3), 2)
    P2, T2 = shapes.box((1, 1, 1), (2, 2, 2))
    return np.concatenate([P1, P2]), np.concatenate([T1, T2 + len(P1)]), [[1.5, 1.5, 1.5]]


def _cube_ball():
    """The cube [-1, 1]^3 minus the ball of radius 0.5 (an icosphere, 320 triangles)."""
    P1, T1 = shapes.box((-1, -1, -1), (1, 1, 1), 2)
    P2, T2 = shapes.icosphere(2, radius=0.5)
    return np.concatenate([P1, P2]), np.concatenate([T1, T2 + len(P1)]), [[0.0, 0.0, 0.0]]


SHAPES = {
    "cube": lambda: (*shapes.box(), []),
    "cube_ball": _cube_ball,
    "icosphere": lambda: (*shapes.icosphere(3), []),
    "torus": lambda: (*shapes.torus(nu=32, nv=16), []),
    "cavity": _cavity,
    "l_block": lambda: (*shapes.l_block(), []),
    "slab": lambda: (*shapes.box((0, 0, 0), (1, 1, 0.01)), []),
    "schonhardt": lambda: (*shapes.schonhardt(), []),
}
#: Our tetrahedra x size^3 / enclosed volume at radius-edge 2, measured at about 100k and
#: 1M (log-interpolated between, the nearer one outside): the thin plate's count follows
#: no power of the size (its thickness is cut in more layers as the size drops below it:
#: 80k at size 0.0107, 120k at 0.0100), so it has a value per row.
DENSITY = {"cube_ball": (15.5496, 15.5496), "torus": (15.0, 15.0), "slab": (11.0, 14.5)}
TOOLS = ("ours", "tetgen", "hxt", "gmsh", "ftetwild")


def _volume(P, T) -> float:
    """The volume the surface encloses (a cavity's taken off: ``Surface.volume``)."""
    from meshcore.domain import parse_surface

    return parse_surface(P, T).volume


def _check(r, s) -> None:
    """What ``--check`` asserts on a row of ours (an AssertionError is the row's error):
    every tetrahedron positive by the exact ``orient3d``, their volumes summing to the
    surface's to 1e-12, no face in more than two tetrahedra, the faces held by one exactly
    the result's boundary faces, tiling the input triangles (their areas per facet to
    1e-12), and every tetrahedron in one region's cell set."""
    from meshcore.geometry.predicates3d import orient3d
    from meshcore.mesh.quality import signed_area, signed_volume
    from meshcore.mesh.topology import boundary, conformity

    P, K = r.mesh.points, r.mesh.cells[0].data
    assert (orient3d(*(P[K[:, i]] for i in range(4))) < 0).all(), "a tetrahedron not positive"
    volume = math.fsum(signed_volume(P, K).tolist())
    assert abs(volume / s.volume - 1) <= 1e-12, f"volume {volume!r}, enclosed {s.volume!r}"
    assert conformity(r.mesh)["nonmanifold"] == 0, "a face in more than two tetrahedra"
    once = np.unique(np.sort(boundary(r.mesh).cells[0].data, axis=1), axis=0)
    assert np.array_equal(once, np.unique(np.sort(r.boundary_faces, axis=1), axis=0))
    facet = r.triangle_facet
    made = signed_area(P, r.boundary_faces)
    made = np.bincount(facet[r.boundary_source], weights=made, minlength=facet.max() + 1)
    given = np.bincount(facet, weights=signed_area(s.points, s.triangles))
    assert np.allclose(made, given, rtol=1e-12, atol=0), "the boundary does not tile the input"
    ids = np.concatenate([cells[0] for cells in r.mesh.cell_sets.values()])
    assert np.array_equal(np.sort(ids), np.arange(len(K))), "cell sets"


def _figures(P, K) -> dict:
    from meshcore.tets import tetra_dihedral_angles, tetra_radius_edge

    d = tetra_dihedral_angles(P, K).min(axis=1)
    ratio = tetra_radius_edge(P, K)
    return {
        "dih_min": float(d.min()),
        "under10": 100.0 * float((d < 10).mean()),
        "re_max": float(np.nanmax(ratio)),
    }


def _maxrss() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# --- the tools (each run in a child process: see ``_child``) --------------------------------


def run_ours(P, T, holes, size, opts, check=False):
    from meshcore.domain import parse_surface
    from meshcore.tets import tetrahedralize

    kw = {"size": size, **opts}
    s = parse_surface(P, T)
    tetrahedralize(s, **{**kw, "size": 4 * size})  # warm-up: numba's cache, the same paths
    t = time.process_time()
    r = tetrahedralize(s, **kw)
    dt = time.process_time() - t
    note = f"given up {r.given_up}"
    if "improvement" in r.left:
        note += f", r/e traded {r.left['improvement'].get('radius_edge_traded', 0)}"
    phases = ", ".join(f"{k} {v:.1f}" for k, v in r.timings.items() if k != "total")
    added = r.surface_points_added + r.interior_points_added
    if check:
        _check(r, s)
        note += ", checked"
    return dt, r.mesh.points, r.mesh.cells[0].data, added, f"{note}; wall s: {phases}"


def run_tetgen(P, T, holes, size, opts):
    import tetgen

    g = tetgen.TetGen(P, T.astype(np.int32))
    for h in holes:
        g.add_hole(h)
    sw = opts["switches"] + f"a{size**3 / 8.48:.6g}Q"
    t = time.process_time()
    nodes, elem = g.tetrahedralize(switches=sw, steinerleft=-1)[:2]
    dt = time.process_time() - t
    added = len(nodes) - len(P)
    return dt, np.asarray(nodes), np.asarray(elem, dtype=np.int64), added, f"-{sw}"


def run_gmsh(P, T, holes, size, opts):
    """Gmsh on one thread: the triangles classified into planar surfaces, remeshed, then 3D."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        for name in ("General.NumThreads", "Mesh.MaxNumThreads1D", "Mesh.MaxNumThreads2D"):
            gmsh.option.setNumber(name, 1)
        gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)
        gmsh.model.add("s")
        tag = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, tag, list(range(1, len(P) + 1)), P.ravel().tolist())
        gmsh.model.mesh.addElementsByType(tag, 2, [], (T + 1).ravel().tolist())
        gmsh.model.mesh.classifySurfaces(5 * np.pi / 180, True, True, np.pi)
        gmsh.model.mesh.createGeometry()
        loop = gmsh.model.geo.addSurfaceLoop([e[1] for e in gmsh.model.getEntities(2)])
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        gmsh.option.setNumber("Mesh.Algorithm3D", opts["algorithm"])
        gmsh.option.setNumber("Mesh.Optimize", opts["optimize"])
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        t = time.process_time()
        gmsh.model.mesh.generate(2)
        t2 = time.process_time()
        gmsh.model.mesh.generate(3)
        dt = time.process_time() - t
        t3 = time.process_time() - t2
        tags, coords, _ = gmsh.model.mesh.getNodes()
        X = np.zeros((int(tags.max()) + 1, 3))
        X[tags.astype(np.int64)] = coords.reshape(-1, 3)
        _, elem = gmsh.model.mesh.getElementsByType(4)
        K = elem.astype(np.int64).reshape(-1, 4)
        keep = np.unique(K)
        remap = np.full(len(X), -1)
        remap[keep] = np.arange(len(keep))
        return dt, X[keep], remap[K], len(keep) - len(P), f"3D alone {t3:.2f} s"
    finally:
        gmsh.finalize()


def run_ftetwild(P, T, holes, size, opts):
    """fTetWild (``pytetwild``, one thread); its tetrahedra come negatively oriented."""
    import tempfile
    import types

    try:
        import pyvista  # noqa: F401
    except ImportError:  # pytetwild imports pyvista at import: a stub avoids VTK
        sys.modules["pyvista"] = types.ModuleType("pyvista")
    import pytetwild

    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # fTetWild writes __tracked_surface.stl into the working directory
        t = time.process_time()
        X, K = pytetwild.tetrahedralize(P, T.astype(np.int32), num_threads=1, edge_length_abs=size)
        dt = time.process_time() - t
        os.chdir(ROOT)
    K = np.asarray(K, dtype=np.int64)[:, [0, 1, 3, 2]]
    return dt, np.asarray(X, dtype=np.float64), K, len(X) - len(P), "surface remeshed"


RUNNERS = {"ours": run_ours, "tetgen": run_tetgen, "gmsh": run_gmsh, "ftetwild": run_ftetwild}


def _child(spec: dict) -> None:
    import resource

    if spec.get("cpu_limit"):
        lim = int(spec["cpu_limit"])
        resource.setrlimit(resource.RLIMIT_CPU, (lim, lim + 5))
    P, T, holes = SHAPES[spec["shape"]]()
    base = _maxrss()
    check = {"check": True} if spec.get("check") and spec["runner"] == "ours" else {}
    run = RUNNERS[spec["runner"]]
    dt, X, K, added, note = run(P, T, holes, spec["size"], spec["opts"], **check)
    out = {"cpu": dt, "tets": int(len(K)), "added": int(added), "mb": _maxrss(), "base": base}
    from meshcore.mesh.quality import signed_volume

    volume = _volume(P, T)
    out["volume_error"] = abs(float(np.abs(signed_volume(X, K)).sum()) - volume) / volume
    out.update(_figures(X, K))
    out["note"] = note
    print("RESULT " + json.dumps(out), flush=True)


def _run(spec: dict, wall_limit: float) -> dict:
    root = spec.get("root", ROOT)  # another checkout (``--baseline``): its copy of this script
    script = os.path.join(root, "benchmarks", os.path.basename(__file__))
    cmd = [sys.executable, script, "--child", json.dumps(spec)]
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=wall_limit, env=env)
    except subprocess.TimeoutExpired:
        return {"error": f"over {wall_limit:.0f} s wall"}
    for line in p.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    tail = (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1]
    return {"error": tail[:120]}


def _matched(spec: dict, n: int, wall_limit: float) -> tuple[float, dict]:
    """(size, run) of a peer at about ``n`` tetrahedra: an untimed pilot at twice the size,
    then the size the counts predict (count ~ size^-e, e from the last two runs, 3 at
    first or where the count did not move: a thin plate's count follows size^-2 while the
    size exceeds the thickness, TetGen's stays at its quality refinement's while ``-a`` is
    inactive), up to three runs until one is within 25 %; the last run is the measured one."""
    s_prev = 2 * spec["size"]
    n_prev = _run({**spec, "size": s_prev}, wall_limit).get("tets", 0)
    if not n_prev:
        return spec["size"], _run(spec, wall_limit)
    e = 3.0
    s = s_prev
    for _ in range(3):
        s_new = s * (n_prev / n) ** (1 / e)
        out = _run({**spec, "size": s_new}, wall_limit)
        got = out.get("tets", 0)
        if not got or abs(got / n - 1) <= 0.25:
            return s_new, out
        e = (
            3.0
            if got == n_prev
            else min(4.0, max(1.0, math.log(got / n_prev) / math.log(s / s_new)))
        )
        s, n_prev = s_new, got
    return s, out


def _density(name: str, n: float) -> float:
    """``DENSITY`` of shape ``name`` at ``n`` tetrahedra (13 for a shape not measured)."""
    lo, hi = DENSITY.get(name, (13.0, 13.0))
    w = min(1.0, max(0.0, math.log10(n) - 5.0))
    return lo ** (1 - w) * hi**w


def _target(text: str) -> int:
    t = text.lower()
    scale = {"k": 1_000, "m": 1_000_000}.get(t[-1], 1)
    return int(float(t[:-1] if scale > 1 else t) * scale)


def _rows(tools, n_target, args):
    """(label, runner, opts, matched) of each row."""
    rows = []
    if "ours" in tools:
        rows.append(("ours r/e 2", "ours", {}, False))
        rows.append(("ours r/e 2 + dihedral 15", "ours", {"min_dihedral": 15.0}, False))
        if args.baseline:
            rows.append(("baseline + dihedral 15", "ours", {"min_dihedral": 15.0}, False))
        if n_target <= args.dihedral20_below:
            rows.append(("ours r/e 2 + dihedral 20", "ours", {"min_dihedral": 20.0}, False))
    if "tetgen" in tools:
        rows.append(("TetGen -pq2", "tetgen", {"switches": "pq2"}, True))
        rows.append(("TetGen -pq1.414", "tetgen", {"switches": "pq1.414"}, True))
    if "hxt" in tools:
        rows.append(("Gmsh HXT, opt. off", "gmsh", {"algorithm": 10, "optimize": 0}, True))
        rows.append(("Gmsh HXT, opt. on", "gmsh", {"algorithm": 10, "optimize": 1}, True))
    if "gmsh" in tools:
        rows.append(("Gmsh Delaunay", "gmsh", {"algorithm": 1, "optimize": 1}, True))
    if "ftetwild" in tools and n_target <= args.ftetwild_below:
        rows.append(("fTetWild", "ftetwild", {}, True))
    return rows


def _available(tools):
    mods = {"tetgen": "tetgen", "hxt": "gmsh", "gmsh": "gmsh", "ftetwild": "pytetwild"}
    kept = []
    for t in tools:
        if t != "ours" and importlib.util.find_spec(mods[t]) is None:
            print(f"{mods[t]} not installed (pip install -e .[bench]): {t} rows skipped")
        else:
            kept.append(t)
    return kept


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=["cube_ball", "torus", "slab"])
    ap.add_argument("--sizes", nargs="+", default=["100k"], help="target tetrahedra: 100k 1M")
    ap.add_argument("--size", type=float, default=None, help="our size (instead of --sizes)")
    ap.add_argument("--tools", nargs="+", default=list(TOOLS), choices=TOOLS)
    ap.add_argument("--repeat", type=int, default=1, help="median of N runs per row")
    ap.add_argument("--cpu-limit", type=float, default=900, help="CPU s per run")
    ap.add_argument("--wall-limit", type=float, default=7200, help="wall s per run")
    ap.add_argument("--dihedral20-below", type=float, default=2e5)
    ap.add_argument("--ftetwild-below", type=float, default=2e5)
    ap.add_argument(
        "--match-count", type=int, default=None, help="match peers to this count (no ours row)"
    )
    ap.add_argument("--json", default=None, help="write every run to this file")
    ap.add_argument(
        "--baseline", default=None, help="also a row of this checkout's ours (before/after)"
    )
    ap.add_argument(
        "--check", action="store_true", help="check ours' rows (_check); the volume error"
    )
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        _child(json.loads(args.child))
        return
    tools = _available(args.tools)
    runs = []
    head = f"{'shape':<9} {'size':>5} {'tool':<25} {'cpu s':>8} {'tets':>9} {'tets/s':>8} "
    head += f"{'dih min':>7} {'%<10':>6} {'r/e max':>7} {'added':>8} {'MB':>6} {'x q1.414':>8}"
    if args.check:
        head += f" {'vol err':>8}"
    print(f"load at start: {open('/proc/loadavg').read().strip()}; CPU seconds", flush=True)
    print(head, flush=True)
    targets = [None] if args.size is not None else args.sizes
    for name in args.shapes:
        P, T, _ = SHAPES[name]()
        for label in targets:
            if label is None:
                size, n_target, label = args.size, 1e5, f"{args.size:g}"
            else:
                n_target = _target(label)
                size = (_density(name, n_target) * _volume(P, T) / n_target) ** (1 / 3)
            rows = _rows(tools, n_target, args)
            matched = {}
            results = {r[0]: [] for r in rows}
            n_ours = args.match_count
            for rep in range(args.repeat):
                for row, runner, opts, match in rows:
                    spec = {"shape": name, "runner": runner, "opts": opts, "size": size}
                    spec["cpu_limit"] = args.cpu_limit
                    spec["check"] = args.check
                    if row.startswith("baseline"):
                        spec["root"] = os.path.abspath(args.baseline)
                    if match and n_ours is not None and row not in matched:
                        matched[row], out = _matched(spec, n_ours, args.wall_limit)
                        spec["size"] = matched[row]
                    else:
                        if row in matched:
                            spec["size"] = matched[row]
                        out = _run(spec, args.wall_limit)
                    out.update(shape=name, target=label, tool=row, size=spec["size"], rep=rep)
                    out["load"] = open("/proc/loadavg").read().split()[0]
                    results[row].append(out)
                    runs.append(out)
                    if row == "ours r/e 2" and "tets" in out and n_ours is None:
                        n_ours = out["tets"]
            ref = None
            for row, *_ in rows:
                ok = [r for r in results[row] if "cpu" in r]
                if not ok:
                    err = results[row][0].get("error", "?")
                    print(f"{name:<9} {label:>5} {row:<25} failed: {err}", flush=True)
                    continue
                r = sorted(ok, key=lambda r: r["cpu"])[len(ok) // 2]
                per = r["cpu"] / r["tets"]
                if row == "TetGen -pq1.414":
                    ref = per
                r["per_tet"] = per
            for row, *_ in rows:
                ok = [r for r in results[row] if "cpu" in r]
                if not ok:
                    continue
                r = sorted(ok, key=lambda r: r["cpu"])[len(ok) // 2]
                x = f"{r['per_tet'] / ref:8.2f}" if ref else "       -"
                if args.check:
                    x += f" {r['volume_error']:8.1e}"
                print(
                    f"{name:<9} {label:>5} {row:<25} {r['cpu']:8.2f} {r['tets']:9,d} "
                    f"{r['tets'] / r['cpu']:8,.0f} {r['dih_min']:7.2f} {r['under10']:6.2f} "
                    f"{r['re_max']:7.2f} {r['added']:8,d} {r['mb']:6.0f} {x}   "
                    f"[size {r['size']:.4g}, load {r['load']}, {r['note']}]",
                    flush=True,
                )
    print(f"load at end: {open('/proc/loadavg').read().strip()}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(runs, fh, indent=1)


if __name__ == "__main__":
    main()
