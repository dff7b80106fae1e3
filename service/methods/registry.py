"""The method registry: one readable entry per method.

A method is a name, a pydantic params model, a function running it on
meshcore and returning the result object (DESIGN.md's fixed keys: ``mesh``,
``quality``, ``axis``, ``domain``, ``regions``, ``stats``), a summary, the
section of the methods text, and an example of valid params. The service
never grows a route per method: the request body is a discriminated union
over this table (see :func:`service.api.jobs.request_model`).

Run functions are module-level so that they pickle by reference into the
job's process.

The API process imports this module to validate and queue jobs: the method
modules hold the params models, and import meshcore's method packages only in
the checks and run functions that use them. So the API loads meshcore's
domain and surface validation, and the rest of a method's code on its first
check that needs it; the job fork server imports all of it before any job
(:data:`METHOD_CODE`, :data:`service.executors.child.PRELOAD`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from meshcore.errors import InputError as InputError  # re-exported: the API answers it as a 422
from meshcore.mesh import io, quality
from meshcore.mesh.formats import FORMATS as FORMATS  # re-exported: the download formats
from service.methods import (
    delaunay,
    grid,
    medial,
    optimize,
    partition,
    product,
    quads,
    tets,
    triangulation,
)
from service.schemas import MeshIn, MethodParams, Progress

#: The meshcore modules that the method modules import only in their checks and run
#: functions (tests/service/test_imports.py keeps this list whole): the job fork server
#: imports them before any job (:data:`service.executors.child.PRELOAD`).
METHOD_CODE = (
    "meshcore.delaunay",
    "meshcore.delaunay.admissible",
    "meshcore.delaunay.admissible3d",
    "meshcore.grid.cartesian",
    "meshcore.grid.patterns",
    "meshcore.grid.superposition",
    "meshcore.medial.axis",
    "meshcore.medial.partitioning",
    "meshcore.medial.simplification",
    "meshcore.medial.transform",
    "meshcore.optimize",
    "meshcore.partition",
    "meshcore.product.extrusion",
    "meshcore.product.merge",
    "meshcore.product.radial_mesh",
    "meshcore.quads",
    "meshcore.quads.combination",
    "meshcore.tets",
    "meshcore.tets.sizing",
    "meshcore.triangulation.refinement",
)


def mesh_of_file(data: bytes, filename: str) -> dict:
    """The JSON mesh of DESIGN.md read from a file in any format meshio reads.

    The reader is picked by ``filename``'s suffix. Raises :class:`InputError`:
    ``unsupported_format`` (no reader for the suffix), ``unreadable_file``,
    ``no_cells``, or a mesh check's code (see :func:`meshcore.mesh.io.from_file`).
    """
    return io.to_json(io.from_file(data, filename))


@dataclass(frozen=True)
class MethodSpec:
    """One method of the service."""

    name: str
    summary: str
    section: str
    params: type[MethodParams]
    run: Callable[[Any, Progress], dict]
    example: dict


Registry = dict[str, MethodSpec]

_UNIT_SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}


class QualityParams(MethodParams):
    mesh: MeshIn


def run_quality(params: QualityParams, progress: Progress) -> dict:
    """The quality report of DESIGN.md for the given mesh."""
    return {"quality": quality.report(params.mesh.to_mesh(), progress=progress)}


def default_registry() -> Registry:
    """The product's methods, by name."""
    specs = [
        MethodSpec(
            name="quality",
            summary="Quality report of a mesh: per cell type counts, invalid cells, "
            "quality and angle statistics, conformity.",
            section="§8.3.1 (conformity), §8.4.4 (quad quality); DESIGN.md quality measures",
            params=QualityParams,
            run=run_quality,
            example={"mesh": _UNIT_SQUARE},
        ),
        MethodSpec(
            name="extrude",
            summary="Product mesh: a base mesh of points, lines, triangles and quads swept along "
            "a translation, rotation, helix, affine maps or explicit sections into lines, quads, "
            "wedges and hexahedra (or simplices), with degeneracies on the axis resolved and "
            "validity checked; cell sets bottom, top, side.",
            section="§8.1.1-§8.1.3 (product method), Figures 8.1, 8.2, 8.5",
            params=product.ExtrudeParams,
            run=product.run_extrude,
            example=product.EXTRUDE_EXAMPLE,
        ),
        MethodSpec(
            name="sweep",
            summary="Semi-automatic product mesh between a source section and a target section: "
            "interior vertices of every intermediate section from a background mesh, "
            "barycentric interpolation and distortion correction.",
            section="§8.1.2 (semi-automatic method)",
            params=product.SweepParams,
            run=product.run_sweep,
            example=product.SWEEP_EXAMPLE,
        ),
        MethodSpec(
            name="merge",
            summary="Merge meshes: coincident points joined, duplicated interface facets "
            "dropped; fails at a hanging node or any non-conforming interface.",
            section="§8.1.4 (Figure 8.5, right: product meshes merged)",
            params=product.MergeParams,
            run=product.run_merge,
            example=product.MERGE_EXAMPLE,
        ),
        MethodSpec(
            name="radial",
            summary="Radial mesh of a disk, ring or sector: the classical product mesh, or "
            "balanced by collapsing ring edges (quads, triangles where the count changes).",
            section="§8.7.1 (radial meshes), Figure 8.16",
            params=product.RadialParams,
            run=product.run_radial,
            example=product.RADIAL_EXAMPLE,
        ),
        MethodSpec(
            name="triangulate",
            summary="Boundary-conforming quality triangle mesh of a planar domain (holes, "
            "constraints): every input segment a chain of edges, refined to a smallest angle, "
            "largest area, edge length or size field; optionally empty or with the boundary kept.",
            section="§9.1 (admissible boundaries), §8.2 (pattern), Remark 8.10 (size field)",
            params=triangulation.TriangulateParams,
            run=triangulation.run_triangulate,
            example=triangulation.TRIANGULATE_EXAMPLE,
        ),
        MethodSpec(
            name="delaunay",
            summary="Delaunay triangulation (2D points) or tetrahedralization (3D points) of a "
            "point set with exact predicates, co-circular and co-spherical ties broken by "
            "symbolic perturbation; the convex hull's facets as cell set hull.",
            section="§9.1, §9.2-§9.3 (Delaunay triangulation, empty spheres)",
            params=delaunay.DelaunayParams,
            run=delaunay.run_delaunay,
            example=delaunay.DELAUNAY_EXAMPLE,
        ),
        MethodSpec(
            name="delaunay_admissible",
            summary="Delaunay-admissible boundary discretization: a domain's segments (2D) split "
            "at projections of encroaching points (on declared circles for curved rings) until "
            "every one is a Delaunay edge, or a closed surface's triangles (3D) refined with "
            "points on the surface until every one is a Delaunay face; per-case counts and the "
            "empty Delaunay triangulation (tetrahedralization) of the inside; in 3D also the "
            "Delaunay tetrahedralization holding the surface, with its co-spherical tie cells.",
            section="§9.1.2-§9.1.5 (classification, splitting, curves), Exercises 9.2-9.4; "
            "§9.4.1; §9.2-§9.3.5 (surfaces)",
            params=triangulation.DelaunayAdmissibleParams,
            run=triangulation.run_delaunay_admissible,
            example=triangulation.DELAUNAY_ADMISSIBLE_EXAMPLE,
        ),
        MethodSpec(
            name="tetrahedralize",
            summary="Tetrahedra filling a closed triangulated surface (bodies, cavities): exact "
            "3D Delaunay, conforming boundary recovery (points on the surface; with "
            "keep_boundary, interior points only: one for a star-shaped region, else the "
            "recovery's surface points moved inside), Delaunay refinement "
            "to a radius-edge, volume and size bound, then optionally flips, smoothing and "
            "insertion to a least dihedral angle; a cell set per region.",
            section="§9.2, §9.3.4-§9.3.5 (edges then faces, points on the surface), §9.5",
            params=tets.TetrahedralizeParams,
            run=tets.run_tetrahedralize,
            example=tets.TETRAHEDRALIZE_EXAMPLE,
        ),
        MethodSpec(
            name="quad_combine",
            summary="Quad mesh by triangle combination: pairs chosen by a stack path, a heap, "
            "a front or a matching (fewest triangles left), weighted by quad quality (metric "
            "optional); optionally only quads (split), and optimized by the quad operators and "
            "smoothing. Planar meshes, surfaces or a domain meshed first.",
            section="§8.4 (8.4.1-8.4.5), Figures 8.12, 8.13, Remarks 8.3-8.8",
            params=quads.QuadCombineParams,
            run=quads.run_quad_combine,
            example=quads.QUAD_COMBINE_EXAMPLE,
        ),
        MethodSpec(
            name="grid",
            summary="Grid mesh of a planar domain (holes, constraints): squares of a placed, "
            "rotated grid; boundary cells kept whole (staircase, with its area and Hausdorff "
            "errors), fitted (nodes snapped, cut cells split by templates, the domain covered "
            "exactly) or split into triangles; interior cells perfect squares or their halves.",
            section="§8.2 (grid methods, steps 1-3)",
            params=grid.GridParams,
            run=grid.run_grid,
            example=grid.GRID_EXAMPLE,
        ),
        MethodSpec(
            name="pattern",
            summary="Pattern-based mesh: parallelogram, hexagon or radial patterns strictly "
            "inside and away from the boundary kept, the gap to the boundary meshed by "
            "triangulate with their outline kept (or all quads), merged; cell sets pattern, gap.",
            section="§8.2 (Figures 8.6, 8.7)",
            params=grid.PatternParams,
            run=grid.run_pattern,
            example=grid.PATTERN_EXAMPLE,
        ),
        MethodSpec(
            name="quad_grid",
            summary="All-quad mesh by grid superposition: the grid's inner squares kept, the band "
            "along the boundary triangulated with their outline kept and turned into quads "
            "(combination, all_quad), optionally smoothed; only quads, exact area, corners kept.",
            section="§8.5.2 (grid superposition), §8.2, Figure 8.13",
            params=grid.QuadGridParams,
            run=grid.run_quad_grid,
            example=grid.QUAD_GRID_EXAMPLE,
        ),
        MethodSpec(
            name="optimize",
            summary="Optimization-based meshing (Coupez): triangles generated from a domain's "
            "boundary, or a tangled triangle or tetrahedral mesh made valid with the same "
            "boundary, or a valid one's worst quality raised, by replacing balls, pairs and "
            "larger sub-topologies with Op(P, δS) while Sur decreases; Sur series in stats.",
            section="§8.3 (Definition 8.1, (8.1)-(8.2), §8.3.2-§8.3.5, Figures 8.9-8.11)",
            params=optimize.OptimizeParams,
            run=optimize.run_optimize,
            example=optimize.OPTIMIZE_EXAMPLE,
        ),
        MethodSpec(
            name="paving",
            summary="All-quad mesh by paving: the boundary resampled with even rings, rows of "
            "quads laid from the boundary inward (row ends, sides, corners, seams), every row "
            "checked by exact front-front intersection tests, fronts that meet joined by strips "
            "of quads between facing nodes, the rest closed by even recursive partition, "
            "smoothed without inverting; only quads.",
            section="§8.5.1 (advancing-front quads), Remark 8.9",
            params=quads.PavingParams,
            run=quads.run_paving,
            example=quads.PAVING_EXAMPLE,
        ),
        MethodSpec(
            name="recursive_partition",
            summary="Triangles or quads by recursive partition: separators between boundary "
            "vertices tested exactly, ranked by balance and angles, subdivided by the size "
            "map; holes joined first; recursion to triangles or to convex quads (even parts). "
            "With a surface: tetrahedra, separator surfaces through cycles of surface edges, "
            "every input triangle a face, one Steiner point where a part cannot be cut.",
            section="§8.7.2 (recursive partition), Remark 8.10",
            params=partition.RecursivePartitionParams,
            run=partition.run_recursive_partition,
            example=partition.RECURSIVE_PARTITION_EXAMPLE,
        ),
        MethodSpec(
            name="medial_axis",
            summary="Medial axis of a polygon (holes allowed) or of a boundary point cloud: "
            "circumcentres of the empty Delaunay triangulation joined across interior edges, "
            "spurious branches pruned; nodes with radii, critical and terminal nodes, branches; "
            "downloadable as a line mesh with the radius.",
            section="§9.4.1-§9.4.3 (Theorem 9.1, Figures 9.9-9.12, Remarks 9.10-9.14), §9.7.4",
            params=medial.MedialAxisParams,
            run=medial.run_medial_axis,
            example=medial.MEDIAL_AXIS_EXAMPLE,
        ),
        MethodSpec(
            name="medial_transform",
            summary="Medial axis transform: the domain rebuilt as the union of the disks of a "
            "medial axis, with the Hausdorff distance to the original boundary.",
            section="§9.6",
            params=medial.MedialTransformParams,
            run=medial.run_medial_transform,
            example=medial.MEDIAL_TRANSFORM_EXAMPLE,
        ),
        MethodSpec(
            name="partition",
            summary="Domain partition along cut lines of the medial axis, by either method of "
            "the text: polygonal regions of 3 to 6 sides that tile the domain.",
            section="§9.7.1 (Figure 9.13)",
            params=medial.PartitionParams,
            run=medial.run_partition,
            example=medial.PARTITION_EXAMPLE,
        ),
        MethodSpec(
            name="quad_medial",
            summary="All-quad mesh from the medial-axis partition: midpoint subdivision of each "
            "region, then repeated subdivision or a conforming transfinite fill at a size.",
            section="§9.7.2 (Figure 9.14), §8.5.3",
            params=medial.QuadMedialParams,
            run=medial.run_quad_medial,
            example=medial.QUAD_MEDIAL_EXAMPLE,
        ),
        MethodSpec(
            name="simplify",
            summary="Geometry simplification: holes and boundary details (notches, protrusions, "
            "fillets, steps) small against the local radius of the medial axis removed.",
            section="§9.7.4 (geometry simplification), Remark 9.15",
            params=medial.SimplifyParams,
            run=medial.run_simplify,
            example=medial.SIMPLIFY_EXAMPLE,
        ),
    ]
    return {s.name: s for s in specs}
