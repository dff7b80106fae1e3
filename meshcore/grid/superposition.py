"""All-quad meshes by grid superposition: ``quad_grid`` (§8.5.2).

"One follows an idea close to that seen in the section devoted to mesh
construction by means of a grid" (§8.5.2, §8.2): a grid of squares is laid
over the domain, the cells well inside it are kept, and the band between
their outline and the domain boundary is filled with quads so that the
whole mesh is quads.

Steps
-----
1. **Core.** A grid of side ``size`` (origin the lower-left corner of the
   domain's bounding box). The core keeps the cells with four inside corners
   (exact tests) and no boundary or constraint segment within ``layers``
   cells (the cells around segment samples, and ``layers`` rings of
   neighbours), minus the cells around nodes where two core cells meet at a
   corner only, so its outline is simple loops, each oriented with the core
   on its left.
2. **Projection** (the band, ``layers`` quads thick). Each outline loop is
   paired with the domain ring it faces (the ring nearest to all of its
   nodes; the pairing must be one to one). Every outline node sends *lines*
   into the band, one per band node it gets on the boundary:

   * a straight node or a *reflex* corner of the core (the band's angle
     there is 90°): one line along the outline's normal averaged over
     ``NORMAL_SPAN`` edges on either side (at a corner, with no averaging,
     the bisector of the two edge normals), so the staircase's steps send
     their lines along the boundary's normal rather than at 45°;
   * a *salient* corner of the core (band angle 270°): one line likewise,
     so the two quads beside it share the corner's 270°; when a sharp
     convex corner of the ring (turning by more than 60°) is nearest to this
     node, the *corner pattern* instead: three lines (the two edge normals
     and the bisector) and a corner quad (node, three line ends), the
     middle line ending at the domain's corner, so that the corner gets a
     quad of its own rather than a flat angle.

   Each line aims at the closest boundary point to the node pushed along its
   direction by its distance to the boundary, which gives a parameter
   (arc length) per line. The parameters are unwrapped around the ring and
   made non-decreasing; each ring vertex is then given a line of its own:
   the nearest, increasing (so every input corner is a mesh vertex, and every
   input segment a chain of edges). The other lines end on the input segment
   between their two anchors, halfway between their projection and an even
   spacing (strictly increasing). Layer ``k`` of a line is at ``k / layers``
   of the way from the node to its end, and the quads join consecutive lines
   layer by layer (the corner quad in the first layer, two quads in each
   following one). **Repair**: a quad between two lines that is not strictly
   convex (an end pulled sideways by its anchor) first gets even spacing
   between the anchors around it, then the move by one line of a nearby
   anchor (pushing the next anchors along) that lowers the count of such
   quads, for ``REPAIR_ROUNDS`` rounds.
3. **Check.** Every band quad must be strictly convex at its four corners
   (exact :func:`~meshcore.geometry.predicates.orient2d`). Then, the band
   being a strip of cells glued along the outline, positively oriented, with
   its outer chain running once along the ring, the mesh covers the domain
   exactly once.
4. ``smooth``: the band and the two rings of core squares along it are
   optimized by :func:`meshcore.quads.optimization.optimize_quads` (the
   operators of §8.4.3, which move valences towards 4, and a smoothing that
   never inverts a cell nor lowers the least quality), the domain boundary
   and the squares beyond staying fixed.

**Refused up front.** The fallback triangulates the band (at least every
ring vertex, and what the angle bound forces where the boundary runs close
to itself: :func:`meshcore.triangulation.estimated_triangles` without
sizes, a strip of width ``w`` and length ``L`` about ``2 L / w`` triangles
whatever the size), then combines and optimizes about three quads per
triangle, some 15k quads a CPU second. Where it would take more than
:data:`MAX_FALLBACK_TRIANGLES` (a 1 x 1e-5 strip; a ring of more than 50k
vertices that the projection cannot follow), ``quad_grid`` raises
``InputError`` ``too_many_cells`` at ``domain`` before triangulating,
naming the reason the projection failed and the estimate: a user waiting
for a mesh gets the reason in milliseconds rather than a time limit
(a 1 x 1e-6 strip ran past 60 s); ``triangulate`` meshes such domains.

**Fallback.** Where the projection does not apply (a loop and a ring not one
to one: narrow parts, holes closer than the band's width to each other or to
the outer ring, constraint segments; a ring with more vertices than lines; a
non-monotone projection; a band quad not strictly convex), the whole band is
built by :func:`meshcore.grid.band.fill_gap` on a grid of side ``2 size``:
triangulated with the core's outline kept, the triangles combined and split
into quads (:func:`meshcore.quads.combination.combine` with ``all_quad``),
and the core's squares split in four. ``stats["band"]`` says which route was
taken and ``stats["fallback"]`` why.

Either way the result is only quads, conforming, covering the domain exactly
(area to rounding), every input vertex a mesh vertex, every quad strictly
convex.

Choices the text leaves open
----------------------------
* The text names no projection rule; the closest point, after a push along
  the line's direction, is the one that keeps lines from a convex corner
  apart (the plain closest point sends them all to one point).
* Salient corners facing a smooth part of the boundary take one line only:
  the corner pattern there would put a flat angle (180°) in its corner quad.

References
----------
Methods text §8.5.2 (grid superposition), §8.2 (grids and patterns),
§8.4.3 (optimization), Remark 8.3.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import Domain
from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d
from meshcore.grid import cartesian
from meshcore.grid.band import _outline, fill_gap, outline_loops
from meshcore.grid.cartesian import (
    MAX_CELLS,
    GridResult,
    Progress,
    _as_domain,
    _cell_seg_pairs,
    _drop_pinches,
    _extent,
    _Frame,
    _inside_rows,
    _number,
    _quad_jacobian,
    _samples,
    _smallest_distance,
)
from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.quality import quad_quality
from meshcore.quads.combination import combine
from meshcore.quads.optimization import optimize_quads
from meshcore.triangulation import estimated_triangles

__all__ = ["check_band", "quad_grid"]

#: A ring vertex turning by more than 60 degrees (cosine of the turn below
#: this) is a sharp convex corner: it gets the corner pattern.
SHARP_COS = 0.5
#: Edges on either side over which the outline's normal is averaged.
NORMAL_SPAN = 3
#: Weight of the even spacing in a line's end (the rest: its projection).
UNIFORM = 0.2
#: Rounds of anchor moves repairing quads that are not strictly convex.
REPAIR_ROUNDS = 4
#: Rings of core squares optimized with the band.
SMOOTH_RINGS = 2
#: The fallback is refused above this many estimated band triangles (module docstring).
MAX_FALLBACK_TRIANGLES = 100_000
# ----------------------------------------------------------------------------- projection


def _ring_vertices(dom: Domain, k: int) -> np.ndarray:
    """Ring ``k``'s vertex ids in order with the domain on the left."""
    ids = np.arange(int(dom.ring_offsets[k]), int(dom.ring_offsets[k + 1]))
    return ids[::-1] if dom.ring_reversed[k] else ids


def _closest_params(V: np.ndarray, cum: np.ndarray, q: np.ndarray, step: float) -> np.ndarray:
    """Arc-length parameter of the closest point of the closed polyline ``V`` to each ``q``."""
    W = np.roll(V, -1, axis=0)
    samples, seg = _samples(
        np.concatenate([V, W]),
        np.column_stack([np.arange(len(V)), len(V) + np.arange(len(V))]),
        step,
    )
    _, near = cKDTree(samples).query(q)
    g = seg[near]
    best = np.full(len(q), np.inf)
    par = np.zeros(len(q))
    m = len(V)
    for dg in (-1, 0, 1):
        s = (g + dg) % m
        a, d = V[s], W[s] - V[s]
        dd = np.maximum((d * d).sum(axis=1), 1e-300)
        t = np.clip(((q - a) * d).sum(axis=1) / dd, 0.0, 1.0)
        dist = np.hypot(*(a + t[:, None] * d - q).T)
        better = dist < best
        best = np.where(better, dist, best)
        par = np.where(better, cum[s] + t * (cum[s + 1] - cum[s]), par)
    return par


def _pair_loops(dom: Domain, P: np.ndarray, loops: list[np.ndarray], h: float):
    """Each core loop with the domain ring it faces, or None when they are not one to one."""
    R = dom.ring_count
    if len(loops) != R or len(dom.constraints):
        return None
    ring_of = np.repeat(np.arange(R), np.diff(dom.ring_offsets))
    q, s = _samples(dom.points, dom.segments, 0.25 * h)
    tree = cKDTree(q)
    pairs = {}
    for li, loop in enumerate(loops):
        _, near = tree.query(P[loop])
        k = np.bincount(ring_of[s[near]], minlength=R)
        r = int(np.argmax(k))
        if k[r] != len(loop) or r in pairs:
            return None
        pairs[r] = li
    return [(r, loops[pairs[r]]) for r in range(R)]


def _loop_band(V, C, h, sharp_cos):
    """One ring of the band: the core loop ``C`` (core on its left) projected onto ``V``.

    Returns ``node`` (the outline node of each line, in order), ``template``
    (per node: whether it takes the corner pattern) and ``B`` (each line's
    end on the ring), or None when the projection does not give a monotone
    correspondence with a line for every ring vertex.
    """
    m = len(C)
    K = len(V)
    W = np.roll(V, -1, axis=0)
    lens = np.hypot(*(W - V).T)
    cum = np.concatenate([[0.0], np.cumsum(lens)])
    total = cum[-1]
    ein = C - np.roll(C, 1, axis=0)
    eout = np.roll(C, -1, axis=0) - C
    nin = np.column_stack([ein[:, 1], -ein[:, 0]]) / h  # towards the band (right side)
    nout = np.column_stack([eout[:, 1], -eout[:, 0]]) / h
    turn = ein[:, 0] * eout[:, 1] - ein[:, 1] * eout[:, 0]
    # the outline's normal smoothed over NORMAL_SPAN edges on either side: the
    # staircase's steps then send their lines along the boundary's normal
    bis = nin + nout
    for k in range(1, NORMAL_SPAN):
        bis = bis + np.roll(nin, k, axis=0) + np.roll(nout, -k, axis=0)
    bis /= np.maximum(np.hypot(*bis.T), 1e-300)[:, None]
    flat = np.hypot(*bis.T) < 0.5  # opposite normals cancel: fall back on the corner's
    bis[flat] = (nin + nout)[flat] / np.maximum(np.hypot(*(nin + nout)[flat].T), 1e-300)[:, None]
    # sharp convex corners of the ring take a corner quad at the nearest salient node
    vin = V - np.roll(V, 1, axis=0)
    vout = W - V
    cosang = (vin * vout).sum(axis=1) / np.maximum(np.hypot(*vin.T) * np.hypot(*vout.T), 1e-300)
    vturn = vin[:, 0] * vout[:, 1] - vin[:, 1] * vout[:, 0]
    sharp = np.flatnonzero((vturn > 0) & (cosang < sharp_cos))
    template = np.zeros(m, dtype=bool)
    corner_of = np.zeros(m, dtype=np.int64)
    if len(sharp):
        _, near = cKDTree(C).query(V[sharp])
        ok = turn[near] > 0
        template[near[ok]] = True
        corner_of[near[ok]] = sharp[ok]
    # lines: per node, its directions (template nodes: in-normal, bisector, out-normal)
    reps = np.where(template, 3, 1)
    node = np.repeat(np.arange(m), reps)
    first = np.cumsum(reps) - reps
    sub = np.arange(len(node)) - np.repeat(first, reps)
    dirs = bis[node].copy()
    tn = template[node]
    dirs[tn & (sub == 0)] = nin[node[tn & (sub == 0)]]
    dirs[tn & (sub == 2)] = nout[node[tn & (sub == 2)]]
    M = len(node)
    if K > M:
        return None
    dist, _ = cKDTree(
        _samples(
            np.concatenate([V, W]), np.column_stack([np.arange(K), K + np.arange(K)]), 0.25 * h
        )[0]
    ).query(C)
    # pushed by the distance to the boundary, measured along the outline's normals
    push = dist[node] / np.maximum((dirs * bis[node]).sum(axis=1), 0.5)
    q = C[node] + push[:, None] * dirs
    t = _closest_params(V, cum, q, 0.25 * h)
    # a corner pattern's middle line ends at its corner, the other two on either side
    mid = np.flatnonzero(tn & (sub == 1))
    tc = cum[corner_of[node[mid]]]
    t[mid] = tc
    half = 0.5 * total
    t[mid - 1] = tc - np.maximum((tc - t[mid - 1] + half) % total - half, 0.25 * h)
    t[mid + 1] = tc + np.maximum((t[mid + 1] - tc + half) % total - half, 0.25 * h)
    d = np.diff(np.concatenate([t, t[:1]]))
    d = (d + 0.5 * total) % total - 0.5 * total
    if abs(d.sum() - total) > 0.25 * total:
        return None
    t = t[0] + np.concatenate([[0.0], np.cumsum(d[:-1])])
    t = np.maximum.accumulate(t)
    # every ring vertex is the end of a line: the nearest line, increasing
    S = cum[:-1].copy()
    S = np.where(S < t[0], S + total, S)
    order = np.argsort(S, kind="stable")
    S = S[order]
    idx = np.clip(np.searchsorted(t, S), 1, M - 1)
    j = np.where(np.abs(t[idx - 1] - S) <= np.abs(t[idx] - S), idx - 1, idx)
    ks = np.arange(K)
    j = np.maximum.accumulate(j - ks) + ks
    j = np.minimum(j, M - K + ks)
    if j[0] < 0 or (np.diff(j) <= 0).any():
        return None
    u = np.full(M, UNIFORM)  # weight of the even spacing, per line
    B = _ends(V, W, t, j, order, total, u)
    # repair: a quad not strictly convex moves a neighbouring anchor by one line,
    # pushing the next anchors along when they are on consecutive lines
    ks = np.arange(K)
    nbad = int(_bad_pairs(C, node, B).sum())
    for _ in range(REPAIR_ROUNDS):
        if nbad == 0:
            break
        for a in np.flatnonzero(_bad_pairs(C, node, B)):
            # first, even spacing between the two anchors around the pair
            lo = j[(np.searchsorted(j, a, side="right") - 1) % K]
            span = (np.arange(M) - lo) % M
            uu = np.where(span <= (j[np.searchsorted(j, a, side="right") % K] - lo) % M, 1.0, u)
            BB = _ends(V, W, t, j, order, total, uu)
            nb = int(_bad_pairs(C, node, BB).sum())
            if nb < nbad:
                u, B, nbad = uu, BB, nb
                continue
            best = None
            for kk in np.flatnonzero(np.abs(((j - a + 1) % M) - 1.5) <= 1.5):
                for step in (-1, 1):
                    jj = j.copy()
                    jj[kk] += step
                    if step < 0:
                        jj[:kk] = np.minimum(jj[:kk], jj[kk] - kk + ks[:kk])
                    else:
                        jj[kk:] = np.maximum(jj[kk:], jj[kk] + ks[: K - kk])
                    if jj[0] < 0 or jj[-1] >= jj[0] + M:
                        continue
                    BB = _ends(V, W, t, jj, order, total, u)
                    nb = int(_bad_pairs(C, node, BB).sum())
                    if nb < nbad:
                        best, nbad = (jj, BB), nb
            if best is not None:
                j, B = best
    return node, template, B


def _ends(V, W, t, j, order, total, u):
    """Line ends: anchors at their ring vertex, the others on the segment between anchors."""
    M, K = len(t), len(j)
    ja = np.concatenate([j, [j[0] + M]])
    tt = np.maximum.accumulate(np.concatenate([t, t[: j[0] + 1] + total]))
    line = np.arange(j[0], j[0] + M)
    seg = np.searchsorted(ja, line, side="right") - 1
    a, b = ja[seg], ja[seg + 1]
    uni = (line - a) / (b - a)
    span = tt[b] - tt[a]
    proj = np.where(span > 0, (tt[line] - tt[a]) / np.where(span > 0, span, 1.0), uni)
    uu = u[line % M]
    w = (1 - uu) * np.clip(proj, 0.0, 1.0) + uu * uni
    vid = order[seg % K]  # ring vertex at the start of this line's interval
    end = V[vid] + w[:, None] * (W[vid] - V[vid])
    end[w == 0] = V[vid[w == 0]]
    line = line % M
    B = np.empty((M, 2))
    B[line] = end
    return B


def _bad_pairs(C, node, B):
    """Whether the quad between line ``a`` and line ``a + 1`` is not strictly convex."""
    M = len(node)
    a = np.arange(M)
    b = (a + 1) % M
    q = [C[node[a]], B[a], B[b], C[node[b]]]
    ok = np.ones(M, dtype=bool)
    for c in range(4):
        ok &= orient2d(q[c], q[(c + 1) % 4], q[(c + 2) % 4]) > 0
    return ~ok & (node[a] != node[b])


def _paired_loops(dom: Domain, P: np.ndarray, core: np.ndarray, h: float):
    """The core's outline loops paired with the domain's rings (step 2's start), or None and
    the reason the projection cannot apply that the grid alone tells."""
    if not len(core):
        return None, "no grid cell lies far enough inside the domain"
    edges, _, _, _ = _outline([core], len(P))
    pairs = _pair_loops(dom, P, outline_loops(edges, len(P)), h)
    if pairs is None:
        return None, "the outline's loops and the domain's rings are not one to one"
    return pairs, ""


def _projected_band(dom: Domain, P: np.ndarray, pairs: list, h: float, layers: int):
    """The band's points (appended to ``P``) and quads by projecting each paired loop onto
    its ring, or the reason it fails."""
    n = len(P)
    new_pts, quads = [], []
    base = n
    L = layers
    for r, loop in pairs:
        V = dom.points[_ring_vertices(dom, r)]
        C = P[loop]
        got = _loop_band(V, C, h, SHARP_COS)
        if got is None:
            return None, f"ring {r}: no monotone projection with a line for each vertex"
        node, template, B = got
        M = len(node)
        k = np.arange(1, L + 1) / L
        X = C[node][:, None, :] + k[None, :, None] * (B - C[node])[:, None, :]
        X[:, -1] = B
        new_pts.append(X.reshape(-1, 2))

        def ident(line, layer, base=base, loop=loop, node=node):
            return np.where(layer == 0, loop[node[line]], base + line * L + layer - 1)

        a = np.arange(M)
        b = (a + 1) % M
        same = node[a] == node[b]
        for lay in range(L):
            sel = a if lay else a[~same]
            sb = b[sel]
            quads.append(
                np.column_stack(
                    [ident(sel, lay), ident(sel, lay + 1), ident(sb, lay + 1), ident(sb, lay)]
                )
            )
        first = np.flatnonzero(template[node] & ~np.concatenate([[False], same[:-1]]))
        first = first[same[first]]
        if len(first):
            v = loop[node[first]]
            quads.append(
                np.column_stack(
                    [v, ident(first, 1), ident((first + 1) % M, 1), ident((first + 2) % M, 1)]
                )
            )
        base += M * L
    Pn = np.concatenate([P, *new_pts])
    Q = np.concatenate(quads).astype(np.int64)
    for c in range(4):
        turn = orient2d(Pn[Q[:, c]], Pn[Q[:, (c + 1) % 4]], Pn[Q[:, (c + 2) % 4]])
        if not (turn > 0).all():
            return None, "a projected quad is not strictly convex"
    return (Pn, Q), None


def _smoothed(P: np.ndarray, core: np.ndarray, band: np.ndarray):
    """Optimize the band with ``SMOOTH_RINGS`` rings of core squares; the rest stays.

    Returns the points, the untouched squares and the optimized quads.
    """
    n = len(P)
    near = np.zeros(n, dtype=bool)
    near[band.ravel()] = True
    pick = np.zeros(len(core), dtype=bool)
    for _ in range(SMOOTH_RINGS):
        pick |= near[core].any(axis=1)
        near[core[pick].ravel()] = True
    sub = np.concatenate([band, core[pick]])
    gid, local = np.unique(sub, return_inverse=True)
    res = optimize_quads(Mesh(P[gid], (CellBlock("quad", local.reshape(-1, 4)),)))
    keep = res.point_map >= 0
    back = np.empty(int(keep.sum()), dtype=np.int64)
    back[res.point_map[keep]] = gid[keep]
    P = P.copy()
    P[back] = res.mesh.points
    out = res.mesh.cells_by_type["quad"]
    return P, core[~pick], back[out]


def _compact(P: np.ndarray, blocks: list[np.ndarray]):
    used = np.zeros(len(P), dtype=bool)
    for b in blocks:
        used[b.ravel()] = True
    new = np.cumsum(used) - 1
    return P[used], [new[b] for b in blocks]


def _triangulated_band(dom: Domain, h: float, layers: int, smooth: bool):
    """The fallback: the band of a ``2 h`` grid triangulated, combined and split (fill_gap)."""
    H = 2.0 * h
    core, P = _core(dom, H, layers)
    if not len(core):
        res = combine(domain=dom, size=H, all_quad=True, optimize=smooth)
        Q = res.mesh.cells[0].data
        return res.mesh.points, np.zeros((0, 4), np.int64), Q
    mesh, _ = fill_gap(dom, P, [("quad", core)], H, gap="quads", smooth=smooth)
    Q = mesh.cells[0].data
    inner = mesh.cell_sets["pattern"][0]
    rest = np.setdiff1d(np.arange(len(Q)), inner)
    return mesh.points, Q[inner], Q[rest]


def _fallback_estimate(dom: Domain) -> tuple[int, int]:
    """The fallback band's estimated triangles, and those the angle bound forces in thin
    parts."""
    forced = estimated_triangles(dom).triangles
    return forced + 2 * len(dom.points), forced


def _check_fallback(dom: Domain, why: str) -> None:
    """Refuse a fallback band estimated above MAX_FALLBACK_TRIANGLES triangles."""
    est, forced = _fallback_estimate(dom)
    if est > MAX_FALLBACK_TRIANGLES:
        thin = f", {forced:,} of them forced by its thin parts" if forced > len(dom.points) else ""
        raise InputError(
            f"quad_grid cannot project the grid onto this boundary ({why}); its fallback "
            f"would triangulate the band into about {est:,} triangles{thin}, above "
            f"{MAX_FALLBACK_TRIANGLES:,}, and combine them into quads: coarsen the "
            "boundary (fewer ring vertices) or mesh this domain with triangulate",
            loc=("domain",),
            code="too_many_cells",
        )


def _core(dom: Domain, h: float, layers: int):
    """The core squares of a grid of side ``h`` (step 1) and the grid's nodes."""
    o = dom.points.min(axis=0)
    shift, nx, ny = _extent(dom, o, 1.0, 0.0, h)
    frame = _Frame(o, 1.0, 0.0, h, shift)
    L = frame.local(dom.points)
    nx1 = nx + 1
    seg = np.concatenate([dom.segments, dom.constraints])
    cand_cell, _ = _cell_seg_pairs(L, seg, nx, ny, ring=int(layers))
    near = np.zeros(nx * ny, dtype=bool)
    near[cand_cell] = True
    inside = _inside_rows(L, dom.segments, ny + 1, nx1, 0.0)
    core = inside[:-1, :-1] & inside[:-1, 1:] & inside[1:, :-1] & inside[1:, 1:]
    core &= ~near.reshape(ny, nx)
    _drop_pinches(core)
    cj, ci = np.nonzero(core)
    c00 = cj * nx1 + ci
    quads = np.column_stack([c00, c00 + 1, c00 + nx1 + 1, c00 + nx1])
    nodes = np.arange(nx1 * (ny + 1))
    pts = frame.world(np.column_stack([nodes % nx1, nodes // nx1]).astype(np.float64))
    return quads, pts


def _layers(layers) -> int:
    if (
        isinstance(layers, bool)
        or not isinstance(layers, (int, np.integer))
        or not 1 <= layers <= 8
    ):
        raise InputError(
            f"layers must be an integer from 1 to 8, got {layers!r}",
            loc=("layers",),
            code="bad_parameter",
        )
    return int(layers)


def _size(dom: Domain, size, max_cells: int) -> float:
    if size is None:
        h = _smallest_distance(dom.points)
        est = cartesian.estimated_cells(dom, size=h)
        if est > max_cells:
            h *= math.sqrt(est / max_cells) * 1.01
        return h
    h = _number(size, "size")
    if h <= 0:
        raise InputError(f"size must be above 0, got {size!r}", loc=("size",), code="bad_parameter")
    est = cartesian.estimated_cells(dom, size=h)
    if est > max_cells:
        raise InputError(
            f"size {h:g} makes a grid of about {est} cells, more than max_cells={max_cells}",
            loc=("size",),
            code="too_many_cells",
        )
    return h


def quad_grid(
    domain,
    *,
    size: float | None = None,
    layers: int = 1,
    smooth: bool = True,
    max_cells: int = MAX_CELLS,
    progress: Progress = None,
) -> GridResult:
    """All-quad mesh of a planar domain by grid superposition (§8.5.2).

    Guarantees: only quads, each strictly convex (exact orientation of its
    four corners), conforming, covering the domain exactly (area to
    rounding), every input vertex a mesh vertex and every input segment a
    chain of edges.

    Parameters
    ----------
    domain : Domain or dict
        Holes and constraints allowed (constraints take the fallback route).
    size : float, optional
        Grid side: the core's squares' side. Default as :func:`meshcore.grid.grid`.
    layers : int
        Quads across the band by projection, 1 to 8 (the band is about
        ``layers`` to ``layers + 1`` cells wide).
    smooth : bool
        Optimize the band and two rings of squares along it (never inverting
        a cell nor lowering the least quality).
    max_cells : int
        Bound on the grid's bounding box, in cells of ``size``.
    progress : callable(fraction, message), optional

    Returns
    -------
    GridResult
        Only a ``quad`` block; cell sets ``interior`` (untouched squares) and
        ``boundary`` (the band and the optimized squares). ``stats``:
        ``band`` (``projection`` or ``triangulation``), ``fallback`` (why,
        or None), ``quads``, ``interior_squares``, ``band_quads``,
        ``quality`` (least and mean (8.4)), ``min_scaled_jacobian``,
        ``valence4_share`` (interior vertices of valence 4), ``area`` and
        ``domain_area``.

    Raises
    ------
    InputError
        A bad domain (``loc`` under ``domain``), ``size``, ``layers``,
        ``too_many_cells`` (at ``size``: the grid; at ``domain``: a fallback
        band past :data:`MAX_FALLBACK_TRIANGLES`).

    References
    ----------
    Methods text §8.5.2 (module docstring).
    """
    t0 = time.process_time()
    dom = _as_domain(domain)
    layers = _layers(layers)
    h = _size(dom, size, max_cells)
    core, P = _core(dom, h, layers)
    pairs, why = _paired_loops(dom, P, core, h)
    got = None
    if pairs is not None:
        got, why = _projected_band(dom, P, pairs, h, layers)
    if progress is not None:
        progress(0.5, "quad_grid: the band")
    if got is not None:
        P, band = got
        inner = core
        if smooth:
            P, inner, band = _smoothed(P, core, band)
        P, (inner, band) = _compact(P, [inner, band])
        route = "projection"
    else:
        _check_fallback(dom, why)
        P, inner, band = _triangulated_band(dom, h, layers, bool(smooth))
        route = "triangulation"
    Q = np.concatenate([inner, band])
    q = quad_quality(P, Q)
    sj = _quad_jacobian(P, Q)
    rel = P - P.min(axis=0)
    R = rel[Q]
    area = math.fsum(
        0.5 * float((R[:, c, 0] * R[:, (c + 1) % 4, 1] - R[:, (c + 1) % 4, 0] * R[:, c, 1]).sum())
        for c in range(4)
    )
    e = np.sort(np.concatenate([Q[:, [c, (c + 1) % 4]] for c in range(4)]), axis=1)
    ue, cnt = np.unique(e, axis=0, return_counts=True)
    on_border = np.zeros(len(P), dtype=bool)
    on_border[ue[cnt == 1].ravel()] = True
    val = np.bincount(ue.ravel(), minlength=len(P))
    interior = ~on_border & (val > 0)
    n_in = len(inner)
    mesh = Mesh(
        P,
        (CellBlock("quad", Q),),
        cell_sets={"interior": [np.arange(n_in)], "boundary": [np.arange(n_in, len(Q))]},
    )
    stats = {
        "size": h,
        "band": route,
        "fallback": None if route == "projection" else why,
        "quads": int(len(Q)),
        "triangles": 0,
        "interior_squares": int(n_in),
        "band_quads": int(len(Q) - n_in),
        "quality": {"min": float(q.min()), "mean": float(q.mean())},
        "min_scaled_jacobian": float(sj.min()),
        "valence4_share": float((val[interior] == 4).mean()) if interior.any() else 1.0,
        "area": area,
        "domain_area": dom.area,
    }
    return GridResult(mesh=mesh, stats=stats, timings={"total": time.process_time() - t0})


def check_band(
    domain, *, size: float | None = None, layers: int = 1, max_cells: int = MAX_CELLS
) -> None:
    """Raise now the refusal of :func:`quad_grid` that the grid alone decides, if any.

    :func:`quad_grid` refuses (``InputError`` ``too_many_cells`` at
    ``domain``) when the projection does not apply and the fallback band
    would be past :data:`MAX_FALLBACK_TRIANGLES`. The estimate depends on the
    domain only; whether the projection applies is known from the grid (step
    1) when no square lies far enough inside or the core's loops and the
    domain's rings are not one to one, and otherwise only by projecting.
    This raises exactly the error :func:`quad_grid` raises in the first two
    cases (and the errors of a bad ``domain``, ``size`` or ``layers``), and
    returns None otherwise: the service calls it before queueing a job. It
    costs the estimate, plus the grid's core (linear in its cells) when the
    estimate is past the bound.

    References
    ----------
    Methods text §8.5.2 (module docstring, "Refused up front").
    """
    dom = _as_domain(domain)
    layers = _layers(layers)
    h = _size(dom, size, max_cells)
    if _fallback_estimate(dom)[0] <= MAX_FALLBACK_TRIANGLES:
        return
    core, P = _core(dom, h, layers)
    pairs, why = _paired_loops(dom, P, core, h)
    if pairs is None:
        _check_fallback(dom, why)
