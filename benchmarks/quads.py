"""Side by side: ``quad_combine`` (ours) and Gmsh's recombination, one triangle mesh.

Run from the repository root::

    .venv/bin/python benchmarks/quads.py                       # 10k, 100k, 1M triangles
    .venv/bin/python benchmarks/quads.py --sizes 10000 100000

Input: the unit square minus a disk of radius 0.25 (Gmsh: its OpenCASCADE
geometry; ours: the square minus a polygon sampling the circle at about the
mesh size, our domains being polygons), meshed into about N triangles by
Gmsh's default 2D algorithm (Frontal-Delaunay, ``MeshSizeMin = MeshSizeMax
= h``, ``h`` calibrated by ``GMSH_FILL``). On that *same* triangle mesh:

* Gmsh: ``Mesh.RecombineAll`` with ``Mesh.RecombinationAlgorithm`` 0
  (simple) and 1 (Blossom), recombination (with Gmsh's own topological
  optimization and smoothing) inside ``generate``; its time is that of
  ``generate`` minus that of meshing alone (the first run), Gmsh being
  deterministic. (``gmsh.model.mesh.recombine()`` after meshing ignores
  ``RecombinationAlgorithm``: Blossom then leaves triangles.)
* ours: ``combine(mesh, algorithm=...)`` for ``matching``, ``heap``,
  ``frontal`` and ``stack``, and ``matching`` with ``optimize`` (the call
  timed after a warm-up that loads numba's cache).

Rows marked * mesh the domain themselves (meshing included in the time):
Gmsh's ``Mesh.RecombineAll`` with algorithms 2 (simple full-quad) and 3
(Blossom full-quad), Gmsh's quad algorithm ``Mesh.Algorithm = 8``
(Frontal-Delaunay for quads) with ``RecombineAll``, ours from the domain
with ``all_quad`` and ``twice_size`` (about N / 2 final quads; ``heap`` and
``matching``, optimized), and ours from the domain without splitting
(pairs of about N right triangles of the sheared lattice, optimized). Gmsh
needs the OpenCASCADE geometry: its full-quad algorithms fail ("1D mesh
cannot be divided by 2") on the geo-kernel polygon.

Every row: wall time, CPU time (``process_time``; the ratio to the peer is
on CPU, wall times swinging 2-4x on a loaded machine; ``--repeat N``: the
run of median CPU among N), quads, triangles left, mean and min quad quality
(8.4) by :func:`meshcore.mesh.quality.quad_quality` (clockwise quads reversed
first: Gmsh orients by its surface normal), the fraction of quads under 0.5.
Every run is a child process. Gmsh is a bench-only dependency (``pip
install -e .[bench]``) and is skipped with a note when absent.

``--curved [SIZES]`` instead: the all-quad methods (``quad_combine`` with
``all_quad``, ``twice_size`` and ``optimize``; ``quad_medial``; ``paving``)
on a disk, an annulus, a 2:1 ellipse and an 8-tooth gear sampled about
``size`` apart and a spiky star polygon with a hole (14 vertices, 60 % radial
jitter: the same polygon at every size), each followed by Gmsh a8r3 (``Mesh.Algorithm`` 8,
``RecombinationAlgorithm`` 3 = Blossom full-quad, on the exact OpenCASCADE
curve) at the mesh size that gives about as many quads: least and mean
quality (8.4), corner range, wall and CPU seconds. ``--poisson``: scikit-fem's Q1
solution of a Poisson problem on the disk meshed by both methods at sizes
0.2 to 0.025, its L2 and H1 errors and their rates per halving (2 and 1
expected). ``quad_medial`` on the issue's random stars and on gears:
``benchmarks/medial.py --quad-medial SIZE...``. ``--bands [N...]``: ours from the
domain (``all_quad``, ``twice_size``, ``optimize``) at about N triangles, its quads
and irregular inner vertices by distance to the hole in sizes: where the mean's
shortfall from 0.95 sits. ``--misses [SIZES]``: ``quad_combine``'s all-quad meshes of
issue 20's 40 random stars that miss its targets, and where their quads under them sit.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

# one BLAS thread, as the service's job processes have (service.executors.child.JOB_THREADS)
# and Gmsh here (General.NumThreads 1): a multithreaded OpenBLAS spinning in L-BFGS-B's
# small calls made quad_medial 5-10x slower in CPU on a loaded machine. Children inherit it.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import numpy as np  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)


def rings(h: float):
    """The square and the circle sampled about every h (at least 32 points), as Gmsh does."""
    n = max(32, 4 * math.ceil(2 * math.pi * 0.25 / h / 4))
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    circ = 0.5 + 0.25 * np.column_stack([np.cos(th), np.sin(th)])
    return [np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), circ[::-1]]


def area() -> float:
    return 1.0 - math.pi / 16


#: Gmsh's Frontal-Delaunay lays about this many times the triangles of equilateral
#: triangles of side MeshSize (measured).
GMSH_FILL = 1.04


def size_for(n: int) -> float:
    """The Gmsh MeshSize giving about n triangles."""
    return math.sqrt(GMSH_FILL * 4 * area() / (math.sqrt(3) * n))


def geometry(h: float):
    return {"type": "Polygon", "coordinates": [r.tolist() for r in rings(h)]}


# ---------------------------------------------------------------------------
# Children
# ---------------------------------------------------------------------------


def _gmsh_model(h: float, algorithm: int | None = None):
    import gmsh

    gmsh.initialize(["-noenv"])
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    if algorithm is not None:
        gmsh.option.setNumber("Mesh.Algorithm", algorithm)
    # the OpenCASCADE kernel: the unit square minus the disk (Gmsh's full-quad algorithms
    # fail with "1D mesh cannot be divided by 2" on a polygonal geo-kernel boundary)
    occ = gmsh.model.occ
    occ.cut([(2, occ.addRectangle(0, 0, 0, 1, 1))], [(2, occ.addDisk(0.5, 0.5, 0, 0.25, 0.25))])
    occ.synchronize()
    return gmsh


def gmsh_cells(gmsh):
    tags, coords, _ = gmsh.model.mesh.getNodes()
    P = coords.reshape(-1, 3)[:, :2].copy()
    index = np.empty(int(tags.max()) + 1, np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    out = {}
    for etype, k, name in ((2, 3, "triangle"), (3, 4, "quad")):
        try:
            _, nodes = gmsh.model.mesh.getElementsByType(etype)
        except Exception:  # noqa: BLE001 (no element of this type)
            nodes = np.zeros(0)
        out[name] = index[np.asarray(nodes, np.int64).reshape(-1, k)]
    return P, out


def ccw(P, cells):
    from meshcore.mesh.quality import signed_area

    if not len(cells):
        return cells
    cw = signed_area(P, cells, "quad" if cells.shape[1] == 4 else "triangle") < 0
    cells = cells.copy()
    cells[cw] = cells[cw, ::-1]
    return cells


def _describe(P, quads, tris, seconds) -> dict:
    from meshcore.mesh.quality import quad_quality

    quads = ccw(P, np.asarray(quads, np.int64))
    q = quad_quality(P, quads) if len(quads) else np.zeros(1)
    return {
        "seconds": seconds,
        "quads": int(len(quads)),
        "triangles": int(len(tris)),
        "mean": float(q.mean()),
        "min": float(q.min()),
        "under05": float(np.mean(q < 0.5)),
    }


def child(tool: str, n: int, path: str) -> dict:
    h = size_for(n)
    if tool == "gmsh-mesh":
        gmsh = _gmsh_model(h)
        t, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        T = ccw(P, cells["triangle"])
        np.savez(path, P=P, T=T)
        return {
            "seconds": seconds,
            "cpu": cpu,
            "quads": 0,
            "triangles": int(len(T)),
            "mean": 0,
            "min": 0,
            "under05": 0,
        }
    if tool.startswith("gmsh-recombine"):
        # gmsh.model.mesh.recombine() ignores RecombinationAlgorithm (Blossom then leaves
        # triangles like the simple algorithm): recombine inside generate, and report the
        # time of generate minus that of meshing alone (the "gmsh-mesh" run)
        k = int(tool[-1])
        gmsh = _gmsh_model(h)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", k)
        t, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        out = _describe(P, cells["quad"], cells["triangle"], seconds)
        out["total"], out["cpu"] = seconds, cpu
        return out
    if tool.startswith("gmsh-all"):
        k = int(tool[-1])
        algo = 8 if k == 8 else None
        gmsh = _gmsh_model(h, algo)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        if k != 8:
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", k)
        t, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        return dict(_describe(P, cells["quad"], cells["triangle"], seconds), cpu=cpu)
    from meshcore.mesh import CellBlock, Mesh
    from meshcore.quads.combination import combine
    from meshcore.triangulation.refinement import triangulate

    warm = np.load(path)
    # warm-up: every kernel (numba loads them from its cache on their first call), on the
    # domain path and on the mesh path (a 20 x 20 grid of right triangles: a timed first
    # call on a mesh took 1.19 s for 0.39 s warm at 10k; and a refined Delaunay mesh, whose
    # matching leaves quads with two opposite valence-3 vertices: neither the grid nor the
    # lattice reaches the collapse operator, whose kernel was loaded inside the timed call,
    # 17 ms for 11 ms warm at 1k)
    g = np.stack(np.meshgrid(np.arange(21.0), np.arange(21.0), indexing="ij"), -1) / 20
    ids = np.arange(441).reshape(21, 21)
    a, b = ids[:-1, :-1].ravel(), ids[1:, :-1].ravel()
    c, d = ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()
    tri = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    grid = Mesh(g.reshape(-1, 2), (CellBlock("triangle", tri),))
    delaunay = triangulate(geometry(0.1), size=0.1, min_angle=30.0).mesh
    for alg in ("matching", "heap", "frontal", "stack"):
        combine(domain=geometry(0.1), size=0.1, algorithm=alg, optimize=True)
        combine(grid, algorithm=alg, optimize=True)
        combine(grid, algorithm=alg)
        combine(delaunay, algorithm=alg, optimize=True)
    combine(domain=geometry(0.1), size=0.1, all_quad=True, twice_size=True, optimize=True)
    # n triangles of the sheared lattice: right triangles of side s, of area s**2 / 2
    s = math.sqrt(2 * area() / n)
    if tool.startswith(("ours-domain", "ours-pairs")):
        alg = tool.split("-")[2]
        if tool.startswith("ours-domain"):  # n / 2 final quads of side s, from 2s triangles
            kw = {"size": s, "all_quad": True, "twice_size": True}
        else:  # pairs of n triangles
            kw = {"size": s}
        t, c = time.perf_counter(), time.process_time()
        res = combine(domain=geometry(s), algorithm=alg, optimize=True, **kw)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
    else:
        alg = tool.split("-")[1]
        opt = tool.endswith("-opt")
        mesh = Mesh(warm["P"], (CellBlock("triangle", warm["T"]),))
        t, c = time.perf_counter(), time.process_time()
        res = combine(mesh, algorithm=alg, optimize=opt)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
    blocks = res.mesh.cells_by_type
    out = _describe(
        res.mesh.points,
        blocks.get("quad", np.zeros((0, 4))),
        blocks.get("triangle", np.zeros((0, 3))),
        seconds,
    )
    out["phases"] = res.stats["seconds"]
    out["cpu"] = cpu
    return out


def run_child(tool: str, n: int, path: str, timeout: float) -> dict | str:
    try:
        out = subprocess.run(
            [sys.executable, __file__, "--child", tool, str(n), path],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
        )
    except subprocess.TimeoutExpired:
        return f"timeout {timeout:.0f} s"
    if out.returncode != 0:
        return out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"
    return json.loads(out.stdout.strip().splitlines()[-1])


def available(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


# ---------------------------------------------------------------------------
# Table
# ---------------------------------------------------------------------------

LABELS = {
    "gmsh-recombine0": "Gmsh simple (algo 0)",
    "gmsh-recombine1": "Gmsh Blossom (algo 1)",
    "ours-matching": "ours matching",
    "ours-heap": "ours heap",
    "ours-frontal": "ours frontal",
    "ours-stack": "ours stack",
    "ours-matching-opt": "ours matching + optimize",
    "gmsh-all2": "Gmsh simple full-quad (algo 2)*",
    "gmsh-all3": "Gmsh Blossom full-quad (algo 3)*",
    "gmsh-all8": "Gmsh quad algorithm 8 + Blossom*",
    "ours-domain-heap": "ours domain all_quad heap + opt*",
    "ours-domain-matching": "ours domain all_quad matching + opt*",
    "ours-pairs-matching": "ours domain (pairs) matching + opt*",
    "ours-pairs-heap": "ours domain (pairs) heap + opt*",
}


def fmt_row(label, r, ref, ref_name):
    if isinstance(r, str):
        return f"| {label} | {r} | | | | | | | |"
    ratio = ""
    if isinstance(ref, dict) and ref is not r:
        ratio = f"{r['cpu'] / ref['cpu']:.2f} ({ref_name})"
    return (
        f"| {label} | {r['seconds']:.3f} | {r['cpu']:.3f} | {r['quads']:,} | {r['triangles']:,} | "
        f"{r['mean']:.3f} | {r['min']:.3f} | {100 * r['under05']:.2f} % | {ratio} |"
    )


def median_run(tool: str, n: int, path: str, timeout: float, repeat: int, base=None):
    """The run of median CPU time among ``repeat`` (Gmsh's recombination: minus the
    meshing alone, ``base``)."""
    runs = []
    for _ in range(repeat):
        r = run_child(tool, n, path, timeout)
        if not isinstance(r, dict):
            return r
        if base is not None:
            r["seconds"] = max(r["total"] - base["seconds"], 1e-6)
            r["cpu"] = max(r["cpu"] - base["cpu"], 1e-6)
        runs.append(r)
    return sorted(runs, key=lambda r: r["cpu"])[len(runs) // 2]


# ---------------------------------------------------------------------------
# Curved domains: the all-quad methods against Gmsh a8r3 (issue 20)
# ---------------------------------------------------------------------------

CURVED = {
    "disk": lambda t: np.column_stack([np.cos(t), np.sin(t)]),
    "ellipse": lambda t: np.column_stack([2 * np.cos(t), np.sin(t)]),
    "gear": lambda t: (
        (1 + 0.12 * np.tanh(4 * np.sin(8 * t)))[:, None] * np.column_stack([np.cos(t), np.sin(t)])
    ),
}


def _curve_points(name: str, size: float) -> np.ndarray:
    """The closed curve sampled about ``size`` apart (counter-clockwise)."""
    f = CURVED["disk" if name == "annulus" else name]
    t = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    xy = f(t)
    s = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T))])
    n = max(8, int(round(s[-1] / size)))
    return f(np.interp(np.arange(n) * s[-1] / n, s[:-1], t))


def _star() -> list[np.ndarray]:
    """A fixed spiky star (14 vertices, 60 % radial jitter) with a star-shaped hole, as
    the tests draw them: its rings, counter-clockwise outer ring, clockwise hole."""
    rng = np.random.default_rng(20)
    n = 14
    t = 2 * np.pi * (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / n
    r = 1 + 0.6 * rng.uniform(-1, 1, n)
    th = 2 * np.pi * np.arange(7) / 7
    rh = 0.06 * (1 + 0.5 * rng.uniform(-1, 1, 7))
    outer = np.column_stack([r * np.cos(t), r * np.sin(t)])
    hole = np.column_stack([rh * np.cos(th), rh * np.sin(th)])[::-1]
    return [outer, hole]


def curved_geometry(name: str, size: float) -> dict:
    if name == "star":  # a polygon: the same at every size
        return {"type": "Polygon", "coordinates": [np.vstack([r, r[:1]]).tolist() for r in _star()]}
    outer = _curve_points(name, size)
    rings = [np.vstack([outer, outer[:1]])]
    if name == "annulus":
        hole = 0.45 * _curve_points("disk", size / 0.45)[::-1]
        rings.append(np.vstack([hole, hole[:1]]))
    return {"type": "Polygon", "coordinates": [r.tolist() for r in rings]}


def _corner_range(P, quads) -> tuple[float, float]:
    p = P[ccw(P, np.asarray(quads, np.int64))]
    a, b = np.roll(p, 1, axis=1) - p, np.roll(p, -1, axis=1) - p
    cos = (a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
    ang = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    return float(ang.min()), float(ang.max())


def curved_child(tool: str, name: str, size: float) -> dict:
    """One all-quad run on a curved domain: ours from the sampled polygon, Gmsh a8r3
    from the exact curve (OpenCASCADE), both timed after a warm-up."""
    if tool == "gmsh-a8r3":
        import gmsh

        def run():
            gmsh.initialize(["-noenv"])
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setNumber("General.NumThreads", 1)
            gmsh.option.setNumber("Mesh.MeshSizeMin", size)
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
            gmsh.option.setNumber("Mesh.Algorithm", 8)
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
            occ = gmsh.model.occ
            if name == "gear":
                pts = [occ.addPoint(x, y, 0) for x, y in _curve_points("gear", 0.02)]
                curve = occ.addBSpline(pts + pts[:1])
                occ.addPlaneSurface([occ.addCurveLoop([curve])])
            elif name == "star":
                loops = []
                for ring in _star():
                    pts = [occ.addPoint(x, y, 0) for x, y in ring]
                    lines = [occ.addLine(a, b) for a, b in zip(pts, pts[1:] + pts[:1], strict=True)]
                    loops.append(occ.addCurveLoop(lines))
                occ.addPlaneSurface(loops)
            elif name == "ellipse":
                occ.addDisk(0, 0, 0, 2, 1)
            elif name == "annulus":
                occ.cut([(2, occ.addDisk(0, 0, 0, 1, 1))], [(2, occ.addDisk(0, 0, 0, 0.45, 0.45))])
            else:
                occ.addDisk(0, 0, 0, 1, 1)
            occ.synchronize()
            t0, c0 = time.perf_counter(), time.process_time()
            gmsh.model.mesh.generate(2)
            sec, cpu = time.perf_counter() - t0, time.process_time() - c0
            P, cells = gmsh_cells(gmsh)
            gmsh.finalize()
            return P, cells["quad"], cells["triangle"], sec, cpu

        P, quads, tris, sec, cpu = run()
    else:
        from meshcore.domain.planar import parse_domain
        from meshcore.medial import quad_medial
        from meshcore.quads import combine, paving

        dom = parse_domain(curved_geometry(name, size))
        calls = {
            "quad_combine": lambda: combine(
                domain=dom, size=size, all_quad=True, twice_size=True, optimize=True
            ),
            "quad_medial": lambda: quad_medial(dom, size=size),
            "paving": lambda: paving(dom, size=size),
        }
        calls[tool]()  # warm-up (numba's cache)
        t0, c0 = time.perf_counter(), time.process_time()
        res = calls[tool]()
        sec, cpu = time.perf_counter() - t0, time.process_time() - c0
        P = res.mesh.points
        quads = res.mesh.cells_by_type.get("quad", np.zeros((0, 4), np.int64))
        tris = res.mesh.cells_by_type.get("triangle", np.zeros((0, 3), np.int64))
    out = _describe(P, quads, tris, sec)
    out["corners"] = _corner_range(P, quads)
    out["cpu"] = cpu
    return out


def _load() -> str:
    """The load line printed before a table (not inside it)."""
    return "load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def curved_main(sizes, timeout: float, tools=None, domains=None) -> None:
    """Tables of the curved domains (``--curved``): each of ours (``tools``, default
    all three), then Gmsh a8r3 at the size that gives about as many quads (one
    calibration run)."""
    print(f"{_load()}\n")
    print("| domain | size | run | quads | least Q | mean Q | corners | seconds | CPU s |")
    print("|---|---:|---|---:|---:|---:|---|---:|---:|")
    for name in domains or ("disk", "annulus", "ellipse", "gear", "star"):
        for size in sizes:
            for tool in tools or ("quad_combine", "quad_medial", "paving"):
                r = _curved_run(tool, name, size, timeout)
                _curved_row(name, size, tool, r)
                if not isinstance(r, dict):
                    continue
                g = _curved_run("gmsh-a8r3", name, size, timeout)
                if isinstance(g, dict) and g["quads"]:
                    h = size * math.sqrt(g["quads"] / r["quads"])
                    g = _curved_run("gmsh-a8r3", name, h, timeout)
                _curved_row(name, size, "  Gmsh a8r3 (matched)", g)


def _curved_run(tool, name, size, timeout):
    cmd = [sys.executable, __file__, "--curved-child", tool, name, repr(size)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return f"timed out at {timeout:.0f} s"
    if out.returncode:
        return "failed: " + (out.stderr.strip().splitlines() or ["?"])[-1][:80]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _curved_row(name, size, label, r):
    if not isinstance(r, dict):
        print(f"| {name} | {size} | {label} | {r} | | | | | |", flush=True)
        return
    lo, hi = r["corners"]
    print(
        f"| {name} | {size} | {label} | {r['quads']:,} | {r['min']:.3f} | {r['mean']:.3f} | "
        f"{lo:.1f}-{hi:.1f} | {r['seconds']:.2f} | {r.get('cpu', float('nan')):.3f} |",
        flush=True,
    )


def poisson_child(tool: str, size: float) -> dict:
    """L2 and H1 errors of scikit-fem's Q1 solution of -lap u = f on the disk
    (u = sin(pi x) sin(pi y) + x y, Dirichlet data from u at the boundary nodes)."""
    from skfem import (
        Basis,
        BilinearForm,
        ElementQuad1,
        Functional,
        LinearForm,
        MeshQuad,
        condense,
        solve,
    )
    from skfem.helpers import dot, grad

    from meshcore.domain.planar import parse_domain
    from meshcore.medial import quad_medial
    from meshcore.quads import combine

    dom = parse_domain(curved_geometry("disk", size))
    if tool == "quad_medial":
        mesh = quad_medial(dom, size=size).mesh
    else:
        mesh = combine(domain=dom, size=size, all_quad=True, twice_size=True, optimize=True).mesh
    P, Q = mesh.points, ccw(mesh.points, mesh.cells_by_type["quad"])
    m = MeshQuad(P.T.copy(), Q.T.copy())
    basis = Basis(m, ElementQuad1(), intorder=4)
    pi = np.pi

    def exact(x, y):
        return np.sin(pi * x) * np.sin(pi * y) + x * y

    @BilinearForm
    def lap(u, v, w):
        return dot(grad(u), grad(v))

    @LinearForm
    def load(v, w):
        x, y = w.x
        return 2 * pi**2 * np.sin(pi * x) * np.sin(pi * y) * v

    A, b = lap.assemble(basis), load.assemble(basis)
    D = basis.get_dofs().all()
    u = basis.zeros()
    u[D] = exact(*m.p[:, D])
    u = solve(*condense(A, b, x=u, D=D))
    uh = basis.interpolate(u)

    @Functional
    def l2(w):
        x, y = w.x
        return (w["uh"] - exact(x, y)) ** 2

    @Functional
    def h1(w):
        x, y = w.x
        gx = pi * np.cos(pi * x) * np.sin(pi * y) + y
        gy = pi * np.sin(pi * x) * np.cos(pi * y) + x
        return (w["uh"].grad[0] - gx) ** 2 + (w["uh"].grad[1] - gy) ** 2

    return {
        "quads": int(len(Q)),
        "l2": float(np.sqrt(l2.assemble(basis, uh=uh))),
        "h1": float(np.sqrt(h1.assemble(basis, uh=uh))),
    }


def poisson_main(timeout: float) -> None:
    """The convergence table (``--poisson``): sizes halved four times on the disk."""
    print("| method | size | quads | L2 error | rate | H1 error | rate |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for tool in ("quad_combine", "quad_medial"):
        last = None
        for size in (0.2, 0.1, 0.05, 0.025):
            cmd = [sys.executable, __file__, "--poisson-child", tool, repr(size)]
            try:
                out = subprocess.run(
                    cmd, capture_output=True, text=True, timeout=timeout, check=False
                )
            except subprocess.TimeoutExpired:
                print(f"| {tool} | {size} | timed out at {timeout:.0f} s | | | | |", flush=True)
                continue
            if out.returncode:
                print(f"| {tool} | {size} | failed: {out.stderr.strip()[-80:]} | | | | |")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            r2 = f"{math.log2(last['l2'] / r['l2']):.2f}" if last else ""
            r1 = f"{math.log2(last['h1'] / r['h1']):.2f}" if last else ""
            row = f"| {tool} | {size} | {r['quads']:,} | {r['l2']:.3e} | {r2} "
            row += f"| {r['h1']:.3e} | {r1} |"
            print(row, flush=True)
            last = r


#: ``--bands``: the bands of distance to the hole, in sizes.
BANDS = (0, 1, 2, 3, 4, 6, math.inf)


def bands_main(sizes) -> None:
    """``--bands``: ours from the domain at about each N triangles (as the
    ``ours-domain-matching`` row), its quads (centroids) and its inner vertices of
    valence other than 4 by distance to the hole, in sizes; then the quads with a
    corner at such a vertex and the others. The corners at an inner vertex of
    valence 3 sum to 360 degrees, so its three quads' qualities (8.4) sum to at most
    2 (at least 0.85 short of 0.95 together); at valence 5 at least 0.75, at 6 1.7."""
    from meshcore.mesh import quality
    from meshcore.quads.combination import combine

    print(f"{_load()}\n")
    print(
        "| N | distance / size | quads | mean Q | min Q | shortfall from 0.95 | "
        "inner valence 3 / 5 / 6 |"
    )
    print("|---|---|---:|---:|---:|---:|---|")
    for n in sizes:
        s = math.sqrt(2 * area() / n)
        res = combine(domain=geometry(s), size=s, all_quad=True, twice_size=True, optimize=True)
        P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
        q = quality.quad_quality(P, Q)
        dq = (np.hypot(*(P[Q].mean(axis=1) - 0.5).T) - 0.25) / s
        val = np.bincount(Q.ravel(), minlength=len(P))
        dv = (np.hypot(*(P - 0.5).T) - 0.25) / s
        inner = (dv > 1e-6) & (P.min(axis=1) > 1e-9) & (P.max(axis=1) < 1 - 1e-9)
        irregular = inner & (val != 4)
        near = irregular[Q].any(axis=1)
        rows = [("all", np.ones(len(Q), bool), irregular)]
        rows += [
            (f"[{lo}, {hi})", (dq >= lo) & (dq < hi), irregular & (dv >= lo) & (dv < hi))
            for lo, hi in zip(BANDS[:-1], BANDS[1:], strict=True)
        ]
        rows += [("at an irregular inner vertex", near, irregular), ("the others", ~near, None)]
        for label, m, at in rows:
            c = np.bincount(val[at], minlength=7) if at is not None else None
            print(
                f"| {n:,} | {label} | {m.sum():,} | {q[m].mean():.3f} | {q[m].min():.3f} | "
                f"{(0.95 - q[m]).sum():.1f} | {'' if c is None else f'{c[3]} / {c[5]} / {c[6]}'} |",
                flush=True,
            )


def misses_main(sizes) -> None:
    """``--misses``: ``quad_combine`` (``all_quad``, ``twice_size``, ``optimize``) on
    issue 20's 40 random stars (:func:`tests.meshcore.quads.stars.issue_star`) at each
    size; each run that misses the targets
    (:func:`~meshcore.quads.boundary_layer.meets_targets`) with its count ratio, least
    quality and corners away from the sharp input corners, mean, and its quads under
    the targets by where their worst corner is (first that applies): within 4 sizes
    of an input corner under 30 degrees (a spike's tip), within 2 sizes of one over
    200 (a reflex corner), at an input corner of 45-135 degrees held by two quads or
    more, at a boundary point held by three or more, else at an inner vertex of
    its valence."""
    from collections import Counter

    from meshcore.domain.planar import parse_domain
    from meshcore.mesh import quality
    from meshcore.partition.smoothing import boundary_points
    from meshcore.quads import combine
    from meshcore.quads.boundary_layer import meets_targets, off_sharp
    from tests.meshcore.quads.stars import issue_star

    print(f"{_load()}\n")
    print("| star | size | quads / (area / size²) | least Q | corners | mean Q | under targets |")
    print("|---|---|---:|---:|---|---:|---|")
    for size in sizes:
        met = 0
        for k in range(40):
            dom = parse_domain(issue_star(k)[0])
            res = combine(domain=dom, size=size, all_quad=True, twice_size=True, optimize=True)
            ok = off_sharp(res.mesh, dom)
            if meets_targets(res.mesh, dom, size, ok):
                met += 1
                continue
            P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
            q, ang = quality.quad_quality(P, Q), quality.quad_angles(P, Q)
            off = (q < 0.5) | (ang.min(axis=1) < 30) | (ang.max(axis=1) > 150)
            bad = np.flatnonzero(ok & off)
            val = np.bincount(Q.ravel(), minlength=len(P))
            on_boundary = boundary_points(P, Q)
            corner = dom.corner_angles()
            where = Counter()
            for i in bad:  # a loop over the few quads under the targets
                v = Q[i, np.argmax(np.abs(ang[i] - 90))]
                d = np.hypot(*(dom.points - P[Q[i]].mean(axis=0)).T) / size
                at = np.flatnonzero((dom.points == P[v]).all(axis=1))
                if ((corner < 30) & (d < 4)).any():
                    where["spike tip"] += 1
                elif ((corner > 200) & (d < 2)).any():
                    where["reflex corner"] += 1
                elif len(at) and 45 <= corner[at[0]] <= 135 and val[v] >= 2:
                    where[f"convex corner in {val[v]} quads"] += 1
                elif on_boundary[v] and val[v] >= 3:
                    where[f"boundary point in {val[v]} quads"] += 1
                else:
                    where[f"inner vertex of valence {val[v]}"] += 1
            a = ang[ok]
            print(
                f"| {k} | {size} | {len(Q) * size * size / dom.area:.2f} | {q[ok].min():.3f} | "
                f"{a.min():.1f}-{a.max():.1f} | {q.mean():.3f} | "
                + ", ".join(f"{n} {w}" for w, n in where.most_common())
                + " |",
                flush=True,
            )
        print(f"| met | {size} | {met} of 40 | | | | |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--timeout", type=float, default=900)
    ap.add_argument("--repeat", type=int, default=1, help="runs per row (the median CPU shown)")
    ap.add_argument("--tools", nargs="*", default=None, help="only these runs (names as in LABELS)")
    ap.add_argument("--child", nargs=3, metavar=("TOOL", "N", "PATH"))
    ap.add_argument(
        "--curved",
        type=float,
        nargs="*",
        default=None,
        help="sizes: the all-quad methods on a disk, annulus, ellipse and gear against Gmsh a8r3",
    )
    ap.add_argument("--domains", nargs="*", default=None, help="--curved: only these domains")
    ap.add_argument("--curved-child", nargs=3, metavar=("TOOL", "DOMAIN", "SIZE"))
    ap.add_argument("--poisson", action="store_true", help="Q1 Poisson convergence on the disk")
    ap.add_argument(
        "--bands",
        type=int,
        nargs="*",
        default=None,
        help="sizes (triangles): ours from the domain, quality by distance to the hole",
    )
    ap.add_argument(
        "--misses",
        type=float,
        nargs="*",
        default=None,
        help="sizes: quad_combine's misses of issue 20's targets on its 40 stars, and where",
    )
    ap.add_argument("--poisson-child", nargs=2, metavar=("TOOL", "SIZE"))
    args = ap.parse_args()
    if args.poisson_child:
        print(json.dumps(poisson_child(args.poisson_child[0], float(args.poisson_child[1]))))
        return
    if args.poisson:
        poisson_main(args.timeout)
        return
    if args.misses is not None:
        misses_main(args.misses or [0.1, 0.05])
        return
    if args.bands is not None:
        bands_main(args.bands or [1_000, 3_000, 10_000])
        return
    if args.curved_child:
        tool, name, size = args.curved_child
        print(json.dumps(curved_child(tool, name, float(size))))
        return
    if args.curved is not None:
        curved_main(args.curved or [0.1, 0.05, 0.025], args.timeout, args.tools, args.domains)
        return
    if args.child:
        tool, n, path = args.child
        print(json.dumps(child(tool, int(n), path)))
        return
    if not available("gmsh"):
        print(
            "note: Gmsh not installed (pip install -e .[bench]): no triangle mesh to share; "
            "ours runs on its own domain input only"
        )
    print(f"{_load()}, medians of {args.repeat}\n")
    print(
        "| run | seconds | CPU s | quads | triangles left | mean Q (8.4) | min Q | Q < 0.5 | "
        "CPU ratio to peer |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            path = os.path.join(tmp, f"mesh{n}.npz")
            results = {}
            if available("gmsh"):
                base = median_run("gmsh-mesh", n, path, args.timeout, args.repeat)
                tri = base["triangles"] if isinstance(base, dict) else base
                print(
                    f"| **~{n:,} triangles** (Gmsh mesh: {tri:,} triangles, "
                    f"{base['seconds'] if isinstance(base, dict) else 0:.2f} s) | | | | | | | | |",
                    flush=True,
                )
                tools = [
                    "gmsh-recombine0",
                    "gmsh-recombine1",
                    "ours-matching",
                    "ours-heap",
                    "ours-frontal",
                    "ours-stack",
                    "ours-matching-opt",
                    "gmsh-all2",
                    "gmsh-all3",
                    "gmsh-all8",
                    "ours-domain-heap",
                    "ours-domain-matching",
                    "ours-pairs-matching",
                    "ours-pairs-heap",
                ]
            else:
                np.savez(path, P=np.zeros((0, 2)), T=np.zeros((0, 3), np.int64))
                tools = ["ours-domain-heap", "ours-domain-matching", "ours-pairs-matching"]
            for tool in tools:
                if tool == "ours-stack" and n > 200_000:
                    continue
                if args.tools is not None and tool not in args.tools:
                    continue
                sub = base if tool.startswith("gmsh-recombine") else None
                results[tool] = median_run(tool, n, path, args.timeout, args.repeat, sub)
                if tool.startswith("ours-domain") or tool.startswith("ours-pairs"):
                    ref, ref_name = results.get("gmsh-all8"), "Gmsh algo 8"
                elif tool.startswith("ours"):
                    ref, ref_name = results.get("gmsh-recombine1"), "Gmsh Blossom"
                else:
                    ref, ref_name = None, ""
                print(fmt_row(LABELS[tool], results[tool], ref, ref_name), flush=True)
    print("* meshing included in the time (the domain is meshed by the run itself).")
    print("CPU ratio: ours / peer CPU time, process_time (below 1: ours faster).")


if __name__ == "__main__":
    main()
