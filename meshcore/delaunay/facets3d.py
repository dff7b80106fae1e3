"""The facets' 2D triangulations of boundary recovery (:mod:`meshcore.delaunay.recovery3d`).

After a split, every facet whose point set changed is triangulated again in
its plane (§9.3: the subfaces are the 2D Delaunay triangles of the facet's
points that lie in it). These are the compiled passes of
:meth:`~meshcore.delaunay.recovery3d.SurfaceRecovery.retriangulate` over all
changed facets at once: gathering each facet's points (:func:`_facet_points`),
their 2D Delaunay triangulations (:func:`triangulate_facets`, our 2D kernel's
own passes, facet after facet in one call, the triangles those of
:func:`meshcore.delaunay.kernel2d.delaunay` row for row) and the triangles
kept as subfaces (:func:`_facet_subfaces`).

References
----------
Methods text §9.1 (the 2D kernel), §9.3 (faces), §9.3.5.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.delaunay.hashgrid import _find, _shift, _table
from meshcore.delaunay.kernel2d import (
    _CHUNK,
    _COLLINEAR,
    _DUPLICATE,
    _HILBERT_BITS,
    _MIN_SCALED,
    IncrementalDelaunay,
    _brio_hilbert_keys,
    _gather,
    _insert_range,
    _insertion_order,
    _output,
    _scan,
    _start,
    _walk_hints,
)
from meshcore.errors import InputError
from meshcore.geometry.predicates import WORK_SIZE

#: Status of a facet in :func:`triangulate_facets` (0: triangulated): the 2D kernel's
#: error (raised again by :func:`meshcore.delaunay.kernel2d.delaunay` on that facet).
FAILED = 1
#: A facet of at least this many points keeps its 2D triangulation between calls
#: (:class:`KeptTriangulations`); smaller ones are triangulated anew.
KEEP_FROM = 2048


@njit(cache=True)
def _facet_points(
    facets, bptr, bu, be, bl, bfwd, lptr, lonely, by_edge, edge_bounds, by_facet,
    facet_bounds, seg_order, seg_bounds,
):  # fmt: skip
    """The points of each facet to triangulate (CSR over ``facets``): its boundary
    loops (each input edge's first vertex, then the points on the edge in the
    loop's direction), then its corners on no loop and the points inside it;
    with each point's loop and rank along the boundary (-1 inside), and the
    subsegments of its boundary edges (CSR)."""
    K = facets.shape[0]
    ptr = np.zeros(K + 1, np.int64)
    sptr = np.zeros(K + 1, np.int64)
    for k in range(K):
        f = facets[k]
        n = lptr[f + 1] - lptr[f] + facet_bounds[f + 1] - facet_bounds[f]
        ns = 0
        for q in range(bptr[f], bptr[f + 1]):
            e = be[q]
            n += 1 + edge_bounds[e + 1] - edge_bounds[e]
            ns += seg_bounds[e + 1] - seg_bounds[e]
        ptr[k + 1] = ptr[k] + n
        sptr[k + 1] = sptr[k] + ns
    ids = np.empty(ptr[K], np.int64)
    loop = np.empty(ptr[K], np.int64)
    pos = np.empty(ptr[K], np.int64)
    segs = np.empty(sptr[K], np.int64)
    for k in range(K):
        f = facets[k]
        j = ptr[k]
        js = sptr[k]
        for q in range(bptr[f], bptr[f + 1]):
            e = be[q]
            lo, hi = edge_bounds[e], edge_bounds[e + 1]
            ids[j] = bu[q]
            loop[j] = bl[q]
            pos[j] = j - ptr[k]
            j += 1
            for i in range(hi - lo):
                ids[j] = by_edge[lo + i] if bfwd[q] else by_edge[hi - 1 - i]
                loop[j] = bl[q]
                pos[j] = j - ptr[k]
                j += 1
            for i in range(seg_bounds[e], seg_bounds[e + 1]):
                segs[js] = seg_order[i]
                js += 1
        for i in range(lptr[f], lptr[f + 1]):
            ids[j] = lonely[i]
            loop[j] = -1
            pos[j] = -1
            j += 1
        for i in range(facet_bounds[f], facet_bounds[f + 1]):
            ids[j] = by_facet[i]
            loop[j] = -1
            pos[j] = -1
            j += 1
    return ptr, ids, loop, pos, sptr, segs


@njit(cache=True)
def _facet_subfaces(
    facets, plain, ptr, ids, loop, pos, tptr, tri, uv, in_ptr, in_tri, tu, tol, sptr, segs,
    seg_keys,
):  # fmt: skip
    """The subfaces of each facet (in ``facets`` order) and its unsettled subsegments.

    A facet with no point added (``plain``) keeps its input triangles
    (``in_tri``, CSR ``in_ptr``). Otherwise, of its 2D Delaunay triangles
    (``tri``, local to its points, CSR ``tptr``) a triangle whose three
    corners lie on one boundary loop is kept when it visits them in the
    loop's cyclic order (two of its three steps forward: the triangles of
    the convex hull's pockets outside the facet, and the slivers of three
    points of one edge that rounding put a hair inside it, run against it);
    another is kept when its centroid lies in one of the facet's input
    triangles (``tu``, projected, non-strict up to ``tol``). The unsettled
    subsegments: the keys ``seg_keys[segs]`` of the facet's boundary
    subsegments that are no edges of its subfaces.
    """
    K = facets.shape[0]
    out = np.empty((tri.shape[0] + in_tri.shape[0], 3), np.int64)
    owner = np.empty(out.shape[0], np.int64)
    uptr = np.zeros(K + 1, np.int64)
    unsettled = np.empty(segs.shape[0], np.int64)
    n = 0
    nu = 0
    for k in range(K):
        f = facets[k]
        first = n
        if plain[k]:
            for t in range(in_ptr[f], in_ptr[f + 1]):
                out[n, 0], out[n, 1], out[n, 2] = in_tri[t, 0], in_tri[t, 1], in_tri[t, 2]
                owner[n] = f
                n += 1
        else:
            base = ptr[k]
            for t in range(tptr[k], tptr[k + 1]):
                a, b, c = tri[t, 0] + base, tri[t, 1] + base, tri[t, 2] + base
                if loop[a] >= 0 and loop[a] == loop[b] and loop[b] == loop[c]:
                    steps = (pos[b] > pos[a]) + (pos[c] > pos[b]) + (pos[a] > pos[c])
                    keep = steps == 2
                else:
                    x0 = ((uv[a, 0] + uv[b, 0]) + uv[c, 0]) / 3.0
                    x1 = ((uv[a, 1] + uv[b, 1]) + uv[c, 1]) / 3.0
                    keep = False
                    for q in range(in_ptr[f], in_ptr[f + 1]):
                        ok = True
                        for i in range(3):
                            p0, p1 = tu[q, i, 0], tu[q, i, 1]
                            q0, q1 = tu[q, (i + 1) % 3, 0], tu[q, (i + 1) % 3, 1]
                            if not ((q0 - p0) * (x1 - p1) - (q1 - p1) * (x0 - p0) >= tol[f]):
                                ok = False
                                break
                        if ok:
                            keep = True
                            break
                if keep:
                    out[n, 0], out[n, 1], out[n, 2] = ids[a], ids[b], ids[c]
                    owner[n] = f
                    n += 1
        ns = sptr[k + 1] - sptr[k]
        if ns > 0:
            # The facet's boundary subsegments in a small hash table, marked as its
            # subface edges are met (the table stays in cache: no sort of the edges).
            keys = seg_keys[segs[sptr[k] : sptr[k + 1]]]
            tk, tv = _table(keys)
            shift = _shift(tk.shape[0])
            met = np.zeros(ns, np.bool_)
            for t in range(first, n):
                for j in range(3):
                    u, v = out[t, j], out[t, (j + 1) % 3]
                    i = _find(tk, tv, (min(u, v) << 32) | max(u, v), shift)
                    if i >= 0:
                        met[i] = True
            for i in range(ns):
                if not met[_find(tk, tv, keys[i], shift)]:
                    unsettled[nu] = keys[i]
                    nu += 1
        uptr[k + 1] = nu
    return out[:n].copy(), owner[:n].copy(), uptr, unsettled[:nu].copy()


@njit(cache=True)
def triangulate_facets(uv, ptr, plain):
    """The 2D Delaunay triangles of each facet's points (rows ``ptr[k]:ptr[k + 1]`` of
    ``uv``), local to the facet, CSR ``tptr`` (none for a ``plain`` facet); and a
    status per facet (``FAILED``: fewer than 3 points, a non-finite or out-of-range
    coordinate, duplicates or all collinear; no triangles then).

    The steps of :func:`meshcore.delaunay.kernel2d.delaunay` (its ``_build`` and
    ``_output``: the same scale factor, insertion order and chunks), so the rows are
    the same as its; one call for all facets instead of one each. ``uv`` read-only,
    as :func:`~meshcore.delaunay.kernel2d.delaunay` passes its points: the kernel's
    passes compiled for it serve both.
    """
    K = ptr.shape[0] - 1
    cap = 0
    for k in range(K):
        if not plain[k]:
            cap += 2 * (ptr[k + 1] - ptr[k])
    tri = np.empty((cap, 3), np.int64)
    tptr = np.zeros(K + 1, np.int64)
    status = np.zeros(K, np.int64)
    nt = 0
    for k in range(K):
        tptr[k + 1] = nt
        n = ptr[k + 1] - ptr[k]
        if plain[k]:
            continue
        if n < 3:
            status[k] = FAILED
            continue
        pts_in = uv[ptr[k] : ptr[k + 1]]
        finite, big, small = _scan(pts_in)
        factor = 1.0
        if big > 0.0:
            e = math.frexp(big)[1]
            if small < np.inf and math.ldexp(small, -e) < _MIN_SCALED:
                finite = False
            factor = math.ldexp(1.0, -e)
        if not finite:
            status[k] = FAILED
            continue
        bits = 0
        while (n >> bits) > 0:
            bits += 1
        nbits = min(_HILBERT_BITS, max(8, bits + 2))
        rnd, curve, nrounds = _brio_hilbert_keys(pts_in, factor, nbits)
        order, along, curve_sorted = _insertion_order(rnd, curve, nrounds)
        hint = _walk_hints(along, curve_sorted)
        pts = _gather(pts_in, order, factor)
        V = np.empty(6 * n, np.int32)
        A = np.empty(6 * n, np.int32)
        stack = np.empty(n + 8, np.int32)
        state = np.zeros(5, np.int64)
        work = np.empty(WORK_SIZE)
        vt = np.zeros(n, np.int32)
        _start(pts, order, V, A, vt, state, work)
        if state[2] == _DUPLICATE or state[2] == _COLLINEAR:
            status[k] = FAILED
            continue
        done = np.int64(3)
        while done < n:
            stop = min(n, done + _CHUNK)
            _insert_range(pts, V, A, stack, vt, hint, state, work, done, stop, None)
            if state[2] == _DUPLICATE:
                break
            done = stop
        if state[2] == _DUPLICATE:
            status[k] = FAILED
            continue
        triangles, _ = _output(V, A, state[0], order)
        for t in range(triangles.shape[0]):
            tri[nt, 0], tri[nt, 1], tri[nt, 2] = triangles[t, 0], triangles[t, 1], triangles[t, 2]
            nt += 1
        tptr[k + 1] = nt
    return tri[:nt].copy(), tptr, status


class KeptTriangulations:
    """The 2D Delaunay triangulations of the large facets, kept and grown.

    :meth:`triangulate` gives what :func:`triangulate_facets` gives (the same
    triangles: the 2D kernel's ties depend only on the point set, §9.1), but a
    facet of at least :data:`KEEP_FROM` points keeps its
    :class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay` and only the
    points added since its last call are inserted (in Hilbert order, each
    walk starting at the point inserted two before it). A facet's points are
    named by their global ids; points are only appended and a point's facet
    never changes, so the new points of a facet are those of its ids not
    below the point count at its last call. The triangles of a kept facet
    come in the kernel's slot order (a triangle no insertion touched keeps
    its row, corners in the same order), not in a fresh build's.
    """

    def __init__(self) -> None:
        #: facet -> (triangulation, global id of each of its points, point count then)
        self._kept: dict[int, tuple] = {}

    def clear(self) -> None:
        """Forget every kept triangulation."""
        self._kept = {}

    def triangulate(self, facets, ptr, ids, uv, plain, n_points):
        """:func:`triangulate_facets` of ``uv`` (rows ``ptr[k]:ptr[k + 1]`` the
        projected points ``ids`` of facet ``facets[k]``), ``n_points`` the global
        point count; the large facets' triangles from their kept triangulations."""
        big = ~plain & (np.diff(ptr) >= KEEP_FROM)
        tri, tptr, status = triangulate_facets(uv, ptr, plain | big)
        if not big.any():
            return tri, tptr, status
        counts = np.diff(tptr)
        parts = {}
        for k in np.flatnonzero(big).tolist():
            lo, hi = int(ptr[k]), int(ptr[k + 1])
            local = self._grown(int(facets[k]), ids[lo:hi], uv[lo:hi], n_points)
            if local is None:
                status[k] = FAILED
            else:
                parts[k] = local
                counts[k] = len(local)
        out_ptr = np.concatenate([[0], np.cumsum(counts)])
        out = np.empty((out_ptr[-1], 3), np.int64)
        rows = np.arange(len(tri))
        owner = np.repeat(np.arange(len(counts)), np.diff(tptr))
        out[out_ptr[owner] + rows - tptr[owner]] = tri
        for k, local in parts.items():
            out[out_ptr[k] : out_ptr[k + 1]] = local
        return out, out_ptr, status

    def _grown(self, f, ids, uv, n_points):
        """Facet ``f``'s triangles as rows of ``ids`` (its points now, projected
        ``uv``), after inserting its new points; None when the kernel refuses
        them (coinciding projections)."""
        kept = self._kept.pop(f, None)
        new = np.flatnonzero(ids >= kept[2]) if kept is not None else None
        try:
            if kept is not None and len(kept[1]) + len(new) == len(ids):
                dt, gid, _ = kept
                if new.size:
                    xy = uv[new]
                    view = xy.view()
                    view.flags.writeable = False
                    curve = _brio_hilbert_keys(view, 1.0, _HILBERT_BITS)[1]
                    order = np.argsort(curve, kind="stable")
                    # Each walk starts at the point inserted two before it (the
                    # kernel reads the next point's start ahead, before the point
                    # just before it is in), the first two at the last one in.
                    near = len(gid) - 1 + np.maximum(np.arange(len(new)) - 1, 0)
                    if dt.insert(xy[order], near) is not None:
                        return None
                    gid = np.concatenate([gid, ids[new[order]]])
            else:
                dt, gid = IncrementalDelaunay(uv), ids.copy()
        except InputError:
            return None
        self._kept[f] = (dt, gid, n_points)
        at = np.empty(n_points, np.int64)
        at[ids] = np.arange(len(ids))
        return at[gid[dt.triangulation(None).triangles]]
