"""Previews of results: ``preview.svg`` (at most about 2 MB) and ``preview.png``.

Both draw, fitted into an 800-pixel box with the y axis pointing up: the
domain and regions (filled), the mesh, the medial axis. A 3D mesh is drawn
as its boundary surface (the faces held by one cell, and the surface cells)
seen from a fixed view: azimuth 30 degrees, elevation 25 degrees.

- **SVG.** The mesh's boundary and feature lines (line cells: constraints
  and axes; edges between cells of different cell sets) are always drawn;
  interior edges are drawn while they fit the byte budget: edges shorter
  than a pixel go first (they only darken the fill), then every k-th of the
  rest. What was left out is said in the SVG's ``<desc>``. Coordinates are
  written to a tenth of a pixel; segments that vanish at that precision are
  dropped.
- **PNG.** Rasterized with numpy and Pillow: every mesh edge is sampled
  once per pixel of its length and the samples are counted per pixel (the
  colour deepens with the count, so a dense mesh reads as a shaded fill);
  the boundary and feature lines, then the axis, go on top. 3D faces are
  splatted with a depth buffer and shaded by their normal.

Edges are counted in one compiled pass over the cells (a hash table), not
by sorting: on a 1.29M-triangle mesh that is the difference between tens
and hundreds of milliseconds.
"""

from __future__ import annotations

import io as _bytesio

import numba
import numpy as np
from PIL import Image, ImageDraw

from meshcore.errors import InputError
from meshcore.mesh import CELL_TYPES, Mesh

SIZE = 800.0
MARGIN = 10.0
SVG_BUDGET = 1_900_000  # bytes of path data; the document stays under about 2 MB
_REGION_COLOURS = ("#cfe2f3", "#d9ead3", "#fff2cc", "#f4cccc", "#d9d2e9", "#fce5cd")
_FACES = {  # boundary faces of 3D cells (meshio's node order)
    "tetra": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)),
    "pyramid": ((0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)),
    "wedge": ((0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)),
    "hexahedron": (
        (0, 3, 2, 1),
        (4, 5, 6, 7),
        (0, 1, 5, 4),
        (1, 2, 6, 5),
        (2, 3, 7, 6),
        (3, 0, 4, 7),
    ),
}


# -- geometry of the drawing ---------------------------------------------------------


def _rings(geometry: dict) -> list[np.ndarray]:
    """The rings of a GeoJSON Polygon or MultiPolygon geometry."""
    coords = geometry.get("coordinates", [])
    polygons = coords if geometry.get("type") == "MultiPolygon" else [coords]
    return [np.asarray(ring, dtype=float)[:, :2] for polygon in polygons for ring in polygon]


@numba.njit(cache=True)
def _degrees(cells, closed, degree):  # pragma: no cover (compiled)
    # sequential by nature (scatter counts); edges are keyed by their lower vertex
    k = cells.shape[1]
    for i in range(cells.shape[0]):
        for j in range(k if closed else k - 1):
            a, b = cells[i, j], cells[i, (j + 1) % k]
            degree[min(a, b)] += 1


@numba.njit(cache=True)
def _fill(cells, closed, start, filled, other):  # pragma: no cover (compiled)
    k = cells.shape[1]
    for i in range(cells.shape[0]):
        for j in range(k if closed else k - 1):
            a, b = cells[i, j], cells[i, (j + 1) % k]
            lo = min(a, b)
            other[start[lo] + filled[lo]] = max(a, b)
            filled[lo] += 1


@numba.njit(cache=True)
def _classify(start, other, px, py, min_length):  # pragma: no cover (compiled)
    # one pass over each vertex's short bucket of higher neighbours
    n = start.size - 1
    single = np.empty((other.size, 2), dtype=np.int64)
    long = np.empty((other.size, 2), dtype=np.int64)
    ns = nl = shared = 0
    for a in range(n):
        for i in range(start[a], start[a + 1]):
            b = other[i]
            seen = False
            count = 0
            for j in range(start[a], start[a + 1]):
                if other[j] == b:
                    count += 1
                    if j < i:
                        seen = True
            if seen:
                continue
            if count == 1:
                single[ns, 0], single[ns, 1] = a, b
                ns += 1
            else:
                shared += 1
                if max(abs(px[a] - px[b]), abs(py[a] - py[b])) >= min_length:
                    long[nl, 0], long[nl, 1] = a, b
                    nl += 1
    return single[:ns], long[:nl], shared


def _edges(
    blocks: list[tuple[np.ndarray, bool]], xy: np.ndarray, min_length: float
) -> tuple[np.ndarray, np.ndarray, int]:
    """Edges of cell arrays (closed cycles or open chains) over points at pixel ``xy``.

    Returns the edges held once ``(b, 2)``, the edges held more than once and
    at least ``min_length`` pixels long ``(l, 2)``, and the count of all edges
    held more than once.
    """
    n = len(xy)
    blocks = [(np.ascontiguousarray(c, dtype=np.int64), closed) for c, closed in blocks if len(c)]
    degree = np.zeros(n, dtype=np.int64)
    for cells, closed in blocks:
        _degrees(cells, closed, degree)
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(degree, out=start[1:])
    other = np.empty(start[-1], dtype=np.int64)
    filled = np.zeros(n, dtype=np.int64)
    for cells, closed in blocks:
        _fill(cells, closed, start, filled, other)
    px, py = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    return _classify(start, other, px, py, min_length)


def _view(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3D points seen from the fixed view: screen ``(n, 2)`` and depth ``(n,)`` (larger: nearer)."""
    az, el = np.radians(30.0), np.radians(25.0)
    right = np.array([np.cos(az), np.sin(az), 0.0])
    toward = np.array([np.sin(az) * np.cos(el), -np.cos(az) * np.cos(el), np.sin(el)])
    up = np.cross(toward, right)
    return points @ np.column_stack([right, up]), points @ -toward


class _Scene:
    """What a preview draws, in pixel coordinates."""

    def __init__(self, meta: dict, mesh: Mesh | None) -> None:
        fills: list[tuple[list[np.ndarray], str, str]] = []  # rings, fill, stroke
        extent: list[np.ndarray] = []
        if meta.get("domain") and "coordinates" in meta["domain"]:
            fills.append((_rings(meta["domain"]), "#f3f3f3", "#444"))
        for i, region in enumerate(meta.get("regions") or []):
            fills.append((_rings(region), _REGION_COLOURS[i % len(_REGION_COLOURS)], "#666"))
        extent += [r for rings, _, _ in fills for r in rings]
        points = depth = None
        solid = False
        if mesh is not None and len(mesh.points):
            points = np.asarray(mesh.points, dtype=float)
            solid = points.shape[1] == 3 and (
                any(CELL_TYPES[b.type][1] == 3 for b in mesh.cells) or bool(np.any(points[:, 2]))
            )
            if solid:
                points, depth = _view(points)
            points = points[:, :2]
            extent.append(points)
        axis_nodes = axis_edges = None
        if meta.get("axis"):
            axis_nodes = np.asarray(meta["axis"]["nodes"], dtype=float).reshape(-1, 2)
            axis_edges = np.asarray(meta["axis"]["edges"], dtype=np.int64).reshape(-1, 2)
            extent.append(axis_nodes)
        extent = [e.reshape(-1, 2) for e in extent if len(e)]
        if not extent:
            raise InputError(
                "this result has no domain, regions, mesh or axis to draw",
                loc=("result",),
                code="nothing_to_draw",
            )
        lo = np.min([e.min(axis=0) for e in extent], axis=0)
        hi = np.max([e.max(axis=0) for e in extent], axis=0)
        self._lo = lo
        self._scale = (SIZE - 2 * MARGIN) / max(float((hi - lo).max()), np.finfo(float).tiny)
        self.width, self.height = (hi - lo) * self._scale + 2 * MARGIN
        self.fills = [([self.tr(r) for r in rings], f, st) for rings, f, st in fills]
        self.axis = self.tr(axis_nodes)[axis_edges] if axis_nodes is not None else _NO_SEGMENTS
        self.lines = self.interior = _NO_SEGMENTS  # boundary and feature lines; other edges
        self.short = 0  # interior edges shorter than a pixel, not in ``interior``
        self.vertices = np.empty((0, 2))
        self.faces: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # 3D: xy, depth, shade
        self.note = ""
        if points is not None:
            xy = self.tr(points)
            if solid:
                self._surface(mesh, xy, depth)
            else:
                self._planar(mesh, xy)

    def tr(self, xy: np.ndarray) -> np.ndarray:
        out = (np.asarray(xy, dtype=float) - self._lo) * self._scale + MARGIN
        out[..., 1] = self.height - out[..., 1]
        return out

    def _planar(self, mesh: Mesh, xy: np.ndarray) -> None:
        faces = [(b.data, True) for b in mesh.cells if b.type in ("triangle", "quad")]
        single, long, shared = _edges(faces, xy, 1.0)
        feature = [single, *(b.data for b in mesh.cells if b.type == "line")]
        for ids in mesh.cell_sets.values():  # edges between cells of different sets
            inside = [
                (b.data[np.asarray(a, dtype=np.int64)], True)
                for b, a in zip(mesh.cells, ids, strict=True)
                if b.type in ("triangle", "quad") and len(a)
            ]
            if inside:
                feature.append(_edges(inside, xy, np.inf)[0])
        self.lines = xy[np.concatenate(feature)]
        self.interior = xy[long]
        self.short = shared - len(long)
        self.vertices = xy

    def _surface(self, mesh: Mesh, xy: np.ndarray, depth: np.ndarray) -> None:
        """The boundary faces, projected and shaded; their edges as interior lines."""
        points = np.asarray(mesh.points, dtype=float)
        polys = [b.data for b in mesh.cells if b.type in ("triangle", "quad")]
        for b in mesh.cells:
            polys += [b.data[:, list(face)] for face in _FACES.get(b.type, ())]
        light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
        segments = []
        for k in (3, 4):
            faces = [p for p in polys if p.shape[1] == k]
            if not faces:
                continue
            f = np.concatenate(faces)
            _, inverse, counts = np.unique(
                np.sort(f, axis=1), axis=0, return_inverse=True, return_counts=True
            )
            f = f[counts[inverse.ravel()] == 1]
            p = points[f]
            normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            length = np.linalg.norm(normal, axis=1)
            shade = np.abs(normal @ light) / np.where(length > 0, length, 1)
            self.faces.append((xy[f], depth[f].mean(axis=1), shade))
            segments.append(np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2))
        if segments:
            self.interior = xy[np.unique(np.sort(np.concatenate(segments), axis=1), axis=0)]
        lines = [b.data for b in mesh.cells if b.type == "line"]
        if lines:
            self.lines = xy[np.concatenate(lines)]
        self.note = "3D mesh: its boundary surface seen from azimuth 30, elevation 25 degrees. "


_NO_SEGMENTS = np.empty((0, 2, 2))


# -- SVG ------------------------------------------------------------------------------------


def _path(segments: np.ndarray) -> str:
    """SVG path data of (s, 2, 2) segments, to a tenth of a pixel."""
    if len(segments) == 0:
        return ""
    flat = np.round(segments.reshape(-1, 4), 1)
    return ("M%.1f %.1fL%.1f %.1f" * len(flat)) % tuple(flat.ravel().tolist())


def _visible(segments: np.ndarray) -> np.ndarray:
    """The segments that do not vanish at a tenth of a pixel."""
    q = np.round(segments * 10)
    return segments[np.any(q[:, 0] != q[:, 1], axis=1)]


def _decimated(segments: np.ndarray, budget: int, what: str) -> tuple[np.ndarray, str]:
    """At most ``budget`` segments: the shortest dropped first, then every k-th kept."""
    total = len(segments)
    if total <= budget:
        return segments, ""
    length = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    segments = segments[length >= 1.0]
    said = f"{what}: {total - len(segments)} of {total} shorter than 1 px left out"
    if len(segments) > budget:
        step = -(-len(segments) // budget)
        said += f", then {len(segments) - len(segments[::step])} more (every {step}th kept)"
        segments = segments[::step]
    return segments, said + "; "


def render_svg(meta: dict, mesh: Mesh | None) -> bytes:
    """An SVG document of about 2 MB at most drawing the result.

    Raises
    ------
    InputError
        ``nothing_to_draw`` when the result holds no domain, regions, mesh or axis.
    """
    scene = _Scene(meta, mesh)
    per_segment = 26  # bytes of "M123.4 567.8L123.4 567.8"
    budget = SVG_BUDGET // per_segment
    lines, said_lines = _decimated(_visible(scene.lines), budget, "boundary and feature edges")
    axis, said_axis = _decimated(_visible(scene.axis), budget - len(lines), "axis edges")
    room = max(budget - len(lines) - len(axis), 0)
    interior, said_interior = _decimated(_visible(scene.interior), room, "interior edges")
    if scene.short:
        said_interior = (
            f"interior edges: {scene.short} of {scene.short + len(scene.interior)} shorter "
            f"than 1 px left out (the mesh is finer than the drawing); " + said_interior
        )
    desc = scene.note + said_lines + said_axis + said_interior
    desc = desc or "everything is drawn"

    def polygon_path(rings: list[np.ndarray]) -> str:
        return " ".join(
            "M" + "L".join(f"{x:.1f} {y:.1f}" for x, y in ring.tolist()) + "Z" for ring in rings
        )

    body = [f"<desc>{desc.strip()}</desc>"]
    for rings, fill, stroke in scene.fills:
        body.append(
            f'<path d="{polygon_path(rings)}" fill="{fill}" stroke="{stroke}" '
            'stroke-width="1" fill-rule="evenodd"/>'
        )
    if len(interior):
        body.append(
            f'<path d="{_path(interior)}" fill="none" stroke="#1f4e79" stroke-width="0.4"/>'
        )
    if len(lines):
        body.append(f'<path d="{_path(lines)}" fill="none" stroke="#0b2540" stroke-width="1"/>')
    if len(axis):
        body.append(f'<path d="{_path(axis)}" fill="none" stroke="#c00000" stroke-width="1.5"/>')
    w, h = scene.width, scene.height
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h:.0f}" '
        f'viewBox="0 0 {w:.1f} {h:.1f}">\n' + "\n".join(body) + "\n</svg>\n"
    ).encode()


# -- PNG ------------------------------------------------------------------------------------


def _samples(segments: np.ndarray, width: int, height: int) -> np.ndarray:
    """Flat pixel indices of points along each segment, one per pixel of its length."""
    if not len(segments):
        return np.empty(0, dtype=np.int64)
    a, b = segments[:, 0], segments[:, 1]
    steps = np.maximum(np.ceil(np.abs(b - a).max(axis=1)).astype(np.int64), 1)
    owner = np.repeat(np.arange(len(segments)), steps)
    first = np.cumsum(steps) - steps
    t = (np.arange(len(owner)) - first[owner] + 0.5) / steps[owner]
    xy = a[owner] + (b - a)[owner] * t[:, None]
    x = np.clip(xy[:, 0].astype(np.int64), 0, width - 1)
    y = np.clip(xy[:, 1].astype(np.int64), 0, height - 1)
    return y * width + x


def _splat(scene: _Scene, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """3D faces: per pixel the shade of the nearest face (NaN: none) by a depth buffer."""
    shade = np.full(width * height, np.nan)
    best = np.full(width * height, -np.inf)
    for xy, depth, s in scene.faces:
        area = 0.5 * np.abs(np.cross(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]))
        count = np.clip(np.ceil(2 * area).astype(np.int64), 1, 4096)
        owner = np.repeat(np.arange(len(xy)), count)
        rng = np.random.default_rng(0)
        u, v = rng.random(len(owner)), rng.random(len(owner))
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        k = xy.shape[1]
        # a quad as two triangles (0, 1, 2) and (0, 2, 3), chosen per sample
        second = (rng.random(len(owner)) < 0.5) if k == 4 else np.zeros(len(owner), bool)
        p0 = xy[owner, 0]
        p1 = np.where(second[:, None], xy[owner, 2], xy[owner, 1])
        p2 = np.where(second[:, None], xy[owner, min(3, k - 1)], xy[owner, 2])
        p = p0 + (p1 - p0) * u[:, None] + (p2 - p0) * v[:, None]
        x = np.clip(p[:, 0].astype(np.int64), 0, width - 1)
        y = np.clip(p[:, 1].astype(np.int64), 0, height - 1)
        pix = y * width + x
        d = depth[owner]
        order = np.lexsort((-d, pix))  # per pixel, nearest first
        pix, d, own = pix[order], d[order], owner[order]
        first = np.r_[True, pix[1:] != pix[:-1]]
        pix, d, own = pix[first], d[first], own[first]
        nearer = d > best[pix]
        best[pix[nearer]] = d[nearer]
        shade[pix[nearer]] = s[own[nearer]]
    return shade, best


def render_png(meta: dict, mesh: Mesh | None) -> bytes:
    """A PNG image (800 pixels on its longer side) drawing the result.

    Raises
    ------
    InputError
        ``nothing_to_draw`` when the result holds no domain, regions, mesh or axis.
    """
    scene = _Scene(meta, mesh)
    width, height = int(np.ceil(scene.width)), int(np.ceil(scene.height))
    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    for rings, fill, stroke in scene.fills:
        for i, ring in enumerate(rings):  # holes (after the first ring) cut out again
            colour = fill if i == 0 else "white"
            draw.polygon([tuple(p) for p in ring.tolist()], fill=colour, outline=stroke)
    rgb = np.asarray(image, dtype=np.float64).reshape(-1, 3).copy()
    if scene.faces:
        shade, _ = _splat(scene, width, height)
        hit = ~np.isnan(shade)
        base = np.array([0.55, 0.7, 0.85]) * 255
        rgb[hit] = base * (0.35 + 0.65 * shade[hit, None])
    density = np.bincount(_samples(scene.interior, width, height), minlength=width * height)
    if len(scene.vertices):  # edges shorter than a pixel: their vertices shade the pixels
        x = np.clip(scene.vertices[:, 0].astype(np.int64), 0, width - 1)
        y = np.clip(scene.vertices[:, 1].astype(np.int64), 0, height - 1)
        density += np.bincount(y * width + x, minlength=width * height)
    alpha = np.minimum(density / 3.0, 1.0)[:, None] * (0.5 if scene.faces else 0.85)
    rgb = rgb * (1 - alpha) + np.array([31, 78, 121]) * alpha
    for layer, colour in ((scene.lines, (11, 37, 64)), (scene.axis, (192, 0, 0))):
        rgb[_samples(layer, width, height)] = colour
    out = Image.fromarray(rgb.reshape(height, width, 3).astype(np.uint8))
    buf = _bytesio.BytesIO()
    out.save(buf, format="PNG", compress_level=1)
    return buf.getvalue()
