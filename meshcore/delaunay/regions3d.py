"""Region labels of a growing tetrahedralization (split from :mod:`meshcore.delaunay.recovery3d`).

:func:`regions` labels each tetrahedron by the shell region it lies in (a
flood fill across the faces that are no subfaces, the subfaces giving each
component its facet's region); :class:`RegionLabels` keeps the labels
between refinement rounds and classifies only the tetrahedra created since
(:func:`fresh_rows`), with the same labels.

References
----------
Methods text §9.3 (the recovered surface bounds the regions).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.delaunay.hashgrid import _shift, _slot, _table
from meshcore.delaunay.prefetch import prefetch
from meshcore.delaunay.recovery3d import (
    TET_FACES,
    SurfaceRecovery,
    _face_key,
    _subface_at,
    face_keys,
)
from meshcore.errors import AlgorithmError
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh.topology import isin_ints

__all__ = ["RegionLabels", "fresh_rows", "regions"]


@njit(cache=True)
def _row_of(slots):
    """(top,) int64: the row of each slot in ``slots`` (-1 for slots not listed)."""
    top = 0
    for s in slots:
        top = max(top, s + 1)
    row_of = np.full(top, -1, np.int64)
    for r in range(slots.shape[0]):
        row_of[slots[r]] = r
    return row_of


@njit(cache=True)
def _flood(nb, sub_of):
    """Connected components of rows joined across their faces: row ``t``'s face ``j``
    joins it to row ``nb[t, j]`` when that is >= 0 and the face is no subface
    (``sub_of[t, j] < 0``). Returns (component of each row, their number), components
    numbered in the order of their first row."""
    k = nb.shape[0]
    comp = np.full(k, -1, np.int64)
    stack = np.empty(k, np.int64)
    n = 0
    for s in range(k):
        if comp[s] >= 0:
            continue
        comp[s] = n
        stack[0] = s
        size = 1
        while size > 0:
            size -= 1
            t = stack[size]
            for j in range(4):
                u = nb[t, j]
                if u >= 0 and sub_of[t, j] < 0 and comp[u] < 0:
                    comp[u] = n
                    stack[size] = u
                    size += 1
        n += 1
    return comp, n


@njit(cache=True)
def _incidences(sub_of):
    """(row, face, subface) of each entry ``sub_of[i, j] >= 0`` of ``sub_of`` (k, 4), in
    row-major order: the subface incidences of :func:`_regions_pass` and
    :func:`_regions_update`."""
    n = 0
    for i in range(sub_of.shape[0]):
        for j in range(4):
            if sub_of[i, j] >= 0:
                n += 1
    inc_i = np.empty(n, np.int64)
    inc_f = np.empty(n, np.int64)
    inc_s = np.empty(n, np.int64)
    q = 0
    for i in range(sub_of.shape[0]):
        for j in range(4):
            if sub_of[i, j] >= 0:
                inc_i[q] = i
                inc_f[q] = j
                inc_s[q] = sub_of[i, j]
                q += 1
    return inc_i, inc_f, inc_s


@njit(cache=True)
def _regions_pass(T, slots, adj, on, tk, tv, faces):
    """The flood fill of :func:`regions` in one pass.

    Returns the component of each tetrahedron (across faces that are not
    subfaces, between real tetrahedra), their number, whether each meets the
    outside (a non-subface with no real tetrahedron behind it), and every
    (tetrahedron, face, subface) incidence in row-major order.
    """
    m = T.shape[0]
    row_of = _row_of(slots)
    top = row_of.shape[0]
    shift = _shift(tk.shape[0])
    nb = np.empty((m, 4), np.int64)
    sub_of = np.full((m, 4), -1, np.int64)
    for t in range(m):
        for j in range(4):
            u = adj[t, j]
            nb[t, j] = row_of[u] if 0 <= u < top else -1
            sub_of[t, j] = _subface_at(T, t, j, faces, on, tk, tv, shift)
    comp, n = _flood(nb, sub_of)
    outside = np.zeros(n, np.bool_)
    for t in range(m):
        for j in range(4):
            if sub_of[t, j] < 0 and nb[t, j] < 0:
                outside[comp[t]] = True
    inc_t, inc_f, inc_s = _incidences(sub_of)
    return comp, n, outside, inc_t, inc_f, inc_s


@njit(cache=True)
def fresh_rows(T, n0):
    """(k,) int64: the rows of ``T`` (m, 4) with a vertex numbered ``n0`` or above (the
    tetrahedra created since the structure had ``n0`` points)."""
    out = np.empty(T.shape[0], np.int64)
    k = 0
    for t in range(T.shape[0]):
        if max(max(T[t, 0], T[t, 1]), max(T[t, 2], T[t, 3])) >= n0:
            out[k] = t
            k += 1
    return out[:k].copy()


@njit(cache=True)
def _regions_update(T, slots, fresh, adj, old, on, tk, tv, faces):
    """The flood fill of :func:`regions` over the ``fresh`` rows only.

    ``old[s]``: the label of the tetrahedron at slot ``s`` at the last call
    (the others kept theirs); ``adj``: the fresh rows' neighbour slots.
    Returns the component of each fresh row, their number, per component the
    label met across ordinary faces (-2 none), whether it meets the outside
    and whether two labels met disagree, and the subface incidences.
    """
    m = T.shape[0]
    row_of = _row_of(slots)
    top = row_of.shape[0]
    k = fresh.shape[0]
    local = np.full(m, -1, np.int64)
    for i in range(k):
        local[fresh[i]] = i
    shift = _shift(tk.shape[0])
    nb = np.full((k, 4), -1, np.int64)  # fresh neighbour (local), -2 old, -3 outside
    sub_of = np.full((k, 4), -1, np.int64)
    for i in range(k):
        # Ahead (misses at 10^6 tetrahedra): the corners' surface flags and the
        # neighbours' rows 16 rows on, the face keys' table slots and the
        # neighbours' local numbers 8 rows on.
        if i + 16 < k:
            for j in range(4):
                prefetch(on, T[fresh[i + 16], j])
                u = adj[i + 16, j]
                if 0 <= u < top:
                    prefetch(row_of, u)
        if i + 8 < k:
            t = fresh[i + 8]
            for j in range(4):
                a, b, c = T[t, faces[j, 0]], T[t, faces[j, 1]], T[t, faces[j, 2]]
                if on[a] and on[b] and on[c]:
                    prefetch(tk, _slot(_face_key(a, b, c), shift))
                u = adj[i + 8, j]
                if 0 <= u < top and row_of[u] >= 0:
                    prefetch(local, row_of[u])
        t = fresh[i]
        for j in range(4):
            sub_of[i, j] = _subface_at(T, t, j, faces, on, tk, tv, shift)
            if sub_of[i, j] >= 0:
                continue
            u = adj[i, j]
            r = row_of[u] if 0 <= u < top else -1
            nb[i, j] = -3 if r < 0 else (local[r] if local[r] >= 0 else -2)
    comp, n = _flood(nb, sub_of)
    met = np.full(n, -2, np.int64)
    outside = np.zeros(n, np.bool_)
    clash = np.zeros(n, np.bool_)
    for i in range(k):
        c = comp[i]
        for j in range(4):
            if sub_of[i, j] >= 0:
                continue
            if nb[i, j] == -3:
                outside[c] = True
            elif nb[i, j] == -2:
                lab = old[slots[row_of[adj[i, j]]]]
                if met[c] == -2:
                    met[c] = lab
                elif met[c] != lab:
                    clash[c] = True
    inc_i, inc_f, inc_s = _incidences(sub_of)
    return comp, n, met, outside, clash, fresh[inc_i], inc_f, inc_s


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only contiguous int64 view: ``b.tets()``'s arrays are read-only, and numba
    compiles a separate copy for a writeable argument."""
    v = np.ascontiguousarray(a, dtype=np.int64).view()
    v.flags.writeable = False
    return v


def regions(b: SurfaceRecovery, slots: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Region of each tetrahedron of ``T`` (-1 outside), by flood fill across non-subfaces."""
    slots = np.ascontiguousarray(slots, dtype=np.int64)
    comp, n_comp, out_comp, t_i, f_j, s_rows = _regions_pass(
        _read_only(T), _read_only(slots), b.dt.adjacent(slots), b.on_surface(),
        *_table(face_keys(b.sub)), TET_FACES,
    )  # fmt: skip
    met = np.full(n_comp, -2, dtype=np.int64)
    clash = np.zeros(n_comp, dtype=bool)
    return _labels(b, T, comp, met, out_comp, clash, t_i, f_j, s_rows)


def _labels(b, T, comp, met, out_comp, clash, t_i, f_j, s_rows) -> np.ndarray:
    """The label of each component of :func:`regions` (of the rows ``comp`` covers).

    ``met``: the label each component already has (-2 unknown), ``out_comp``:
    whether it meets the outside, ``clash``: whether labels met disagree;
    ``(t_i, f_j, s_rows)`` the subface incidences (row of ``T``, face,
    subface). Raises if the surface does not separate the regions.
    """
    label = met.copy()
    # A tetrahedron on a hull face (neighbour a ghost) across a non-subface is outside.
    outside = np.flatnonzero(out_comp)
    # Subfaces: the tetrahedron on the inner side takes the facet's region.
    sf = b.sub[s_rows]
    d = T[t_i, f_j]
    side = orient3d(b.P[sf[:, 0]], b.P[sf[:, 1]], b.P[sf[:, 2]], b.P[d])
    inner = side > 0
    reg = b.group_region[b.sub_facet[s_rows]]
    ci = comp[t_i[inner]]
    ri = reg[inner]
    label[ci] = ri
    conflict = clash.copy()
    chk = (label[ci] != ri) | ((met[ci] != -2) & (met[ci] != ri))
    conflict[ci[chk]] = True
    co = comp[t_i[~inner]]
    outer_reg = reg[~inner]
    # A tetrahedron on the outer side of a facet is in another region or outside:
    # never in the facet's own region.
    same = label[co] == outer_reg
    conflict[co[same]] = True
    conflict[outside[isin_ints(outside, ci)]] = True
    conflict[outside[met[outside] >= 0]] = True
    if conflict.any():
        raise AlgorithmError(
            "the recovered surface does not separate the regions (a subface is "
            "missing or doubled): the tetrahedra could not be classified",
            code="recovery_failed",
        )
    label[label == -2] = -1
    label[outside] = -1
    return label[comp]


class RegionLabels:
    """:func:`regions` kept between calls, for a tetrahedralization that only grows.

    Each call classifies only the tetrahedra with a vertex added since the
    last one (every tetrahedron an insertion creates holds the new point):
    the others keep their region, and a new one takes the region of the old
    tetrahedra it meets across faces that are not subfaces, or of the
    subfaces it holds, as :func:`regions` would; with every subface present
    (as after :func:`recover`) the labels are those of :func:`regions`.
    """

    def __init__(self, b: SurfaceRecovery) -> None:
        self.b = b
        self.n = -1
        self.by_slot = np.zeros(0, dtype=np.int64)

    def __call__(self, slots: np.ndarray, T: np.ndarray) -> np.ndarray:
        """(m,) int64: the region of each tetrahedron ``T`` at ``slots`` (-1 outside)."""
        b = self.b
        slots = np.ascontiguousarray(slots, dtype=np.int64)
        T = np.ascontiguousarray(T, dtype=np.int64)
        if self.n < 0:
            label = regions(b, slots, T)
        else:
            fresh = fresh_rows(T, self.n)
            comp, n_comp, met, out_comp, clash, t_i, f_j, s_rows = _regions_update(
                T, slots, fresh, b.dt.adjacent(slots[fresh]), self.by_slot, b.on_surface(),
                *_table(face_keys(b.sub)), TET_FACES,
            )  # fmt: skip
            label = self.by_slot[np.minimum(slots, len(self.by_slot) - 1)]
            if fresh.size:
                whole = np.zeros(len(T), dtype=np.int64)
                whole[fresh] = comp
                label[fresh] = _labels(b, T, whole, met, out_comp, clash, t_i, f_j, s_rows)[fresh]
        self.by_slot = np.full(int(slots.max()) + 1 if len(slots) else 0, -3, dtype=np.int64)
        self.by_slot[slots] = label
        self.n = b.n
        return label
