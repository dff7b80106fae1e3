"""Validity checks of product meshes (§8.1.1): signed measures and self-overlap.

A swept cell must have positive measure at every corner (exact signs for
the base's orientation, the measures of :mod:`meshcore.mesh.quality`), and
the swept solid must not overlap itself (a rotation past 360 degrees, a
helix whose turns cross): sample points of each cell are located in the
cells of other layers through a grid, and a hit well inside a foreign cell
fails the job naming both cells.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from meshcore.errors import InputError
from meshcore.mesh import CELL_TYPES, Mesh, quality, topology

Progress = Callable[[float, str], None] | None

_MAX_REPORTED = 20  # offending cells listed in an error


def _report(progress: Progress, fraction: float, message: str) -> None:
    if progress is not None:
        progress(min(max(fraction, 0.0), 1.0), message)


def _local(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points ``cells`` use and the cells renumbered onto them (measures of a few cells)."""
    used, inverse = np.unique(cells, return_inverse=True)
    return points[used], inverse.reshape(cells.shape)


_CHUNK = 1 << 20  # cells per chunk of the measure check


def _fmt(value) -> str:
    a = np.asarray(value, dtype=np.float64)
    return f"{float(a):.6g}" if a.ndim == 0 else "[" + ", ".join(f"{x:.6g}" for x in a) + "]"


def _invalid_error(
    mesh: Mesh,
    bad: list[tuple[int, np.ndarray, np.ndarray]],
    summary: str,
    detail: str,
    code: str,
    fault: tuple,
) -> InputError:
    """An error naming the offending cells: ``bad`` holds (block, cell ids, a value per cell)."""
    total = sum(len(c) for _, c, _ in bad)
    errors, named = [], []
    for b, cells, values in bad:
        block = mesh.cells[b]
        shown = cells[: max(_MAX_REPORTED - len(errors), 0)]
        if len(shown):
            named.append(f"{', '.join(map(str, shown.tolist()))} of block {b} ({block.type})")
        for c, v in zip(shown, values, strict=False):
            c = int(c)
            layer = int(mesh.cell_data["layer"][b][c])
            src = int(mesh.cell_data["source_cell"][b][c])
            errors.append(
                {
                    "loc": list(fault),
                    "msg": f"cell {c} of block {b} ({block.type}, layer {layer}, "
                    f"source cell {src}) {detail} {_fmt(v)}",
                    "type": code,
                }
            )
    more = f" and {total - len(errors)} more" if total > len(errors) else ""
    message = (
        f"the product mesh is invalid: {total} cells {summary}: cells "
        f"{'; '.join(named)}{more}; set validate: false to get the mesh anyway"
    )
    return InputError(message, code=code, errors=errors)


def _along_axis(screw: tuple, tol: float) -> bool:
    """Whether a screw motion's translation runs along its axis (every layer congruent)."""
    _, d, _, _, w = screw
    return bool(np.linalg.norm(w - (w @ d) * d) <= tol)


def _check_measures(
    mesh: Mesh, n_swept: int, fault: tuple, progress: Progress, uniform: bool
) -> None:
    """Every swept cell has a positive volume (area, length); raise naming those that do not.

    With ``uniform`` only the first layer is computed, which decides every
    layer: under a translation each cell's volume is its first-layer
    counterpart's times the ratio of the (positive) steps, since the signed
    volume of a prism between a cell and its translate is linear in the
    step; under a rotation, or a helix along its axis, every layer is the
    first one moved rigidly.
    """
    bad = []
    total = sum(len(mesh.cells[b]) for b in range(n_swept))
    done = 0
    for b in range(n_swept):
        block = mesh.cells[b]
        d = CELL_TYPES[block.type][1]
        stop = len(block)
        if uniform:
            stop = int(np.searchsorted(mesh.cell_data["layer"][b], 1))
        for start in range(0, stop, _CHUNK):
            cells = block.data[start : min(start + _CHUNK, stop)]
            pts = mesh.points
            if uniform:
                pts, cells = _local(pts, cells)
            if d == 3:
                m = quality.signed_volume(pts, cells, block.type)
            elif d == 2:
                m = quality.signed_area(pts, cells, block.type)
            else:
                m = np.linalg.norm(pts[cells[:, 1]] - pts[cells[:, 0]], axis=1)
            sel = np.flatnonzero(m <= 0)
            if len(sel):
                bad.append((b, sel + start, m[sel]))
            done += len(cells)
            _report(progress, 0.5 + 0.3 * done / max(total, 1), "checking cell volumes")
    if bad:
        raise _invalid_error(
            mesh,
            bad,
            "have a non-positive volume (area, length)",
            "has the signed measure",
            "inverted_cells",
            fault,
        )


def _plane(points: np.ndarray):
    """Best-fit plane: centroid, in-plane axes (2, 3), normal, largest offset, singular values."""
    c = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - c, full_matrices=False)
    normal = vt[-1] if len(vt) == 3 else np.cross(vt[0], vt[1]) if len(vt) == 2 else vt[0]
    return c, vt[:2], normal, float(np.max(np.abs((points - c) @ normal))), s


def _check_overlap(mesh, n_swept, base, screw, translate, closed, tol, tolerances, fault, progress):
    """Raise when the swept solid overlaps itself (see the module docstring for the method)."""
    solid = [b for b in range(n_swept) if CELL_TYPES[mesh.cells[b].type][1] == 3]
    used = np.unique(np.concatenate([blk.data.ravel() for blk in base.blocks]))
    bpts = base.points[used]
    c, _, normal, off, _ = _plane(bpts)
    planar = off <= tol
    if translate and planar and solid:
        return
    if screw is not None and planar:
        a, d, angle, layers, w = screw
        in_plane = abs(normal @ d) <= tolerances.coincident and abs((a - c) @ normal) <= tol
        along = np.linalg.norm(w - (w @ d) * d) <= tol
        u = (bpts - a) @ np.cross(d, normal)
        one_side = bool(np.all(u >= -tol) or np.all(u <= tol))
        if in_plane and along and one_side:
            if abs(angle) <= 360 and not (abs(angle) == 360 and w.any()):
                return
            if not w.any():  # a rotation past a whole turn: the cells past 360°
                ends = np.abs(angle) * (np.arange(1, layers + 1)) / layers
                past = np.flatnonzero(ends > 360 * (1 + tolerances.coincident))
                bad = []
                for b in range(n_swept):
                    cells = np.flatnonzero(np.isin(mesh.cell_data["layer"][b], past))
                    if len(cells):
                        bad.append((b, cells, mesh.cell_data["layer"][b][cells].astype(float)))
                raise _invalid_error(
                    mesh,
                    bad,
                    "lie past a whole turn, over the first cells",
                    "overlaps the first turn: it is in layer",
                    "self_overlap",
                    fault,
                )
    if not solid:
        return
    hits = _overlapping(mesh, solid, tol, closed, progress)
    if hits:
        raise _invalid_error(
            mesh,
            hits,
            "overlap other cells (the swept solid overlaps itself)",
            "overlaps another cell at",
            "self_overlap",
            fault,
        )


def _face_planes(pts: np.ndarray, cells: np.ndarray, cell_type: str):
    """Outward unit normals ``(m, f, 3)`` and offsets ``(m, f)`` of every face triangle.

    A point ``x`` is inside face plane ``j`` of cell ``i`` by ``offset[i, j] -
    normal[i, j] . x``. Quad faces count as their two triangles (0 1 2) and
    (0 2 3), so that a warped face is replaced by the intersection of both
    half-spaces.
    """
    tris = []
    for ftype, faces in topology.CELL_FACES[cell_type].items():
        for face in faces:
            if ftype == "triangle":
                tris.append(face)
            else:
                tris.extend([face[[0, 1, 2]], face[[0, 2, 3]]])
    tris = np.array(tris)
    p = pts[cells[:, tris]]  # (m, f, 3, 3)
    n = np.cross(p[:, :, 1] - p[:, :, 0], p[:, :, 2] - p[:, :, 0])
    norm = np.linalg.norm(n, axis=2, keepdims=True)
    n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    return n, np.einsum("mfk,mfk->mf", n, p[:, :, 0])


_CORNER_PULL = 0.25  # corner samples lie this fraction of the way from a corner to the centroid
_PAIR_CHUNK = 1 << 19  # (cell, sample) pairs tested at once
_GRID_BUDGET = 16  # grid cells covered per mesh cell, at most, on average


def _overlapping(mesh: Mesh, solid: list[int], tol: float, closed: bool, progress: Progress):
    """Cells holding a sample point of a cell of a non-adjacent layer strictly inside.

    Samples: each cell's centroid and, for each corner, the point a quarter
    of the way from the corner to the centroid; all lie inside their own
    cell. Candidates: a uniform grid, its spacing along each axis the median
    extent of the cells' bounding boxes (doubled until the boxes cover few
    grid cells), pairs each cell with the samples in the grid cells its box
    covers. A sample more than ``tol`` inside the box of a cell two or more
    layers away (cyclically for a closed ring) is tested against that cell's
    face planes. Cells of the same or adjacent layers are not compared: they
    share a section, and their overlaps are folds that turn some volume
    negative. Memory: about 0.3 kB per cell.
    """
    pts = mesh.points
    blocks = [mesh.cells[b].data for b in solid]
    starts = np.concatenate([[0], np.cumsum([len(d) for d in blocks])])
    layer = np.concatenate([mesh.cell_data["layer"][b] for b in solid])
    n_layers = int(layer.max()) + 1
    lo = np.concatenate([pts[d].min(axis=1) for d in blocks])
    hi = np.concatenate([pts[d].max(axis=1) for d in blocks])
    samples, owners = [], []
    for i, d in enumerate(blocks):
        p = pts[d]
        cen = p.mean(axis=1)
        gid = starts[i] + np.arange(len(d))
        samples += [cen, (p + _CORNER_PULL * (cen[:, None] - p)).reshape(-1, 3)]
        owners += [gid, np.repeat(gid, d.shape[1])]
    samples, owners = np.concatenate(samples), np.concatenate(owners)

    origin = lo.min(axis=0)
    ext = hi - lo
    h = np.maximum(np.median(ext, axis=0), max(tol, float(ext.max()) * 1e-6, 1e-300))
    while True:  # coarsen until the boxes cover few grid cells
        # a sample more than tol inside a box lies in these grid cells (rounding is monotone)
        i0 = np.floor((lo + tol - origin) / h).astype(np.int64)
        i1 = np.maximum(np.floor((hi - tol - origin) / h).astype(np.int64), i0)
        span = i1 - i0 + 1
        count = span.prod(axis=1)
        if count.sum() <= _GRID_BUDGET * len(lo):
            break
        h = 2 * h
    dims = np.floor((hi.max(axis=0) - origin) / h).astype(np.int64) + 1
    gs = np.clip(np.floor((samples - origin) / h).astype(np.int64), 0, dims - 1)
    skey = (gs[:, 0] * dims[1] + gs[:, 1]) * dims[2] + gs[:, 2]
    order = np.argsort(skey, kind="stable")
    skey = skey[order]
    n_grid = int(dims.prod())
    # samples of grid cell g: order[offsets[g]:offsets[g + 1]] (a dense table when it is small)
    offsets = None
    if n_grid <= 4 * len(skey):
        offsets = np.concatenate([[0], np.cumsum(np.bincount(skey, minlength=n_grid))])

    hit_cells, hit_samples = [], []
    total = len(lo)
    per_key = len(skey) / (np.count_nonzero(np.diff(skey)) + 1)  # samples per occupied grid cell
    cell_chunk = max(1, int(_PAIR_CHUNK / max(count.mean() * per_key, 1.0)))
    for c0 in range(0, total, cell_chunk):
        _report(progress, 0.8 + 0.2 * c0 / total, "checking for self-overlap")
        cells = np.arange(c0, min(c0 + cell_chunk, total))
        cnt = count[cells]
        cell = np.repeat(cells, cnt)
        r = np.arange(len(cell)) - np.repeat(np.cumsum(cnt) - cnt, cnt)  # index within the box
        sy, sz = span[cell, 1], span[cell, 2]
        g = i0[cell] + np.column_stack([r // (sy * sz), (r // sz) % sy, r % sz])
        key = (g[:, 0] * dims[1] + g[:, 1]) * dims[2] + g[:, 2]
        if offsets is not None:
            a, z = offsets[key], offsets[key + 1]
        else:
            a, z = np.searchsorted(skey, key, "left"), np.searchsorted(skey, key, "right")
        n = z - a
        pc = np.repeat(cell, n)
        ps = order[np.repeat(a, n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]
        apart = np.abs(layer[owners[ps]] - layer[pc])
        if closed:
            apart = np.minimum(apart, n_layers - apart)
        keep = apart >= 2
        pc, ps = pc[keep], ps[keep]
        x = samples[ps]
        keep = np.all((x > lo[pc] + tol) & (x < hi[pc] - tol), axis=1)
        pc, ps = pc[keep], ps[keep]
        blk = np.searchsorted(starts, pc, "right") - 1
        for i in np.unique(blk):
            sel = blk == i
            cc, ss = pc[sel], ps[sel]
            uniq, local = np.unique(cc - starts[i], return_inverse=True)
            normal, offset = _face_planes(pts, blocks[i][uniq], mesh.cells[solid[i]].type)
            local = local.ravel()
            inside = np.all(
                offset[local] - np.einsum("pfk,pk->pf", normal[local], samples[ss]) > tol, axis=1
            )
            # both the cell holding the sample and the sample's own cell
            hit_cells += [cc[inside], owners[ss[inside]]]
            hit_samples += [ss[inside], ss[inside]]
    if not hit_cells:
        return []
    cells_all = np.concatenate(hit_cells)
    samples_all = np.concatenate(hit_samples)
    ids, first = np.unique(cells_all, return_index=True)
    out = []
    for i, b in enumerate(solid):
        sel = (ids >= starts[i]) & (ids < starts[i + 1])
        if sel.any():
            out.append((b, ids[sel] - starts[i], samples[samples_all[first[sel]]]))
    return out
