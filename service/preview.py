"""SVG previews of 2D results: mesh edges, medial axis, regions, domain.

The drawing is fitted into a 800-pixel box with the y axis pointing up.
Mesh edges are deduplicated and written as one path, so a preview of a
large mesh stays one element per layer.
"""

from __future__ import annotations

import numpy as np

from meshcore.errors import InputError

SIZE = 800.0
MARGIN = 10.0
_REGION_COLOURS = ("#cfe2f3", "#d9ead3", "#fff2cc", "#f4cccc", "#d9d2e9", "#fce5cd")


def _rings(geometry: dict) -> list[np.ndarray]:
    """The rings of a GeoJSON Polygon or MultiPolygon geometry."""
    coords = geometry.get("coordinates", [])
    polygons = coords if geometry.get("type") == "MultiPolygon" else [coords]
    return [np.asarray(ring, dtype=float)[:, :2] for polygon in polygons for ring in polygon]


def _mesh_edges(mesh: dict) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(mesh["points"], dtype=float)
    if points.shape[1] == 3 and np.any(points[:, 2]):
        raise InputError(
            "the result's mesh is three-dimensional; preview.svg draws 2D results only",
            loc=("mesh",),
            code="not_2d",
        )
    edges = []
    for block in mesh["cells"]:
        data = np.asarray(block["data"], dtype=np.int64)
        if block["type"] in ("line", "triangle", "quad") and len(data):
            k = data.shape[1]
            cycle = [(i, (i + 1) % k) for i in range(k if k > 2 else 1)]
            edges.extend(data[:, list(pair)] for pair in cycle)
    if not edges:
        return points[:, :2], np.empty((0, 2), dtype=np.int64)
    all_edges = np.sort(np.concatenate(edges), axis=1)
    return points[:, :2], np.unique(all_edges, axis=0)


def _path(segments: np.ndarray) -> str:
    """SVG path data of (s, 2, 2) segments."""
    if len(segments) == 0:
        return ""
    flat = segments.reshape(-1, 4)
    return " ".join(f"M{a:.2f} {b:.2f}L{c:.2f} {d:.2f}" for a, b, c, d in flat)


def render_svg(result: dict) -> str:
    """An SVG document drawing the 2D parts of a result (domain, regions, mesh, axis).

    Raises
    ------
    InputError
        ``nothing_to_draw`` when the result holds none of them, ``not_2d``
        for a 3D mesh.
    """
    layers: list[tuple[str, list[np.ndarray]]] = []
    everything: list[np.ndarray] = []
    if result.get("domain") and "coordinates" in result["domain"]:
        rings = _rings(result["domain"])
        layers.append(("domain", rings))
        everything += rings
    regions = [_rings(r) for r in result.get("regions") or []]
    for rings in regions:
        everything += rings
    segments = np.empty((0, 2, 2))
    if result.get("mesh"):
        points, edges = _mesh_edges(result["mesh"])
        segments = points[edges]
        everything.append(points)
    axis_segments = np.empty((0, 2, 2))
    if result.get("axis"):
        nodes = np.asarray(result["axis"]["nodes"], dtype=float).reshape(-1, 2)
        axis_edges = np.asarray(result["axis"]["edges"], dtype=np.int64).reshape(-1, 2)
        axis_segments = nodes[axis_edges]
        everything.append(nodes)
    if not everything or not any(len(a) for a in everything):
        raise InputError(
            "this result has no domain, regions, mesh or axis to draw",
            loc=("result",),
            code="nothing_to_draw",
        )
    allpts = np.concatenate([a.reshape(-1, 2) for a in everything if len(a)])
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    scale = (SIZE - 2 * MARGIN) / max(float((hi - lo).max()), np.finfo(float).tiny)
    width, height = (hi - lo) * scale + 2 * MARGIN

    def tr(xy: np.ndarray) -> np.ndarray:
        out = (np.asarray(xy, dtype=float) - lo) * scale + MARGIN
        out[..., 1] = height - out[..., 1]
        return out

    def polygon_path(rings: list[np.ndarray]) -> str:
        parts = []
        for ring in rings:
            xy = tr(ring)
            parts.append("M" + "L".join(f"{x:.2f} {y:.2f}" for x, y in xy) + "Z")
        return " ".join(parts)

    body = []
    for _, rings in layers:
        body.append(
            f'<path d="{polygon_path(rings)}" fill="#f3f3f3" stroke="#444" '
            'stroke-width="1.5" fill-rule="evenodd"/>'
        )
    for i, rings in enumerate(regions):
        colour = _REGION_COLOURS[i % len(_REGION_COLOURS)]
        body.append(
            f'<path d="{polygon_path(rings)}" fill="{colour}" stroke="#666" '
            'stroke-width="1" fill-rule="evenodd"/>'
        )
    if len(segments):
        body.append(
            f'<path d="{_path(tr(segments))}" fill="none" stroke="#1f4e79" stroke-width="0.5"/>'
        )
    if len(axis_segments):
        body.append(
            f'<path d="{_path(tr(axis_segments))}" fill="none" stroke="#c00000" '
            'stroke-width="1.5"/>'
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.2f} {height:.2f}">\n' + "\n".join(body) + "\n</svg>\n"
    )
