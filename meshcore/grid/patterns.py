"""Pattern-based meshes: ``pattern`` (§8.2, Figures 8.6 and 8.7).

"Using as pre-specified mesh a mesh composed of pre-defined patterns results
in a final mesh where most of the elements conform to this pattern": an
enclosing mesh of patterns is laid over the domain, the patterns strictly
inside and far enough from the boundary are kept, the remaining region is
meshed by a general-purpose mesher, and the two are merged. The steps of
Figure 8.7:

i) the patterns with a portion inside the domain (counted in ``stats``);
ii) the retained ones: every vertex strictly inside (exact ray parity) and
    the pattern at least ``margin`` times its size from the boundary and the
    constraints (distance to boundary samples at most a quarter of
    ``margin`` times the smallest pattern size apart: a boundary crossing a
    pattern always drops it); where two retained patterns touch at a corner
    only, the patterns at that vertex are dropped too (the outline is then
    simple loops);
iii) the gap, between the retained patterns' outline and the boundary,
    meshed by :func:`meshcore.triangulation.refinement.triangulate` with the
    outline kept (no point added on it) and the input segments split into
    pieces of the pattern's edge length (:func:`meshcore.grid.band.fill_gap`);
iv) the two merged into one conforming mesh
    (:func:`meshcore.product.merge.merged`), cell sets ``pattern`` and ``gap``.

Patterns (Figure 8.6 and the last paragraph of §8.2)::

    parallelogram              hexagon (six equilateral      radial (quads between
    o + i a + j b               triangles)                    rings about a centre)
       ____ ____                  __                            ___
      /   /   /                __/\\/\\__                       /\\ | /\\
     /___/___/                  \\/__\\/                        |--(c)--|
                                                                \\/_|_\\/

* ``{"type": "parallelogram", "vectors": [a, b], "origin": o}``: cells
  ``o + i a + j b`` (one pattern each).
* ``{"type": "hexagon", "size": s, "origin": o}``: regular hexagons of side
  ``s`` on the triangular lattice, each six equilateral triangles (a pattern
  is the whole hexagon: it is kept or dropped whole).
* ``{"type": "radial", "center": c, "radii": [r0, r1, ...] | "rings": n,
  "segments": m}``: quads between consecutive circles of the radii (or of
  ``n`` radii equally spaced up to the farthest domain vertex), ``m``
  angular sectors; the disc inside the first radius is left to the gap.

With ``gap="quads"`` the gap's triangles are combined and split into quads
only (:func:`meshcore.quads.combination.combine`, ``all_quad``), and the
retained patterns are split the same way (quads into four, triangles into
three quads) so that the interface conforms: the whole mesh is quads. The
gap's quads are then optimized with the patterns and the boundary fixed
(``combine``'s ``optimize``: the operators of §8.4.3 and a smoothing that
never inverts a cell nor lowers the least quality), which lifts the least
quality of Figure 8.7's gap from 0.28 / 0.11 / 0.06 (parallelogram,
hexagon, radial) to 0.48 / 0.56 / 0.08; the radial pattern's last poor
quads have two edges on its outline meeting at a nearly flat angle, which a
fixed outline cannot mend.

Guarantees: the cell areas add up to the domain's, every input segment is a
chain of mesh edges and every input vertex a mesh vertex (the gap's own
boundary), no cell has non-positive area, the mesh conforms (checked by the
merge); the retained patterns are exactly the pattern's cells.

References
----------
Methods text §8.2 (Figures 8.6, 8.7).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import ray_parity
from meshcore.errors import InputError, positive_parameter
from meshcore.geometry.predicates import orient2d
from meshcore.grid.band import fill_gap
from meshcore.grid.cartesian import GridResult, Progress, _as_domain, _choice, _number
from meshcore.mesh import Mesh
from meshcore.mesh.quality import quad_quality, triangle_shape

__all__ = ["MAX_PATTERN_CELLS", "check_pattern", "pattern"]

#: Largest number of pattern cells laid over the domain's bounding box.
MAX_PATTERN_CELLS = 4_000_000
#: Largest number of boundary samples of the retention test (step ii).
MAX_BOUNDARY_SAMPLES = 1 << 22


def _bad(msg: str, *loc) -> InputError:
    return InputError(msg, loc=("pattern", *loc), code="bad_parameter")


def _point(value, *loc) -> np.ndarray:
    try:
        p = np.asarray(value, dtype=np.float64).reshape(2)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int beyond float64
        raise _bad(f"{loc[-1]} must be [x, y], got {value!r}", *loc) from None
    if not np.isfinite(p).all():
        raise InputError(f"{loc[-1]} must be finite", loc=("pattern", *loc), code="non_finite")
    return p


def _size(spec: Mapping) -> float:
    """A hexagon pattern's size: ``positive_parameter``'s check, under ``pattern``."""
    if spec.get("size") is None:
        raise _bad("a hexagon pattern needs its size", "size")
    try:
        return positive_parameter(spec["size"], "size")
    except InputError as exc:
        raise exc.prefixed("pattern") from None


def _count(n: float) -> None:
    if not n <= MAX_PATTERN_CELLS:  # NaN too
        raise InputError(
            f"the pattern lays about {n:.3g} cells over the domain, more than "
            f"{MAX_PATTERN_CELLS:,}",
            loc=("pattern",),
            code="too_many_cells",
        )


def _vectors(spec: Mapping) -> tuple[np.ndarray, int]:
    vec = spec.get("vectors")
    try:
        V = np.asarray(vec, dtype=np.float64).reshape(2, 2)
    except (TypeError, ValueError, OverflowError):
        raise _bad(f"vectors must be two [x, y] vectors, got {vec!r}", "vectors") from None
    if not np.isfinite(V).all():
        raise InputError("vectors must be finite", loc=("pattern", "vectors"), code="non_finite")
    for k in range(2):
        if not V[k].any():
            raise _bad(f"vector {k} is zero", "vectors", k)
    turn = int(orient2d(np.zeros(2), V[0], V[1]))
    if turn == 0:
        raise _bad("the two vectors are parallel: they span no parallelogram", "vectors")
    return V, turn


def _parallelogram(spec: Mapping, P: np.ndarray):
    V, turn = _vectors(spec)
    o = _point(spec["origin"], "origin") if spec.get("origin") is not None else P.min(axis=0)
    M = np.column_stack([V[0], V[1]])
    ij = np.linalg.solve(M, (P - o).T).T
    with np.errstate(over="ignore"):  # counted in float before the int casts: inf for a tiny cell
        _count(float(np.prod(np.ceil(ij.max(axis=0)) - np.floor(ij.min(axis=0)) + 2)))
    i0, j0 = np.floor(ij.min(axis=0)).astype(int) - 1
    i1, j1 = np.ceil(ij.max(axis=0)).astype(int) + 1
    ni, nj = i1 - i0, j1 - j0
    ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1))
    pts = o + ii.ravel()[:, None] * V[0] + jj.ravel()[:, None] * V[1]
    w = ni + 1
    ci, cj = np.meshgrid(np.arange(ni), np.arange(nj))
    c00 = (cj * w + ci).ravel()
    quads = np.column_stack([c00, c00 + 1, c00 + w + 1, c00 + w])
    if turn < 0:
        quads = quads[:, ::-1]
    size = max(float(np.hypot(*(V[0] + V[1]))), float(np.hypot(*(V[0] - V[1]))))
    h = float(min(np.hypot(*V[0]), np.hypot(*V[1])))
    return pts, [("quad", quads)], [np.arange(len(quads))], np.full(len(quads), size), h


def _hexagon(spec: Mapping, P: np.ndarray):
    s = _size(spec)
    o = _point(spec["origin"], "origin") if spec.get("origin") is not None else P.min(axis=0)
    u, v = np.array([s, 0.0]), np.array([0.5 * s, 0.5 * math.sqrt(3.0) * s])
    M = np.column_stack([u, v])
    ij = np.linalg.solve(M, (P - o).T).T
    with np.errstate(over="ignore"):  # as for the parallelogram
        _count(2 * float(np.prod(np.ceil(ij.max(axis=0)) - np.floor(ij.min(axis=0)) + 5)))
    i0, j0 = np.floor(ij.min(axis=0)).astype(int) - 2
    i1, j1 = np.ceil(ij.max(axis=0)).astype(int) + 2
    ni = i1 - i0 + 1
    ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1))
    ii, jj = ii.ravel(), jj.ravel()
    pts = o + ii[:, None] * u + jj[:, None] * v
    centre = ((ii - jj) % 3 == 0) & (ii > i0) & (ii < i1) & (jj > j0) & (jj < j1)
    c = np.flatnonzero(centre)
    ring = [(1, 0), (0, 1), (-1, 1), (-1, 0), (0, -1), (1, -1)]  # counter-clockwise
    nb = [c + di + dj * ni for di, dj in ring]
    tris = np.concatenate([np.column_stack([c, nb[k], nb[(k + 1) % 6]]) for k in range(6)])
    group = np.tile(np.arange(len(c)), 6)
    return pts, [("triangle", tris)], [group], np.full(len(tris), 2 * s), s


def _radii(spec: Mapping) -> np.ndarray | None:
    """The given radii, checked (None when rings are given instead)."""
    if (spec.get("radii") is None) == (spec.get("rings") is None):
        raise _bad("give either radii or rings", "radii")
    if spec.get("radii") is None:
        return None
    try:
        r = np.asarray(spec["radii"], dtype=np.float64).ravel()
    except (TypeError, ValueError, OverflowError):
        raise _bad("radii must be a list of numbers", "radii") from None
    if len(r) < 2:
        raise _bad("radii needs at least two circles", "radii")
    for k, x in enumerate(r):
        if not math.isfinite(x) or x <= 0:
            raise _bad(f"radius {k} must be a finite number above 0, got {x!r}", "radii", k)
    bad = np.flatnonzero(np.diff(r) <= 0)
    if bad.size:
        raise _bad("radii must increase", "radii", int(bad[0]) + 1)
    return r


def check_pattern(spec: Mapping) -> None:
    """Check a pattern's parameters without laying it (the service's check before queueing).

    Raises
    ------
    InputError
        ``loc`` under ``pattern``: zero or parallel vectors, a radius not
        above 0 or radii not increasing, a size not above 0, an unknown type.
    """
    kind = spec.get("type")
    if kind not in _BUILDERS:
        raise _bad(f"pattern type must be one of {', '.join(_BUILDERS)}, got {kind!r}", "type")
    if kind == "parallelogram":
        _vectors(spec)
    elif kind == "hexagon":
        _size(spec)
    else:
        _radii(spec)


def _radial(spec: Mapping, P: np.ndarray):
    if spec.get("center") is None:
        raise _bad("a radial pattern needs its center", "center")
    c = _point(spec["center"], "center")
    m = spec.get("segments")
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 3:
        raise _bad(f"segments must be an integer of at least 3, got {m!r}", "segments")
    r = _radii(spec)
    if r is None:
        n = spec["rings"]
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise _bad(f"rings must be a positive integer, got {n!r}", "rings")
        R = float(np.hypot(*(P - c).T).max())
        r = R * np.arange(1, n + 2) / (n + 1)
    _count(len(r) * m)
    th = 2 * np.pi * np.arange(m) / m
    rr, tt = np.meshgrid(r, th, indexing="ij")
    pts = c + np.column_stack([(rr * np.cos(tt)).ravel(), (rr * np.sin(tt)).ravel()])
    k, j = np.meshgrid(np.arange(len(r) - 1), np.arange(m), indexing="ij")
    k, j = k.ravel(), j.ravel()
    a = k * m + j
    b = (k + 1) * m + j
    quads = np.column_stack([a, b, (k + 1) * m + (j + 1) % m, k * m + (j + 1) % m])
    Q = pts[quads]
    size = np.maximum(np.hypot(*(Q[:, 2] - Q[:, 0]).T), np.hypot(*(Q[:, 3] - Q[:, 1]).T))
    edge = np.hypot(*(Q[:, 1] - Q[:, 0]).T)
    h = float(np.median(np.minimum(edge, np.hypot(*(Q[:, 3] - Q[:, 0]).T))))
    return pts, [("quad", quads)], [np.arange(len(quads))], size, h


_BUILDERS = {"parallelogram": _parallelogram, "hexagon": _hexagon, "radial": _radial}


def _boundary_samples(dom, step: float, margin: float):
    """Samples at most ``step`` apart along the segments and constraints, each end included.

    Raises InputError (``margin``) past :data:`MAX_BOUNDARY_SAMPLES` samples: ``step``
    is a quarter of ``margin`` times the pattern's size, so a tiny margin asks for a
    boundary sampled finer than any job can hold.
    """
    seg = np.concatenate([dom.segments, dom.constraints])
    a, b = dom.points[seg[:, 0]], dom.points[seg[:, 1]]
    with np.errstate(over="ignore"):  # float, inf for a tiny step: int64 would overflow
        n = np.ceil(np.hypot(*(b - a).T) / step) + 1
    if n.sum() > MAX_BOUNDARY_SAMPLES:
        raise InputError(
            f"margin {margin:g} would test the patterns against {n.sum():.3g} boundary "
            f"samples {step:.3g} apart; at most {MAX_BOUNDARY_SAMPLES:,}: give a larger "
            "margin or a coarser pattern",
            loc=("margin",),
            code="too_many_samples",
        )
    n = n.astype(np.int64)
    s = np.repeat(np.arange(len(seg)), n)
    k = np.arange(len(s)) - np.repeat(np.cumsum(n) - n, n)
    t = (k / (n[s] - 1))[:, None]
    return a[s] + t * (b[s] - a[s])


def _polygon_distance(V: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from points q (r, 2) to convex CCW polygons V (r, k, 2); 0 inside."""
    k = V.shape[1]
    inside = np.ones(len(q), dtype=bool)
    d = np.full(len(q), np.inf)
    for c in range(k):
        a, b = V[:, c], V[:, (c + 1) % k]
        e = b - a
        cross = e[:, 0] * (q[:, 1] - a[:, 1]) - e[:, 1] * (q[:, 0] - a[:, 0])
        inside &= cross >= 0
        t = np.clip(np.einsum("ij,ij->i", q - a, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        d = np.minimum(d, np.hypot(*(a + t[:, None] * e - q).T))
    return np.where(inside, 0.0, d)


def pattern(
    domain,
    *,
    pattern: Mapping,
    margin: float = 0.5,
    gap: str = "triangles",
    progress: Progress = None,
) -> GridResult:
    """Mesh a planar domain with pre-defined patterns and a mesh of the gap (§8.2).

    Parameters
    ----------
    domain : Domain or dict
        Holes and constraints allowed.
    pattern : dict
        ``parallelogram``, ``hexagon`` or ``radial`` (module docstring).
    margin : float
        Patterns closer to the boundary than ``margin`` times their size (the
        longer diagonal; a hexagon's: twice its side) are dropped. Above 0.
    gap : {"triangles", "quads"}
        The gap as triangles, or the whole mesh as quads.
    progress : callable(fraction, message), optional

    Returns
    -------
    GridResult
        Cell sets ``pattern`` and ``gap``. ``stats``: ``steps`` (``i`` the
        patterns with a portion inside, ``ii`` the retained patterns, ``iii``
        the gap's triangles, ``iv`` the final cells), ``pattern_cells``,
        ``gap_cells``, ``pattern_area_share``, ``quality`` (least and mean
        per cell type: (8.4) for quads, shape ratio for triangles), ``area``
        and ``domain_area``.

    Raises
    ------
    InputError
        A bad domain (``loc`` under ``domain``), a bad pattern (``loc``
        under ``pattern``: zero or parallel vectors, a zero radius, radii not
        increasing, a size not above 0), a bad ``margin`` or ``gap``,
        ``too_many_cells``, ``too_many_samples`` (a margin so small that the
        boundary would need more than :data:`MAX_BOUNDARY_SAMPLES` samples).

    References
    ----------
    Methods text §8.2, Figures 8.6 and 8.7 (module docstring).
    """
    t0 = time.process_time()
    dom = _as_domain(domain)
    if not isinstance(pattern, Mapping):
        raise _bad(f"pattern must be an object with a type, got {pattern!r}")
    kind = pattern.get("type")
    if kind not in _BUILDERS:
        raise _bad(f"pattern type must be one of {', '.join(_BUILDERS)}, got {kind!r}", "type")
    m = _number(margin, "margin")
    if m <= 0:
        raise InputError(
            f"margin must be above 0, got {margin!r}", loc=("margin",), code="bad_parameter"
        )
    gap = _choice(gap, "gap", ("triangles", "quads"))
    pts, blocks, groups, size, h = _BUILDERS[kind](pattern, dom.points)
    data = blocks[0][1]
    group = groups[0]
    n_groups = int(group.max()) + 1 if len(group) else 0
    if progress is not None:
        progress(0.1, "pattern: retaining patterns")

    # -- ii) retained: vertices inside, far enough from the boundary ---------
    V = pts[data]
    cen = V.mean(axis=1)
    rad = np.hypot(*(V - cen[:, None]).transpose(2, 0, 1)).max(axis=1)
    step = 0.25 * m * float(size.min())
    S = _boundary_samples(dom, step, m)
    tree = cKDTree(S)
    d0, _ = tree.query(cen)
    need = m * size
    rs = dom.segments
    vin = np.zeros(len(pts), dtype=bool)
    cand_pts = np.unique(data.ravel())
    rows = ray_parity(
        pts[cand_pts],
        np.full(len(cand_pts), -1, dtype=np.int64),
        dom.points[rs[:, 0]],
        dom.points[rs[:, 1]],
        dom.segment_ring,
        dom.ring_count,
    )
    vin[cand_pts] = np.bincount(rows[:, 0], minlength=len(cand_pts)) % 2 == 1
    all_in = vin[data].all(axis=1)
    portion = vin[data].any(axis=1) | (d0 < rad)
    ok = all_in & (d0 - 0.5 * step > rad + need)
    unsure = np.flatnonzero(all_in & ~ok & (d0 >= need))
    if unsure.size:
        balls = tree.query_ball_point(cen[unsure], rad[unsure] + need[unsure] + step)
        lens = np.array([len(b) for b in balls])
        cell = np.repeat(unsure, lens)
        smp = np.concatenate([np.asarray(b, dtype=np.int64) for b in balls])
        dist = _polygon_distance(V[cell], S[smp])
        best = np.full(len(data), np.inf)
        np.minimum.at(best, cell, dist)
        ok[unsure] = best[unsure] >= need[unsure]
    # a pattern is kept whole or dropped whole
    group_ok = np.ones(n_groups, dtype=bool)
    np.logical_and.at(group_ok, group, ok)
    group_portion = np.zeros(n_groups, dtype=bool)
    np.logical_or.at(group_portion, group, portion)
    # corners where retained patterns touch only at a point: drop those patterns
    n = len(pts)
    while True:
        keep = group_ok[group]
        sel = data[keep]
        k = sel.shape[1]
        he = np.concatenate([sel[:, [c, (c + 1) % k]] for c in range(k)])
        fwd = he[:, 0] * n + he[:, 1]
        rev = he[:, 1] * n + he[:, 0]
        bnd = he[~np.isin(fwd, rev)]
        out = np.bincount(bnd[:, 0], minlength=n)
        pinch = out > 1
        if not pinch.any():
            break
        hit = np.flatnonzero(keep)[pinch[sel].any(axis=1)]
        group_ok[group[hit]] = False
    kept = data[group_ok[group]]
    if progress is not None:
        progress(0.3, "pattern: meshing the gap")
    if len(kept) == 0:
        raise InputError(
            "no pattern lies far enough inside the domain: make the pattern finer or the "
            "margin smaller",
            loc=("pattern",),
            code="no_pattern_kept",
        )
    mesh, gstats = fill_gap(dom, pts, [(blocks[0][0], kept)], h, gap=gap, smooth=gap == "quads")
    stats = {
        "steps": {
            "i": int(group_portion.sum()),
            "ii": int(group_ok.sum()),
            "iii": int(gstats["gap_triangles"]),
            "iv": int(mesh.n_cells),
        },
        "pattern_cells": gstats["pattern_cells"],
        "gap_cells": gstats["gap_cells"],
        "loops": gstats["loops"],
        "gap_size": h,
    }
    P = mesh.points
    rel = P - P.min(axis=0)
    area_of = {}
    quality = {}
    for b in mesh.cells:
        R = rel[b.data]
        kk = b.data.shape[1]
        a = 0.5 * sum(
            R[:, c, 0] * R[:, (c + 1) % kk, 1] - R[:, (c + 1) % kk, 0] * R[:, c, 1]
            for c in range(kk)
        )
        area_of[b.type] = a
        q = quad_quality(P, b.data) if b.type == "quad" else triangle_shape(P, b.data)
        quality[b.type] = {"min": float(q.min()), "mean": float(q.mean())}
    pattern_area = math.fsum(
        float(area_of[b.type][ids].sum())
        for b, ids in zip(mesh.cells, mesh.cell_sets["pattern"], strict=True)
    )
    stats.update(
        quality=quality,
        pattern_area_share=pattern_area / dom.area,
        area=math.fsum(float(a.sum()) for a in area_of.values()),
        domain_area=dom.area,
        quads=int(sum(len(b) for b in mesh.cells if b.type == "quad")),
        triangles=int(sum(len(b) for b in mesh.cells if b.type == "triangle")),
    )
    mesh = Mesh(P, mesh.cells, cell_sets=mesh.cell_sets)
    return GridResult(mesh=mesh, stats=stats, timings={"total": time.process_time() - t0})
