"""Side by side: ``optimize`` (ours, Coupez §8.3) and the untanglers issue 15 names, same tangles.

Run from the repository root::

    .venv/bin/python benchmarks/optimize.py --only correction --sizes 100 224
    .venv/bin/python benchmarks/optimize.py --gmsh-timeout 60 --ff-limit 60

Input (correction): the unit square cut into ``nx x nx`` squares, each split
into two triangles (2 nx^2 triangles: 20k at nx = 100, 100k at 224); the
boundary fixed, interior nodes moved by U(-a h, a h) (``a`` = 0.5 and 0.9)
or put at uniformly random positions in the square. The mesh and the tangle
are Gmsh's own (a transfinite square, nodes moved by ``setNode``) when Gmsh
is installed, so that all work on the same input. Then the same on a
``triangulate`` mesh of a 7-pointed star with a square hole (not convex),
about as many triangles. Ours: :func:`meshcore.optimize.optimize` on the
tangled mesh (the point set kept), after a warm-up that loads numba's cache.
Peers, in the same run: Gmsh's ``UntangleMeshGeometry`` (a Winslow
untangler; the grid only) in a child process with a CPU-time limit
(``--gmsh-timeout``), and a plain numpy implementation of "Foldover-free maps
in 50 lines of code" (Garanzha et al. 2021; reference shapes the untangled
mesh; ``--ff-limit`` CPU seconds). Each row: CPU and wall seconds, cells
inverted before and after (exact orient2d), least shape quality and least
angle after. Also tetrahedral tangles (an extruded triangle mesh of the cube,
free nodes moved or random), generation from a boundary (without insertion
from 10k boundary points; with insertion against ``triangulate`` at the same
point count), and tetrahedra from closed surfaces (a cube, an icosphere,
torus-like rings) against TetGen ``pYQ`` on the same surface. Gmsh and
TetGen are bench-only dependencies, skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from meshcore.errors import AlgorithmError
from meshcore.geometry.predicates import orient2d
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import boundary
from meshcore.optimize import optimize


def grid(nx: int, noise: float | None, seed: int = 0):
    h = 1.0 / nx
    x, y = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, nx + 1), indexing="ij")
    P = np.column_stack([x.ravel(), y.ravel()])
    idx = np.arange((nx + 1) ** 2).reshape(nx + 1, nx + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    T = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    inner = (P[:, 0] > 0) & (P[:, 0] < 1) & (P[:, 1] > 0) & (P[:, 1] < 1)
    rng = np.random.default_rng(seed)
    if noise is None:
        P[inner] = rng.uniform(0, 1, (inner.sum(), 2))
    else:
        P[inner] += rng.uniform(-noise * h, noise * h, (inner.sum(), 2))
    return P, T


def inverted2(P, T) -> int:
    return int(np.sum(orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) <= 0))


def describe2(P, T) -> tuple[float, float]:
    return float(quality.triangle_shape(P, T).min()), float(quality.triangle_angles(P, T).min())


GMSH_CHILD = r"""
import sys, time, numpy as np, gmsh
nx, noise, seed = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("m")
p = [gmsh.model.geo.addPoint(x, y, 0) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
c = [gmsh.model.geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
s = gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(c)])
gmsh.model.geo.synchronize()
for ci in c:
    gmsh.model.mesh.setTransfiniteCurve(ci, nx + 1)
gmsh.model.mesh.setTransfiniteSurface(s)
gmsh.model.mesh.generate(2)
tags, xyz, _ = gmsh.model.mesh.getNodes()
index = {int(t): i for i, t in enumerate(tags)}
P = xyz.reshape(-1, 3)[:, :2].copy()
R = P.copy()
_, etags, enodes = gmsh.model.mesh.getElements(2, s)
T = np.array([index[int(t)] for t in enodes[0]]).reshape(-1, 3)
inner_tags, _, _ = gmsh.model.mesh.getNodes(2, s, includeBoundary=False)
rng = np.random.default_rng(seed); h = 1.0 / nx
for t in inner_tags:
    i = index[int(t)]
    P[i] = rng.uniform(0, 1, 2) if noise < 0 else P[i] + rng.uniform(-noise * h, noise * h, 2)
    gmsh.model.mesh.setNode(int(t), [P[i, 0], P[i, 1], 0.0], [])
np.savez(sys.argv[4], P=P, T=T, R=R)
t0, c0 = time.perf_counter(), time.process_time()
gmsh.model.mesh.optimize("UntangleMeshGeometry")
dt, dc = time.perf_counter() - t0, time.process_time() - c0
tags, xyz, _ = gmsh.model.mesh.getNodes()
Q = np.zeros_like(P)
for t, x in zip(tags, xyz.reshape(-1, 3)):
    Q[index[int(t)]] = x[:2]
np.save(sys.argv[5], Q); print(dt, dc)
"""


def gmsh_case(nx: int, noise: float | None, timeout: float, seed: int = 0):
    """Gmsh's own structured mesh of the square, tangled, untangled by Gmsh in a child process.

    Returns (P, T, R, Gmsh's (wall, CPU) seconds or a note, Gmsh's positions or None), R the
    untangled positions; None when Gmsh is absent.
    """
    try:
        import gmsh  # noqa: F401
    except ImportError:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        args = [
            str(nx),
            str(-1 if noise is None else noise),
            str(seed),
            f"{tmp}/in.npz",
            f"{tmp}/out.npy",
        ]
        note, Q = None, None
        try:
            out = subprocess.run(
                [sys.executable, "-c", GMSH_CHILD, *args],
                capture_output=True,
                text=True,
                timeout=10 * timeout,
                preexec_fn=lambda: resource.setrlimit(
                    resource.RLIMIT_CPU, (int(timeout), int(timeout) + 5)
                ),
            )
            if out.returncode == -signal.SIGXCPU:
                note = f"did not finish in {timeout:.0f} CPU s"
            elif out.returncode != 0:
                note = f"failed: {out.stderr.strip()[-100:]}"
        except subprocess.TimeoutExpired:
            note = f"did not finish in {10 * timeout:.0f} wall s"
        try:
            d = np.load(f"{tmp}/in.npz")
        except OSError:
            return None
        P, T, R = d["P"], d["T"], d["R"]
        if note is None:
            Q = np.load(f"{tmp}/out.npy")
            note = tuple(float(x) for x in out.stdout.split()[-2:])
        return P, T, R, note, Q


def foldover_free(P, T, R, fixed, time_limit: float, theta: float = 1 / 128):
    """The peer: "Foldover-free maps in 50 lines of code" (Garanzha et al. 2021), plain numpy.

    Minimizes the regularized Winslow-type energy sum_t area_t ((1 - theta) tr(J^T J) /
    chi(det J, eps) + theta (det J^2 + 1) / chi(det J, eps)), chi(D, eps) = (D + sqrt(eps^2 +
    D^2)) / 2, J the map from the reference triangle (``R``, the untangled mesh) to the current
    one, by L-BFGS (scipy) over the free nodes, with the paper's eps schedule; stops when no
    determinant is negative and the energy falls by less than 0.1 % in an outer round, or after
    ``time_limit`` CPU seconds. Returns the positions and the outer rounds.
    """
    from scipy.optimize import minimize

    t0 = time.process_time()
    Rm = np.stack([R[T[:, 1]] - R[T[:, 0]], R[T[:, 2]] - R[T[:, 0]]], axis=2)
    Z = np.linalg.inv(Rm)
    Zt = np.transpose(Z, (0, 2, 1))
    area = np.abs(np.linalg.det(Rm))
    area /= area.sum()
    detZ = np.linalg.det(Z)
    free = np.flatnonzero(~fixed)
    X = P.copy()

    def jac(x):
        X[free] = x.reshape(-1, 2)
        M = np.stack([X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]]], axis=2)
        return M, M @ Z

    def energy(x, eps):
        M, J = jac(x)
        D = np.linalg.det(J)
        sq = np.sqrt(eps * eps + D * D)
        chi, dchi = 0.5 * (D + sq), 0.5 * (1 + D / sq)
        s2 = np.einsum("tij,tij->t", J, J)
        E = np.sum(area * ((1 - theta) * s2 + theta * (D * D + 1)) / chi)
        dD = (1 - theta) * (-s2 * dchi / chi**2) + theta * (
            2 * D / chi - (D * D + 1) * dchi / chi**2
        )
        cof = np.stack(
            [np.stack([M[:, 1, 1], -M[:, 1, 0]], 1), np.stack([-M[:, 0, 1], M[:, 0, 0]], 1)], 1
        )
        dM = (2 * (1 - theta) / chi)[:, None, None] * J @ Zt + (dD * detZ)[:, None, None] * cof
        dM *= area[:, None, None]
        G = np.zeros_like(X)
        for k in range(2):
            for c in range(2):
                G[:, c] += np.bincount(T[:, 1 + k], dM[:, c, k], len(X))
                G[:, c] -= np.bincount(T[:, 0], dM[:, c, k], len(X))
        return E, G[free].ravel()

    x = X[free].ravel().copy()
    m = np.linalg.det(jac(x)[1]).min()
    eps = np.sqrt(1e-12 + 0.04 * min(m, 0) ** 2)
    rounds = 0
    while rounds < 1000:
        rounds += 1
        e0 = energy(x, eps)[0]
        x = minimize(
            energy, x, args=(eps,), jac=True, method="L-BFGS-B", options={"maxiter": 100}
        ).x
        e1 = energy(x, eps)[0]
        sigma = max(1 - e1 / e0, 0.1)
        m = np.linalg.det(jac(x)[1]).min()
        if (m > 0 and 1 - e1 / e0 < 1e-3) or time.process_time() - t0 > time_limit:
            break
        r = np.sqrt(m * m + eps * eps)
        eps *= (1 - sigma) if m > 0 else 1 - sigma * r / (abs(m) + r)
    X[free] = x.reshape(-1, 2)
    return X, rounds


def row(name, cpu, wall, before, after, q, a, extra=""):
    print(
        f"{name:<36} {cpu:>7.2f} {wall:>7.2f} {before:>7} {after:>7} {q:>7.3f} {a:>7.2f}  {extra}"
    )


def unstructured(size: float, noise: float | None, seed: int = 0):
    """A ``triangulate`` mesh of a 7-pointed star (radii 1 and 0.3) with a square hole, tangled.

    Not convex: the barycentric fixed point folds near the reentrant corners, the passes
    finish. Free nodes moved by U(-noise size, noise size) or put at uniformly random
    positions in [-1, 1]^2. Returns (P, T, R) with R the untangled positions.
    """
    from meshcore.triangulation import triangulate

    a = np.pi / 2 + np.pi * np.arange(14) / 7
    r = np.where(np.arange(14) % 2 == 0, 1.0, 0.3)
    ring = np.column_stack([r * np.cos(a), r * np.sin(a)])
    b = 0.12
    hole = [[-b, -b], [-b, b], [b, b], [b, -b], [-b, -b]]
    dom = {"type": "Polygon", "coordinates": [np.vstack([ring, ring[:1]]).tolist(), hole]}
    m = triangulate(dom, size=size).mesh
    R, T = m.points, m.cells[0].data
    free = np.setdiff1d(np.arange(len(R)), boundary(m).cells[0].data.ravel())
    rng = np.random.default_rng(seed)
    P = R.copy()
    if noise is None:
        P[free] = rng.uniform(-1, 1, (len(free), 2))
    else:
        P[free] += rng.uniform(-noise * size, noise * size, (len(free), 2))
    return P, T, R


def correction(sizes, gmsh_timeout, ff_limit, peers_max_cells):
    """Triangle tangles: ours, Gmsh's untangler and the foldover-free peer on the same input."""
    print(
        f"{'correction (triangles)':<36} {'CPU s':>7} {'wall s':>7} {'inv.bef':>7} "
        f"{'inv.aft':>7} {'min q':>7} {'min ang':>7}"
    )
    P, T = grid(4, 0.9)
    optimize(Mesh(P, (CellBlock("triangle", T),)))  # warm-up: loads numba's cache
    cases = []
    for nx in sizes:
        for noise in (0.5, 0.9, None):
            cases.append(("grid", nx, noise))
    for nx in sizes:
        for noise in (0.5, 0.9, None):
            cases.append(("star", nx, noise))
    for kind, nx, noise in cases:
        tag = f"U(+-{noise}h)" if noise else "random"
        g = None
        peers = 2 * nx * nx <= peers_max_cells
        if kind == "grid":
            g = gmsh_case(nx, noise, gmsh_timeout) if peers else None
            if g is None:
                P, T = grid(nx, noise)
                R = grid(nx, 0.0)[0]
            else:
                P, T, R = g[0], g[1], g[2]
        else:
            # about 2 nx^2 triangles, as the grid
            P, T, R = unstructured(0.99 / nx, noise)
        label = f"{len(T)} tri {kind}, {tag}"
        before = inverted2(P, T)
        t, w = time.process_time(), time.perf_counter()
        try:
            res = optimize(Mesh(P, (CellBlock("triangle", T),)), max_sweeps=5000)
        except AlgorithmError as exc:  # a failure is a row, not a crash
            dt, dw = time.process_time() - t, time.perf_counter() - w
            row(f"ours {label}", dt, dw, before, -1, 0, 0, str(exc)[:60])
            res = None
        if res is not None:
            dt, dw = time.process_time() - t, time.perf_counter() - w
            Pn, Tn = res.mesh.points, res.mesh.cells[0].data
            ops = {k: v for k, v in res.stats["operators"].items() if v}
            row(f"ours {label}", dt, dw, before, inverted2(Pn, Tn), *describe2(Pn, Tn),
                f"passes {res.stats['sweeps']}, {ops}")  # fmt: skip
        if not peers:
            print(f"{'  peers':<36} not run (over --peers-max-cells)")
            continue
        if g is not None:
            if isinstance(g[3], str):
                print(f"{'  gmsh UntangleMeshGeometry':<36} {g[3]}")
            else:
                Q = g[4]
                row("  gmsh UntangleMeshGeometry", g[3][1], g[3][0], before, inverted2(Q, T),
                    *describe2(Q, T), f"CPU gmsh / ours {g[3][1] / dt:.1f}x")  # fmt: skip
        elif kind == "grid":
            print(f"{'  gmsh':<36} not installed")
        fixed = np.ones(len(P), bool)
        fixed[T.ravel()] = False
        fixed[boundary(Mesh(R, (CellBlock("triangle", T),))).cells[0].data.ravel()] = True
        t, w = time.process_time(), time.perf_counter()
        X, rounds = foldover_free(P, T, R, fixed, ff_limit)
        ft, fw = time.process_time() - t, time.perf_counter() - w
        row("  foldover-free (numpy)", ft, fw, before, inverted2(X, T), *describe2(X, T),
            f"rounds {rounds}, CPU ff / ours {ft / dt:.1f}x")  # fmt: skip


def correction3d():
    """Tet tangles: an extruded triangle mesh of the unit cube, free nodes moved (CPU s)."""
    from meshcore.product import Translate, extrude
    from meshcore.triangulation import triangulate

    sq = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}
    print(
        f"\n{'correction (tetrahedra)':<36} {'CPU s':>7} {'wall s':>7} {'inv.bef':>7} "
        f"{'inv.aft':>7} {'min rr':>7}"
    )
    for size, layers in ((0.05, 16), (0.03, 24)):
        m = extrude(
            triangulate(sq, size=size).mesh, Translate([0, 0, 1], layers=layers), simplices=True
        ).mesh
        T = m.cells_by_type["tetra"]
        faces = boundary(Mesh(m.points, (CellBlock("tetra", T),))).cells[0].data
        free = np.setdiff1d(np.arange(len(m.points)), faces.ravel())
        for noise in (0.5, 0.9, None):
            P = m.points.copy()
            rng = np.random.default_rng(0)
            if noise is None:
                P[free] = rng.uniform(0, 1, (len(free), 3))
            else:
                h = np.array([size, size, 1 / layers])
                P[free] += rng.uniform(-noise, noise, (len(free), 3)) * h
            s = -orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], P[T[:, 3]])
            label = f"ours {len(T)} tets " + (f"U(+-{noise}h)" if noise else "random")
            t, w = time.process_time(), time.perf_counter()
            try:
                res = optimize(Mesh(P, (CellBlock("tetra", T),)), max_sweeps=2000)
            except AlgorithmError as exc:
                print(f"{label:<36} {time.process_time() - t:>7.2f}  {str(exc)[:70]}")
                continue
            dt, dw = time.process_time() - t, time.perf_counter() - w
            Pn, Tn = res.mesh.points, res.mesh.cells[0].data
            after = np.sum(-orient3d(Pn[Tn[:, 0]], Pn[Tn[:, 1]], Pn[Tn[:, 2]], Pn[Tn[:, 3]]) <= 0)
            q = float(quality.tetra_radius_ratio(Pn, Tn).min())
            print(
                f"{label:<36} {dt:>7.2f} {dw:>7.2f} {int(np.sum(s <= 0)):>7} {int(after):>7} "
                f"{q:>7.3f}  passes {res.stats['sweeps']}"
            )


def generation():
    print(f"\n{'generation':<34} {'time s':>8} {'points':>8} {'tri':>8} {'min ang':>8}")
    rng = np.random.default_rng(1)
    n = 10_000
    a = 2 * np.pi * np.arange(n) / n
    for jitter in (0.0, 0.2):
        # a five-petal flower; jitter: radial noise in boundary spacings (a zigzag boundary)
        r = 1 + 0.3 * np.sin(5 * a) + jitter * (2 * np.pi / n) * rng.uniform(-1, 1, n)
        ring = np.column_stack([r * np.cos(a), r * np.sin(a)]).tolist()
        dom = {"type": "Polygon", "coordinates": [ring]}
        label = f"ours 10k flower{' jitter' if jitter else ''}, no ins."
        t = time.perf_counter()
        try:
            res = optimize(domain=dom, insert_points=False, max_sweeps=1000)
        except AlgorithmError as exc:
            print(f"{label:<34} {time.perf_counter() - t:>8.2f}  {str(exc)[:70]}")
            continue
        dt = time.perf_counter() - t
        P, T = res.mesh.points, res.mesh.cells[0].data
        print(
            f"{label:<34} {dt:>8.2f} {len(P):>8} {len(T):>8} "
            f"{quality.triangle_angles(P, T).min():>8.2f}  inverted {inverted2(P, T)}"
        )
    generation_with_insertion()


def _cpu(f, repeat=3):
    """Median CPU seconds of ``repeat`` calls of f (this process, all threads) and its result."""
    times = []
    for _ in range(repeat):
        t = time.process_time()
        out = f()
        times.append(time.process_time() - t)
    return float(np.median(times)), out


def generation_with_insertion():
    """Generation with insertion against ``triangulate`` at the same point count.

    A disk (a regular m-gon, m = 400, 2,000 and 10,000) and a five-petal
    flower (10,000 boundary points), the boundary kept; ours at the given
    ``size`` (the boundary spacing h, or 5h for the 10k boundaries: h would
    make 9M points), ``triangulate`` (``min_angle=25``, ``keep_boundary``) at
    the size that gives within 2 % of our point count (a few secant steps).
    CPU seconds, medians of 3 in this process.
    """
    from meshcore.triangulation import triangulate

    print(
        f"\n{'with insertion (CPU s, median of 3)':<30} {'ours s':>7} {'points':>8} {'min ang':>7}"
        f" {'tri. s':>7} {'points':>8} {'min ang':>7} {'ratio':>6}"
    )
    cases = []
    for m, f in ((400, 1), (2000, 1), (10_000, 5)):
        a = 2 * np.pi * np.arange(m) / m
        cases.append((f"disk {m}, size {f}h", np.column_stack([np.cos(a), np.sin(a)]), f))
    # the flower's first stage needs more passes than the default (see generation())
    m = 10_000
    a = 2 * np.pi * np.arange(m) / m
    r = 1 + 0.3 * np.sin(5 * a)
    cases.append((f"flower {m}, size 5h", np.column_stack([r * np.cos(a), r * np.sin(a)]), 5))
    for label, ring, f in cases:
        dom = {"type": "Polygon", "coordinates": [ring.tolist()]}
        m = len(ring)
        h = f * float(np.median(np.linalg.norm(np.diff(ring, axis=0), axis=1)))
        dt, res = _cpu(lambda dom=dom, h=h: optimize(domain=dom, size=h, max_sweeps=1000))
        P, T = res.mesh.points, res.mesh.cells[0].data
        n = len(P)
        ang = quality.triangle_angles(P, T).min()
        s, tr = h, None
        for _ in range(6):  # triangulate's size for our point count
            tr = triangulate(dom, size=s, min_angle=25, keep_boundary=True).mesh
            k = len(tr.points)
            if abs(k - n) <= 0.02 * n:
                break
            s *= float(np.clip(np.sqrt((k - m) / max(n - m, 1)), 0.5, 2.0)) if k > m else 0.7
        dt2, tr = _cpu(
            lambda dom=dom, s=s: triangulate(dom, size=s, min_angle=25, keep_boundary=True)
        )
        P2, T2 = tr.mesh.points, tr.mesh.cells[0].data
        print(
            f"{label:<30} {dt:>7.3f} {n:>8} {ang:>7.2f} {dt2:>7.3f} {len(P2):>8} "
            f"{quality.triangle_angles(P2, T2).min():>7.2f} {dt / dt2:>5.2f}x"
            f"  given up {res.stats['insertion']['given_up']}"
        )


def generation3d():
    """Tetrahedra from closed surfaces (Figure 8.11): ours against TetGen ``pYQ`` on the same one.

    Ours without insertion, and with insertion (``size`` above the diameter: only the points
    the stuck first stage and the optimization stage add) for both measures of (8.2). Columns:
    CPU seconds (median of 3), points, tets, the least quality of the run's measure before
    and after the optimization stage, the least radius ratio 3r/R of the result, the stuck
    initial vertices restarted from, the volume's relative error, and whether the surface
    translated by 1e6 and scaled by 1e-6 gives the same tets (or fails the same way).
    """
    from meshcore.domain.surface import parse_surface
    from tests.meshcore.optimize.test_generate3d import grid_cube, icosphere, ring

    print(
        f"\n{'generation from a surface':<36} {'CPU s':>6} {'points':>6} {'tets':>6} "
        f"{'q before':>9} {'q after':>8} {'min rr':>8} {'restarts':>8} {'vol err':>8} placed"
    )

    def placed(P, F, kw, ref):
        """'same' when +1e6 and x1e-6 give the cells of ``ref`` (or its failure's count)."""
        for Q, f in ((P + 1e6, 1.0), (P * 1e-6, 1e-6)):
            k = dict(kw, size=kw["size"] * f) if "size" in kw else kw
            try:
                got = optimize(surface=parse_surface(Q, F), **k).mesh.cells[0].data
            except AlgorithmError as exc:  # no valid mesh: the same failure wherever it lies?
                got = str(exc).split(", within")[0]
            if isinstance(ref, str) or isinstance(got, str):
                if not (isinstance(ref, str) and isinstance(got, str) and got == ref):
                    return "differs"
            elif not np.array_equal(got, ref):
                return "differs"
        return "same"

    shapes = {
        "cube 6x6 per face": grid_cube(6),
        "icosphere level 3": icosphere(3),
        "ring 16x5": ring(16, 5),
        "ring 12x6": ring(12, 6),
        "ring 24x8": ring(24, 8),
    }
    runs = (
        ("no ins.", {"insert_points": False}),
        ("ins., shape", {"size": 1e9}),
        ("ins., radius_ratio", {"size": 1e9, "quality": "radius_ratio"}),
    )
    for name, (P, F) in shapes.items():
        surf = parse_surface(P, F)
        for label, kw in runs:
            times = []
            for _ in range(3):
                t = time.process_time()
                try:
                    res = optimize(surface=surf, **kw)
                except AlgorithmError as exc:
                    res = exc
                times.append(time.process_time() - t)
            dt = float(np.median(times))
            if isinstance(res, Exception):
                where = placed(P, F, kw, str(res).split(", within")[0])
                print(f"{'ours ' + name + ', ' + label:<36} {dt:>6.3f}  {str(res)[:60]} {where}")
                continue
            Pn, Tn = res.mesh.points, res.mesh.cells[0].data
            err = abs(np.sum(quality.signed_volume(Pn, Tn)) - surf.volume) / surf.volume
            q = float(quality.tetra_radius_ratio(Pn, Tn).min())
            st = res.stats
            print(
                f"{'ours ' + name + ', ' + label:<36} {dt:>6.3f} {len(Pn):>6} {len(Tn):>6} "
                f"{st['least_quality_before_optimization']:>9.3g} "
                f"{st['least_quality_after']:>8.3g} "
                f"{q:>8.3g} {len(st['restarts']):>8} {err:>8.1e} {placed(P, F, kw, Tn)}"
            )
        try:
            import tetgen
        except ImportError:
            print("  (tetgen not installed)")
            continue
        times = []
        for _ in range(3):
            t = time.process_time()
            tg = tetgen.TetGen(np.asarray(surf.points, float), np.asarray(surf.triangles, np.int32))
            nodes, elems = tg.tetrahedralize(switches="pYQ")[:2]
            times.append(time.process_time() - t)
        q = float(np.abs(quality.tetra_radius_ratio(nodes, elems)).min())
        err = abs(np.sum(np.abs(quality.signed_volume(nodes, elems))) - surf.volume) / surf.volume
        print(
            f"{'TetGen pYQ ' + name:<36} {float(np.median(times)):>6.3f} {len(nodes):>6} "
            f"{len(elems):>6} {'':>9} {'':>8} {q:>8.3g} {'':>8} {err:>8.1e}"
        )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 224], help="grid nx (2 nx^2 tri)")
    ap.add_argument("--gmsh-timeout", type=float, default=120.0, help="Gmsh CPU seconds")
    ap.add_argument("--peers-max-cells", type=int, default=10**9, help="peers up to this size")
    ap.add_argument("--ff-limit", type=float, default=120.0, help="foldover-free CPU seconds")
    ap.add_argument("--only", choices=["correction", "generation", "insertion", "3d"], default=None)
    args = ap.parse_args()
    if args.only in (None, "correction"):
        correction(args.sizes, args.gmsh_timeout, args.ff_limit, args.peers_max_cells)
        correction3d()
    if args.only in (None, "generation"):
        generation()
    if args.only == "insertion":
        generation_with_insertion()
    if args.only in (None, "3d"):
        generation3d()
    print(json.dumps({"note": "correction: CPU and wall seconds; 3D generation CPU seconds"}))


if __name__ == "__main__":
    main()
