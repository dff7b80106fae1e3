"""Side by side: ``tetrahedralize`` (ours), TetGen and Gmsh on the same closed surfaces.

Run from the repository root::

    .venv/bin/python benchmarks/tetrahedralize.py
    .venv/bin/python benchmarks/tetrahedralize.py --shapes torus --size 0.08

Inputs: a unit cube, a cube minus a ball (``cube_ball``), an icosphere (1,280
triangles), a torus (32 x 16 quads split), a box with a box-shaped cavity, an
L-block, a thin slab (1 x 1 x 0.01) and Schönhardt's prism, each given to every
tool as the same points and triangles. Ours runs with the default
``max_radius_edge=2``, then with ``min_dihedral`` added (``--min-dihedral``, 15
by default; the output is then no longer Delaunay), with ``size`` alone (no
radius-edge bound) and with ``keep_boundary`` (beside TetGen's ``pY``); TetGen
with ``pq2`` (radius-edge 2), ``pq1.414`` and ``pY`` (boundary kept, no
quality), all with ``-a`` from the same volume bound where ``--size`` is given;
Gmsh's Delaunay (``Mesh.Algorithm3D`` 1) and HXT (10) on the same triangles as
one discrete surface per shell (``Mesh.MeshSizeMax`` the size where given);
fTetWild (``pytetwild``, one thread, ``edge_length_abs`` the size where given;
it remeshes the surface, so its boundary is not the input's). TetGen gets
``add_hole`` for the cavities. Each row: CPU seconds of the meshing call
(``time.process_time``: every tool runs in this process, and on a shared
machine wall time mostly measures the other processes; ours after a
warm-up that loads numba's cache), tetrahedra, tetrahedra per
second, points added, least and largest dihedral angle (degrees), the share
of tetrahedra under 10 degrees, the largest radius-edge ratio, the peak
resident memory of the process so far (MB, ``ru_maxrss``: monotone, so read
it as an upper bound for the row) and the ratio of our time to TetGen's
``pq2``. TetGen and Gmsh are bench-only dependencies, skipped with a note
when absent.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.domain import parse_surface  # noqa: E402
from meshcore.tets import tetra_dihedral_angles, tetrahedralize  # noqa: E402
from meshcore.tets.refinement import _shortest_edge, _tet_circumcenters  # noqa: E402
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


def _figures(P, K) -> tuple[float, float, float, float]:
    d = tetra_dihedral_angles(P, K)
    _, R = _tet_circumcenters(P, K)
    ratio = R / _shortest_edge(P, K)
    under = 100.0 * float((d.min(axis=1) < 10).mean())
    return float(d.min()), float(d.max()), under, float(np.nanmax(ratio))


def run_gmsh(P, T, algorithm: int, size: float | None):
    """Gmsh 3D on the given triangles (one discrete surface per shell)."""
    import gmsh

    shells = parse_surface(P, T).triangle_shell
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("s")
        loops = []
        for k in np.unique(shells).tolist():
            tri = T[shells == k]
            used = np.unique(tri)
            tag = gmsh.model.addDiscreteEntity(2)
            gmsh.model.mesh.addNodes(2, tag, (used + 1).tolist(), P[used].ravel().tolist())
            gmsh.model.mesh.addElementsByType(tag, 2, [], (tri + 1).ravel().tolist())
            loops.append(gmsh.model.geo.addSurfaceLoop([tag]))
        gmsh.model.geo.addVolume(loops)
        gmsh.model.geo.synchronize()
        gmsh.option.setNumber("Mesh.Algorithm3D", algorithm)
        if size is not None:
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        t = time.process_time()
        gmsh.model.mesh.generate(3)
        dt = time.process_time() - t
        tags, coords, _ = gmsh.model.mesh.getNodes()
        X = np.zeros((int(tags.max()) + 1, 3))
        X[tags.astype(np.int64)] = coords.reshape(-1, 3)
        _, elem = gmsh.model.mesh.getElementsByType(4)
        K = elem.astype(np.int64).reshape(-1, 4)
        keep = np.unique(K)
        remap = np.full(len(X), -1)
        remap[keep] = np.arange(len(keep))
        return dt, X[keep], remap[K], len(keep) - len(np.unique(T))
    finally:
        gmsh.finalize()


def run_ours(P, T, **kw):
    s = parse_surface(P, T)
    tetrahedralize(parse_surface(*shapes.box()), **kw)  # warm-up (numba cache)
    t = time.process_time()
    r = tetrahedralize(s, **kw)
    dt = time.process_time() - t
    K = r.mesh.cells[0].data
    added = r.surface_points_added + r.interior_points_added
    return dt, r.mesh.points, K, added, r.given_up


def run_ftetwild(P, T, size: float | None):
    """fTetWild (``pytetwild``, one thread); its tetrahedra come negatively oriented."""
    import types

    if "pyvista" not in sys.modules:
        try:
            import pyvista  # noqa: F401
        except ImportError:  # pytetwild imports pyvista at import: a stub avoids VTK
            sys.modules["pyvista"] = types.ModuleType("pyvista")
    import pytetwild

    kw = {"edge_length_abs": size} if size is not None else {}
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # fTetWild writes __tracked_surface.stl into the working directory
        try:
            t = time.process_time()
            X, K = pytetwild.tetrahedralize(P, T.astype(np.int32), num_threads=1, **kw)
            dt = time.process_time() - t
        finally:
            os.chdir(here)
    K = np.asarray(K, dtype=np.int64)
    return dt, np.asarray(X), K[:, [0, 1, 3, 2]], len(X) - len(P)


def run_tetgen(P, T, holes, switches):
    import tetgen

    g = tetgen.TetGen(P, T.astype(np.int32))
    for h in holes:
        g.add_hole(h)
    t = time.process_time()
    nodes, elem = g.tetrahedralize(switches=switches + "Q")[:2]
    dt = time.process_time() - t
    return dt, np.asarray(nodes), np.asarray(elem, dtype=np.int64), len(nodes) - len(P)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=sorted(SHAPES))
    ap.add_argument("--size", type=float, default=None, help="target edge length (ours, TetGen -a)")
    ap.add_argument("--no-gmsh", action="store_true", help="skip the Gmsh rows")
    ap.add_argument(
        "--no-slivers", action="store_true", help="skip our min_dihedral rows (long jobs)"
    )
    ap.add_argument(
        "--min-dihedral", type=float, nargs="+", default=[15.0], help="our min_dihedral rows"
    )
    ap.add_argument("--no-ftetwild", action="store_true", help="skip the fTetWild row")
    ap.add_argument("--no-keep", action="store_true", help="skip our keep_boundary row")
    args = ap.parse_args()
    try:
        import tetgen  # noqa: F401

        have_tetgen = True
    except ImportError:
        have_tetgen = False
        print("tetgen not installed (pip install -e .[bench]): TetGen rows skipped")
    try:
        import gmsh  # noqa: F401

        have_gmsh = not args.no_gmsh
    except ImportError:
        have_gmsh = False
        print("gmsh not installed (pip install -e .[bench]): Gmsh rows skipped")
    try:
        import importlib.util

        have_ftetwild = importlib.util.find_spec("pytetwild") is not None and not args.no_ftetwild
    except ImportError:
        have_ftetwild = False
    print(f"load (uptime): {os.getloadavg()[0]:.1f}; seconds are CPU seconds")
    head = f"{'input':<10} {'tool':<26} {'cpu s':>7} {'tets':>8} {'tets/s':>8} {'added':>7} "
    head += f"{'dih min':>7} {'dih max':>7} {'%<10':>6} {'r/e max':>8} {'MB':>6} {'x pq2':>6}"
    print(head)
    for name in args.shapes:
        P, T, holes = SHAPES[name]()
        rows = []
        extra = {} if args.size is None else {"size": args.size}
        dt, X, K, added, gu = run_ours(P, T, **extra)
        rows.append((f"ours r/e 2 (given up {gu})", dt, X, K, added))
        for mdh in [] if args.no_slivers else args.min_dihedral:
            dt, X, K, added, gu = run_ours(P, T, min_dihedral=mdh, **extra)
            rows.append((f"ours r/e 2, dihedral {mdh:g}", dt, X, K, added))
        if not args.no_keep:
            dt, X, K, added, gu = run_ours(P, T, keep_boundary=True)
            rows.append(("ours keep_boundary", dt, X, K, added))
        if args.size is not None:
            dt, X, K, added, gu = run_ours(P, T, size=args.size, max_radius_edge=None)
            rows.append(("ours size only", dt, X, K, added))
        ref = None
        if have_tetgen:
            vol = "" if args.size is None else f"a{args.size**3 / 8.48:.6g}"
            for sw in ("pq2", "pq1.414", "pY"):
                dt, X, K, added = run_tetgen(P, T, holes, sw + (vol if sw != "pY" else ""))
                rows.append((f"tetgen -{sw}", dt, X, K, added))
                if sw == "pq2":
                    ref = dt
        if have_gmsh:
            for alg, label in ((1, "gmsh Delaunay"), (10, "gmsh HXT")):
                dt, X, K, added = run_gmsh(P, T, alg, args.size)
                rows.append((label, dt, X, K, added))
        if have_ftetwild:
            dt, X, K, added = run_ftetwild(P, T, args.size)
            rows.append(("fTetWild", dt, X, K, added))
        for tool, dt, X, K, added in rows:
            dmin, dmax, under, rmax = _figures(X, K)
            ratio = f"{dt / ref:6.2f}" if ref else "     -"
            mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(
                f"{name:<10} {tool:<26} {dt:7.3f} {len(K):8d} {len(K) / dt:8.0f} {added:7d} "
                f"{dmin:7.2f} {dmax:7.2f} {under:6.2f} {rmax:8.2f} {mb:6.0f} {ratio}"
            )


if __name__ == "__main__":
    main()
