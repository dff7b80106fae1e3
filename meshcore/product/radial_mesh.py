r"""Radial meshes of a disk, a ring or a sector (§8.7.1, Figure 8.16).

The classical radial mesh (Figure 8.16, left) is a product mesh: a segment
from ``inner_radius`` to ``outer_radius`` cut into ``radial_layers``, turned
about the centre through ``angle`` in ``segments`` steps
(:func:`meshcore.product.extrusion` with a rotation). Every ring then carries
``segments`` edges, so the cells near the centre are thin slivers; with
``inner_radius = 0`` the centre is one vertex and the innermost cells are
triangles (the quad -> triangle degeneracy of §8.1.1).

The balanced variant (Figure 8.16, right; Hecht and Saltel) collapses ring
edges so that the number of subdivisions varies from ring to ring and the
cells keep their size. We build the collapsed mesh directly:

- ring ``j`` (radius ``r_j``, equally spaced) keeps ``n_j`` of the
  ``segments`` edges, ``n_j`` the count whose arcs come closest to the
  radial spacing ``h``: ``round(angle r_j / h)``, at least 3 on a full ring
  (1 on a sector), at most ``segments``, and never more than the next ring
  out; the outermost ring keeps all ``segments``. A ring whose count is
  within a factor 1.5 of the next ring's keeps that count (no collapse
  there), so the count changes only where the sizes would drift apart;
- its vertices are spread evenly over the angle (the collapsed vertices are
  re-spaced, the smoothing step that follows a collapse);
- the band between rings with ``n`` and ``N >= n`` edges gets ``n`` quads
  and ``N - n`` triangles, the triangles spread evenly along the band
  (Bresenham): "quads, with triangles only where the count changes".
  Around the centre of a disk the band is a fan of triangles.

Both cover the same polygonal region when the inner ring keeps its count:
the polygon with ``segments`` edges on the outer circle minus the inner
ring's polygon (areas ``n r² sin(angle / n) / 2`` for ``n`` edges on radius
``r``). With ``balance`` the inner ring of an annulus may be collapsed too;
``ring_segments`` says how many edges each ring kept.

Output: 2D points (x, y); cells ``quad`` (and ``triangle``), counterclockwise;
boundary ``line`` blocks in the cell sets ``outer``, ``inner`` (when
``inner_radius > 0``) and, for a sector (``angle < 360``), ``start`` and
``end`` (the radial sides at angle 0 and ``angle``). Cell data ``ring``: the
band of each cell (0 innermost), of each boundary line its ring's band.

References
----------
Methods text §8.7.1 (Figure 8.16); §8.1.1 (degeneracies); F. Hecht and E.
Saltel, "Emc2: un logiciel d'édition de maillages et de contours
bidimensionnels", INRIA report 118 (1990).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from meshcore.errors import InputError
from meshcore.geometry.tolerances import MAX_COORDINATE, MIN_DIAMETER, TOLERANCES
from meshcore.mesh import CellBlock, Mesh, quality, topology
from meshcore.product.extrusion import Rotate, extrude

__all__ = ["RadialResult", "radial"]

Progress = Callable[[float, str], None] | None

#: A ring keeps the next ring's count while its ideal count is at least this fraction of it.
KEEP_RATIO = 1 / 1.5


@dataclass(frozen=True, eq=False)
class RadialResult:
    """A radial mesh and the classical mesh it was balanced from.

    Attributes
    ----------
    mesh : Mesh
    ring_segments : (radial_layers + 1,) int64
        Edges on each ring, innermost first (0 for the centre of a disk).
    classical_quality : dict or None
        With ``balance``, :func:`meshcore.mesh.quality.report` of the classical
        product mesh with the same parameters ("before"); ``None`` otherwise.
    """

    mesh: Mesh
    ring_segments: np.ndarray
    classical_quality: dict | None = None

    def stats(self) -> dict:
        counts: dict[str, int] = {}
        for block in self.mesh.cells:
            counts[block.type] = counts.get(block.type, 0) + len(block)
        out = {
            "points": len(self.mesh.points),
            "cells": counts,
            "ring_segments": self.ring_segments.tolist(),
        }
        if self.classical_quality is not None:
            out["quality_before"] = self.classical_quality
        return out


def _number(value, name: str, *, low: float, strict: bool, high: float | None = None) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    ok = math.isfinite(x) and (x > low if strict else x >= low) and (high is None or x <= high)
    if not ok:
        bound = f"{'>' if strict else '>='} {low:g}" + (f" and <= {high:g}" if high else "")
        raise InputError(
            f"{name} must be a finite number {bound}, got {value!r}", loc=(name,), code="bad_value"
        )
    return x


def _count(value, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
        raise InputError(
            f"{name} must be an integer >= {low}, got {value!r}", loc=(name,), code="bad_value"
        )
    return int(value)


def _checked(center, inner_radius, outer_radius, angle, radial_layers, segments):
    try:
        c = np.asarray(center, dtype=np.float64)
    except (TypeError, ValueError):
        c = np.full(0, np.nan)
    if c.shape != (2,) or not np.isfinite(c).all():
        raise InputError("center must be 2 finite numbers", loc=("center",), code="bad_value")
    r0 = _number(inner_radius, "inner_radius", low=0.0, strict=False)
    r1 = _number(outer_radius, "outer_radius", low=r0, strict=True)
    a = _number(angle, "angle", low=0.0, strict=True, high=360.0)
    layers = _count(radial_layers, "radial_layers", 1)
    n = _count(segments, "segments", 3 if a == 360 else 1)
    if r1 < MIN_DIAMETER:
        raise InputError(
            f"outer_radius {r1:g} is below {MIN_DIAMETER:g} (squared radii underflow float64)",
            loc=("outer_radius",),
            code="out_of_range",
        )
    reach = float(np.abs(c).max()) + r1
    if reach > MAX_COORDINATE:
        raise InputError(
            f"the mesh would reach coordinate magnitude {reach:.3g}, beyond {MAX_COORDINATE:g}",
            loc=("center",) if np.abs(c).max() > r1 else ("outer_radius",),
            code="out_of_range",
        )
    # the closest two vertices: on a radial line, or on the innermost ring with n vertices
    radial = (r1 - r0) / layers
    inner = r0 if r0 > 0 else radial
    spacing = min(radial, inner * math.radians(a) / n)
    if not spacing > TOLERANCES.coincident * reach:
        raise InputError(
            f"vertices {spacing:.3g} apart cannot be told apart at distance {reach:.3g} from the "
            "origin: give a larger radius, fewer layers or segments, or a centre nearer 0",
            loc=(_closest_cause(spacing, radial, r0, r1, a),),
            code="out_of_range",
        )
    return c, r0, r1, a, layers, n


def _closest_cause(spacing: float, radial: float, r0: float, r1: float, a: float) -> str:
    """The parameter that brings two vertices within rounding: the centre when they would be
    apart at the origin; else the inner radius of a ring shorter than a layer, the outer
    radius of a band too thin for its layers, the segments or a sliver of an angle."""
    if spacing > TOLERANCES.coincident * r1:
        return "center"
    if spacing == radial:
        return "outer_radius"
    if 0 < r0 < radial:
        return "inner_radius"
    return "segments" if a >= 1 else "angle"


def _classical(c, r0, r1, angle, layers, n) -> Mesh:
    """The product mesh of Figure 8.16 (left), by extruding the radial segment."""
    r = np.linspace(r0, r1, layers + 1)
    segment = Mesh(
        np.column_stack([r, np.zeros_like(r)]),
        [("line", np.column_stack([np.arange(layers), np.arange(1, layers + 1)]))],
    )
    res = extrude(segment, Rotate([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], angle, n))
    m = res.mesh
    pts = m.points[:, :2]
    swept = [i for i, b in enumerate(m.cells) if b.type in ("quad", "triangle")]
    # which band each cell is in: its source segment
    cells = tuple(m.cells[i] for i in swept)
    ring = [m.cell_data["source_cell"][i] for i in swept]
    return _with_boundary(pts, list(cells), ring, c, r0, r1, angle)


def _ring_counts(r: np.ndarray, angle_rad: float, n_out: int, full: bool) -> np.ndarray:
    h = r[1] - r[0]
    low = 3 if full else 1
    counts = np.empty(len(r), dtype=np.int64)
    counts[-1] = n_out
    for j in range(len(r) - 2, -1, -1):  # inward, ring by ring (each bounded by the next)
        if r[j] == 0:
            counts[j] = 0
            continue
        ideal = angle_rad * r[j] / h
        nxt = counts[j + 1]
        counts[j] = nxt if ideal >= KEEP_RATIO * nxt else min(nxt, max(low, round(ideal)))
    return counts


def _balanced(c, r0, r1, angle, layers, n):
    full = angle == 360
    arad = math.radians(angle)
    r = np.linspace(r0, r1, layers + 1)
    counts = _ring_counts(r, arad, n, full)
    # vertices ring by ring; a full ring has n of them, a sector n + 1, the centre 1
    nv = np.where(counts == 0, 1, counts + (0 if full else 1))
    first = np.concatenate([[0], np.cumsum(nv)])
    pts = []
    for j in range(len(r)):
        if counts[j] == 0:
            pts.append(np.zeros((1, 2)))
            continue
        t = arad * np.arange(nv[j]) / counts[j]
        pts.append(r[j] * np.column_stack([np.cos(t), np.sin(t)]))
    pts = np.concatenate(pts)

    def vid(j: int, i: np.ndarray) -> np.ndarray:
        if counts[j] == 0:
            return np.full(len(i), first[j])
        return first[j] + (i % counts[j] if full else i)

    quads, tris, qring, tring = [], [], [], []
    for j in range(layers):  # band between ring j and ring j + 1
        lo, hi = counts[j], counts[j + 1]
        s = np.arange(hi)
        # inner index before outer step s; it advances on lo of the hi steps, spread evenly
        i0 = np.floor(s * lo / hi + 0.5).astype(np.int64) if lo else np.zeros(hi, np.int64)
        i1 = np.floor((s + 1) * lo / hi + 0.5).astype(np.int64) if lo else i0
        q = i1 > i0
        a, b = vid(j, i0), vid(j + 1, s)
        cq, dq = vid(j + 1, s + 1), vid(j, i1)
        quads.append(np.column_stack([a, b, cq, dq])[q])
        tris.append(np.column_stack([a, b, cq])[~q])
        qring.append(np.full(int(q.sum()), j))
        tring.append(np.full(int((~q).sum()), j))
    blocks, ring = [], []
    for t, cells, rr in (("quad", quads, qring), ("triangle", tris, tring)):
        data = np.concatenate(cells)
        if len(data):
            blocks.append(CellBlock(t, data))
            ring.append(np.concatenate(rr))
    return _with_boundary(pts, blocks, ring, c, r0, r1, angle), counts


def _with_boundary(pts, blocks, ring, c, r0, r1, angle) -> Mesh:
    """Add the boundary lines (sets outer, inner, start, end) to the cells of a radial mesh
    whose points ``pts`` are relative to the centre; the mesh is moved to ``c`` last, so
    that the classification does not depend on where the centre lies.

    A boundary line is ``outer`` (``inner``) when both its ends lie on the
    outer (inner) circle, else ``start`` when both lie on the ray at angle
    0, else ``end``.
    """
    bnd = topology.boundary(Mesh(pts, tuple(blocks)))
    lines, holder = bnd.cells[0].data, bnd.cell_data["cell"][0]
    rel = pts
    radius = np.linalg.norm(rel, axis=1)
    tol = TOLERANCES.coincident * 2 * r1
    outer = np.all(np.abs(radius[lines] - r1) <= tol, axis=1)
    inner = np.all(np.abs(radius[lines] - r0) <= tol, axis=1) & ~outer & (r0 > 0)
    kinds = {"outer": outer, "inner": inner}
    if angle < 360:
        start = np.all(np.abs(rel[lines, 1]) <= tol, axis=1) & np.all(rel[lines, 0] >= -tol, axis=1)
        kinds["start"] = start & ~outer & ~inner
        kinds["end"] = ~start & ~outer & ~inner
    names = [k for k in kinds if kinds[k].any()]
    cell_ring = np.concatenate(ring)
    order = [lines[kinds[k]] for k in names]
    starts = np.cumsum([0] + [len(o) for o in order])
    nb = len(blocks)
    sets = {
        k: [np.zeros(0, np.int64)] * nb + [np.arange(starts[i], starts[i + 1])]
        for i, k in enumerate(names)
    }
    line_ring = np.concatenate([cell_ring[holder[kinds[k]]] for k in names])
    return Mesh(
        pts + c,
        (*blocks, CellBlock("line", np.concatenate(order))),
        cell_data={"ring": [*ring, line_ring]},
        cell_sets=sets,
    )


def radial(
    center: Sequence[float] = (0.0, 0.0),
    inner_radius: float = 0.0,
    outer_radius: float = 1.0,
    angle: float = 360.0,
    radial_layers: int = 8,
    segments: int = 32,
    *,
    balance: bool = False,
    progress: Progress = None,
) -> RadialResult:
    """A radial mesh of a disk, ring or sector (§8.7.1).

    Parameters
    ----------
    center : (2,) float64
    inner_radius : float
        0 for a full disk (or a sector of one).
    outer_radius : float
        Greater than ``inner_radius``.
    angle : float
        In degrees, in ``(0, 360]``; 360 closes the ring.
    radial_layers : int
        Bands between the inner and the outer circle (equal spacing).
    segments : int
        Edges on the outer ring (at least 3 for a full ring).
    balance : bool
        Collapse ring edges so that sizes stay balanced (Figure 8.16, right);
        see the module docstring.
    progress : callable(fraction, message), optional

    Returns
    -------
    RadialResult

    Raises
    ------
    InputError
        ``bad_value`` naming the parameter; ``out_of_range`` when the mesh would
        reach beyond ``MAX_COORDINATE``, the outer radius is below
        ``MIN_DIAMETER``, or two vertices would be closer than the coincidence
        tolerance at the mesh's distance from the origin.

    References
    ----------
    §8.7.1, Figure 8.16.
    """
    c, r0, r1, a, layers, n = _checked(
        center, inner_radius, outer_radius, angle, radial_layers, segments
    )
    if progress is not None:
        progress(0.0, "classical radial mesh")
    classical = _classical(c, r0, r1, a, layers, n)
    if not balance:
        counts = np.full(layers + 1, n, dtype=np.int64)
        if r0 == 0:
            counts[0] = 0
        return RadialResult(classical, counts)
    if progress is not None:
        progress(0.4, "balancing the ring counts")
    before = quality.report(classical)
    mesh, counts = _balanced(c, r0, r1, a, layers, n)
    if progress is not None:
        progress(1.0, "radial mesh done")
    return RadialResult(mesh, counts, before)
