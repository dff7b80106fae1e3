r"""All-quad meshes by paving: rows of quads from the boundary inward (§8.5.1).

After Blacker and Stephenson: no triangle mesh is made first; rows of quads
are laid on the closed fronts, starting from the boundary.

Algorithm
---------
1. **Boundary** (Remark 8.9): every ring resampled to the size map with an
   even number of segments (:func:`~meshcore.partition.boundary.resample_boundary`;
   an odd ring gets one more split where it costs least in size error, and
   ``stats["parity_repairs"]`` says where). The rings are the first fronts.
2. **Rows.** Each front node is classified by its interior angle ``a``:
   *row end* (``a < 135``), *side* (``135 <= a < 225``), *corner*
   (``225 <= a < 315``) and *reversal* (``a >= 315``). A side node gets one
   new node on its bisector at distance ``h / sin(a / 2)`` (at most
   ``2 h``); a row end gets none: its two neighbours share one new node
   (the parallelogram on them), closing the row there with one quad; a
   corner gets three (``h`` along the normals of its two edges and their
   parallelogram), so three quads turn around it; a reversal gets five
   (the two normals, the normal half-way between them, and the two
   parallelograms), so four quads turn around it. Row ends closer than
   three nodes apart are demoted to sides. *Wedges*: where the new front
   would stretch (a new edge longer than ``1.15 h``, as on a front growing
   out of a hole), one side node per ``2 h`` of excess length gets the
   corner's three nodes spread along the front (a kite, ``h / 2`` either
   side and ``1.3 h`` ahead). A front node count changes by ``-2`` per row
   end and ``+2`` per corner, reversal or wedge: every front stays even.
   In a row with wedges the new front is evened out before the checks
   (``_RELAX`` Jacobi sweeps moving each side node, and each wedge's two
   side nodes, half-way to the midpoint of its neighbours along the new
   front): else the kite is a bump whose nodes the next row reads as
   corners, each adding two more nodes (a front growing out of a hole went
   124, 146, 190 nodes in three rows and froze).
3. **Seams, merges and splits** (the fronts are chains of directed edges;
   the front left after a row is the old fronts minus the boundaries of
   the new quads, opposite edges cancelling, traced into cycles). A new
   node within ``0.6 h`` of a node ``t`` is snapped to it when ``t`` is a
   node of another front (the two fronts *merge*), a node of its own front
   outside its own quads (a thin gap is closed and the front *splits*; the
   row's own quads at ``t`` are dropped), or another new node of the row
   (both to their midpoint: the front splits, or, two nodes apart, it is
   the *seam* of a fold of the front below about 60 degrees). Snaps are
   kept only in runs (a neighbour along the new front snapped to the
   matching neighbour of ``t``), so the joined fronts share an edge that
   cancels and no front ever touches itself at a single node; a fold seam
   cancels the two edges of the fold. New nodes closer than ``0.4 h`` to
   the next one are seamed in pairs (the front stays even), each seam
   kept only when the quads stay strictly convex. A *front of two
   segments* is one edge and its reverse: it cancels, which closes it.
4. **Checks before commit** (exact :func:`orient2d`;
   :mod:`meshcore.quads.paving_checks`): every quad of the row
   strictly convex and of quality (8.4) at least 0.1; no new edge touches a
   front edge or another new edge except at a shared node; no front node
   or new node inside a new quad; every new node at least ``0.5 h`` from
   the nodes not of its quads and ``2 h`` from those of other fronts
   (unless its quad joins that front): rows stop short of each other so
   that the region left between them stays closable; the fronts left are
   simple even cycles of at least 4 nodes. A row failing on at most
   ``_RETRY_BAD`` quads is laid again (up to ``_RETRIES`` times) with the
   front nodes of the failed quads made sides (their corner, reversal,
   wedge or row end given up), and without its snaps when a failed quad has
   a snapped node; so is a row failing on at most ``_RETRY_SHARE`` of its
   quads. A row whose failed quads (still failing after the retries, or with
   nothing left to give up while at most ``_STUCK_SHARE`` of its quads)
   fail only the ``2 h`` gap to other fronts, and are at most ``_PARTIAL``
   of its quads, or are at most ``_FEW_BAD`` of them whatever they fail, is
   committed without them (a *partial row*: the front stops short there and
   goes on elsewhere; a set of quads passing the checks overlaps nothing,
   and the trace below checks the fronts left). Measured side by side at 10k
   quads: the square with a hole mean quality 0.952 -> 0.961, valence-4 share 96.4 -> 97.8 %; the
   plate with 20 holes 0.881 -> 0.897, 87.5 -> 90.0 %, least scaled
   Jacobian 0.734 -> 0.744 (its outer front froze at its second row by the
   holes); the gear, the L unchanged. The ``_FEW_BAD`` rule (5 %), measured
   side by side: the plate at 100k quads mean quality 0.927 -> 0.940,
   valence-4 share 92.7 -> 95.0 %, least scaled Jacobian 0.771 -> 0.763; the
   square with a hole at 100k 0.988 -> 0.990, 98.99 -> 99.38 %, 0.809 ->
   0.766; the plate at 10k 0.894 -> 0.896, 90.4 -> 90.1 %; the gear, the L
   and the square with a hole at 10k about unchanged; at 30k and 50k quads
   the plate 88.1 -> 92.3 % and 89.5 -> 93.8 %, the gear at 50k 96.4 ->
   97.6 %, the square with a hole 99.1 -> 98.9 % and 99.2 -> 99.1 %. It
   costs rows tried (more fronts freeze and meet): CPU s at 100k quads, the
   plate 5.25 -> 6.54, the square with a hole 1.75 -> 2.02. The share is erratic:
   at 4 % the plate's least scaled Jacobian was 0.707, at 8 % the gear at
   100k quads lost 4.5 points of valence-4 share (its rows stepped where
   they met). Any other row that still fails is
   not committed and its front is *frozen* (it is unfrozen when a merge
   makes it part of a new front). After strips (step 5) every front is
   active again, but one whose row failed is not tried again while the
   front edges near it (those meeting the box its row looked at, from
   :func:`_try_row`) are the same: the row would fail the same way (on the
   plate with 20 holes at 100k quads 183 of 690 rows tried were such
   repeats, every one failing; the meshes are unchanged). A front is frozen too when it has 8
   nodes or fewer, or after ``max_rows`` rounds.
5. **Fronts meeting: strips** (a choice of this module; the text leaves
   the meeting of fronts open). Rows stop ``2 h`` short of other fronts,
   so fronts that meet face each other across a band. A *rung* joins two
   front nodes that are each other's nearest facing node (each within
   ``_LADDER_TURN`` degrees of the other's inward bisector, on another
   front or at least 4 nodes away on the same one); a *strip* grows from a
   rung along both fronts, ``(a, b)`` to ``(succ a, pred b)``, while the
   quad between two rungs is strictly convex (exact) of quality at least
   ``_LADDER_Q`` and the new rung between 0.4 and 2.5 times the first
   (``_LADDER_TAPER``), then passes the row checks (step 4); a strip of rungs
   about ``k h`` long is a ``k``-wide grid (rungs cut in ``k`` parts; the
   end rungs bowed into the strip so that the front left has no flat
   vertex). ``k`` is ``round(length / h)``, or one more or less when that
   is needed to leave even fronts (the chain arithmetic of step 3 cuts the
   strip out; a strip between two fronts merges them, one across a thin
   front splits or closes it). The taper bound: every rung is cut in as
   many parts as the median rung is long, so a strip of rungs of very
   different lengths left runs of edges down to ``0.2 h`` and slivers no
   closure pattern fits (the plate with 20 holes at 100k quads took back
   29 rows for them); with it, measured side
   by side (mean quality, valence-4 share, least scaled Jacobian, CPU s):
   the plate at 100k quads 0.902 -> 0.914, 88.0 -> 90.3 %, 0.720 ->
   0.681, 20.8 -> 10.5 s (no row taken back); the square with a hole at
   100k 0.978 -> 0.987, 97.4 -> 98.9 %, 0.758 -> 0.797, 3.9 -> 2.3 s; the
   gear at 100k 0.963 -> 0.969, 96.9 -> 98.1 %, 0.755 -> 0.658; at 10k the
   plate 0.897 -> 0.887, the gear 0.933 -> 0.936, the hole 0.961 -> 0.963
   (a bound of 0.6 to 1.7 lowered the plate at 10k to 0.877). When every
   front is frozen, strips across
   gaps up to ``_MEET_REACH h`` are laid and the rows go on from the fronts
   left (``stats["strips"]``, at most ``_MEETINGS`` times); at the closure,
   strips across bands up to ``_LADDER_REACH h`` wide
   (``stats["ladders"]``), made again without the front nodes of a polygon
   the partition is stuck on, up to ``_LADDER_TRIES`` times (2: over the
   paving tests and the benchmark's domains at 2k to 100k quads a third or
   fourth try never closed what the second left stuck, and each costs a
   whole closure: the plate at 100k quads took 18.7 s of CPU with 4 tries,
   15.2 s with 2, the same mesh).
6. **Closure.** Each counter-clockwise front left is an outer ring, each
   clockwise one a hole of the smallest outer ring around it; the
   polygons without holes of at least 12 nodes whose corners (below 135
   degrees) allow it are closed by a midpoint subdivision into grids
   (:mod:`meshcore.quads.paving_templates`: 3 or 5 structured patches
   around one centre, or one grid for 4 sides with equal opposite counts;
   ``closure.templates``): the corner pockets left between the rows of a
   square and of a round hole in it, which the partition filled with
   irregular vertices (measured side by side, valence-4 share of the
   interior vertices: the square with a hole at 100k quads 98.93 -> 98.99
   %, the plate with 20 holes 92.22 -> 92.71 %, the gear 98.27 -> 98.57 %;
   at 10k quads the plate 89.17 -> 90.42 %, mean quality 0.890 -> 0.894,
   the hole 98.08 -> 98.10 % with its least scaled Jacobian 0.813 ->
   0.811, the gear unchanged: no polygon fitted).
   The others are closed by the recursive partition in its quad mode
   (:func:`meshcore.partition.partition_polygon`, which keeps the front
   nodes): fronts of 4 and 6 segments are its standard patterns (one quad;
   two quads or three around a centre), larger ones are cut by separators
   into even parts first. The partition hands back the sub-polygons it is
   stuck on (of a polygon with holes too: the holes bridged,
   ``partition_polygon(..., leave_stuck=True)``) and meshes the rest; each
   stuck sub-polygon gets a ring of quads around a shrunk copy of itself
   (the copy closed by the partition), or else the guaranteed route
   locally: every other vertex a coarse polygon, triangulated, each
   triangle cut in three quads through the skipped vertices and new
   midpoints (``closure.rings``, ``closure.coarse_splits``); each only when
   all its quads are strictly convex (exact) of quality at least
   ``_MIN_Q``. When both fail it becomes a *cavity*: the quads sharing an
   edge with it (rows, strips, the closure's own) are taken out and the
   union closed again, one ring of quads wider at a time, up to three
   (``closure.cavities``; :mod:`meshcore.quads.paving_fronts`); a polygon
   a ring closes is rather a cavity when the partition closes one (the
   ring's valence-3 corners were the least sines at 100k quads). When a
   piece is still stuck, the strips' last try closes the polygons one by
   one, and a polygon (without holes) still stuck
   gets the guaranteed route locally: its coarse split with the coarse
   triangles at 2.5 times the size (``closure.polygon_splits``; the stuck
   pieces are slivers between two separators from nearly one point, which no
   quad of quality ``_MIN_Q`` fits). Before, such a piece took the rows back
   (below): on the plate with 20 holes at 10k quads all but 3,128 of 7,547
   row quads, mean quality 0.860; now 0.876, valence-4 share 82.7 % ->
   86.4 %, no irregular boundary vertex (was 2), but the least scaled
   Jacobian 0.705 -> 0.664 (0.734, mean 0.881, valence-4 87.5 %, since the
   partition takes no quad separator within 17 degrees of an edge). When the
   rows leave more than half the domain's area, and over 20,000 cells of the
   least size, to the closure (the gear at 100k quads: its fronts freeze
   between the teeth after a few rows), the closure is not tried: the rows
   are laid again from the boundary with *every* new front evened out as in
   step 2 (not only rows with wedges; ``stats["evened"]``), and only when
   that stops early too (or its closure is stuck to the end) is the
   guaranteed route below taken. Evening out every row smooths the kinks a
   seam or a snap leaves, which the next row reads as corners or reversals
   whose quads then fail (on the gear at 100k quads the outer front froze at
   round 6 on 27 failed quads in the tooth roots): the gear at 100k gets
   105 rows instead of 39, mean quality 0.967 instead of 0.935 (the
   guaranteed route), 2.5 % irregular interior vertices instead of 8.4 %.
   It is not the default for every row: measured so, the plate with 20
   holes at 10k quads lost 0.020 of mean quality and the square with a hole
   at 100k 0.011 (its least scaled Jacobian 0.60 -> 0.54).
7. **Smoothing** (``smooth``):
   :func:`~meshcore.partition.smoothing.smooth_quads`, one compiled
   Gauss-Seidel loop: the length-weighted Laplacian of Blacker and
   Stephenson on the interior points, with their boundary angle correction
   (a point joined to a boundary point is also pulled to where its edge
   splits the boundary angle evenly), each move tried at 1, 1/2, 1/4 of
   its step and kept only when every quad around the point stays strictly
   convex (exact test) and its least quality (8.4) does not drop below
   ``min(old, max(0.5, least of the mesh))``. It never inverts a cell nor
   lowers the least quality.
8. **Clean-up** (``smooth``): the quads below quality 0.85 or at an
   interior point of valence other than 4 (the closure's region, mostly),
   with two rings of quads around them, go through
   :func:`~meshcore.quads.optimize_quads` (§8.4.3: valence-2 and valence-3
   removal, doublet collapse, hexagon rebuilds, edge swaps, smoothing; every
   cell strictly convex, the least quality never lowered). The border of
   that region is kept, so it fits back in place. The paving literature
   follows paving by such a clean-up (Canann, Muthukrishnan, Phillips,
   "Topological improvement procedures for quadrilateral finite element
   meshes", 1998); measured on the square with a hole at 10k quads it
   lifts the least quality from 0.37 (smoothing alone) to 0.55 and the
   interior valence-4 share from 95.7 % to 96.7 %.
9. **Corners squared** (``smooth``):
   :func:`~meshcore.partition.smoothing.square_corners`, ``_SQUARE_SWEEPS``
   Gauss-Seidel sweeps of steepest descent at each free point on the sum,
   over the quads around it, of the 4-norm of their corners' ``cos^2``,
   under the same acceptance rule as the smoothing (never inverting a cell
   nor lowering the least quality). The Laplacian evens out lengths but
   leaves skewed corners next to the irregular points of the closure, the
   strips and the wedges; at 10k quads this lifts the mean quality (8.4) of
   the plate 0.866 -> 0.896, the gear 0.914 -> 0.932, the square with a
   hole 0.950 -> 0.960.

Why it always ends with only quads
----------------------------------
*The rows end.* A round that commits no row freezes every active front,
and a frozen front is made active again only by a merge, which happens
inside a committed row or a round of strips (step 5), and there are at
most ``_MEETINGS`` of those; so the rounds go on only while rows are
committed. Each row lays quads of quality at least 0.1 (corners between
9 and 171 degrees) inside the region left (step 4), about ``h`` deep, so
the region shrinks by about ``h`` a round; as a guard that does not rest
on that estimate, the rounds stop after ``4 D / h_min + 16`` (``D`` the
diagonal of the domain's box, ``h_min`` the least size).

*Only quads, every front even.* Rows add only quads, each checked strictly
convex. The total count of front segments stays even (each quad toggles
four edges), and the trace refuses any odd cycle, so every front handed to
the closure is even (Remark 8.9).

*The closure ends with quads.* It works on even polygons; when the
recursive partition finds one without a valid even split (it can: flat
vertices, see :mod:`meshcore.partition.recursive`) and neither a ring, a
coarse split nor a cavity closes it, nor the coarse split of its whole
polygon (each covers its polygon exactly: the
winding-number argument of :mod:`meshcore.quads.paving_fronts`), the
*guaranteed route* is taken instead (first the rows are taken back, one round, then two,
four... more, the closure retried each time, ending with no row at all:
the partition of the resampled boundary; then the same with every row
evened out, step 6): the whole paving is run again
at 2.5 times the size with the region closed by triangles (the recursive
partition's triangle mode always succeeds on a polygon with holes), then
every quad is cut into four and every triangle into three through the
edge midpoints and the cell's centre (§8.4, Figure 8.13). Shared midpoints
keep it conforming, the pieces of a strictly convex quad or of a triangle
are strictly convex, and the boundary is split at the midpoints of its
segments. The median edge then comes out near the size (a triangle of
side ``H`` gives half edges ``H / 2`` and spokes ``0.29 H``).
``stats["fallback"]`` counts it (0 or 1).

*Strips, rings and coarse splits* add only strictly convex quads (exact)
whose boundary chain is the front edges they remove plus the new front
edges, so by the winding number they cover exactly the region they take
out; they are kept only when the fronts left are simple even cycles.

Not done: fronts that meet with counts far apart are paired only where
their nodes face each other (strips); the junctions between strips, and
bands wider than ``_LADDER_REACH h``, are closed by the partition, which is
where the irregular vertices are; the rows still freeze a whole front when
more than ``_FEW_BAD`` of a row fails for another reason than the gap
(committing every quad that passes, leaving steps in the front, was tried
with no bound on the share: the steps make the next rows
fail around them, and on the plate at 10k quads it took 15 s for a lower
mean quality; partial rows on gap failures above a quarter of the row
lowered the gear's mean quality at 10k quads 0.933 -> 0.927; a partial row
also when the failed quads' front nodes are all sides already, before the
retries run out, lowered the plate's 0.887 -> 0.864 and raised the square
with a hole's 0.963 -> 0.970).
Interior constraint segments are refused.

Dense boundaries
----------------
(A choice of this module.) Every input vertex stays a mesh vertex, so a ring
sampled far below the size (a circle of 100,000 vertices meshed at size 0.05)
makes fronts whose nodes have thousands of neighbours within the rows'
clearance and the strips' reach: the row checks and strips would hold
billions of neighbour pairs (the 100,000-vertex circle ran out of 8 GB), and
rows of such slivers fail their clearance checks anyway (an 8,000-vertex
circle at 0.05 took the guaranteed route, 40 s and 1.5 GB). A grading
of the size away from the boundary would be the way to mesh it; it is not
done: such a domain is refused before any work (:func:`_dense_boundary`,
``code="boundary_denser_than_size"``, located at the domain), when the pairs
along its rings would exceed ``_PAIRS``.

Local coordinates
-----------------
(A choice of this module.) The paving runs on the domain moved to the least
corner of its box and scaled by its diagonal (:func:`_local`), and its points
are moved back at the end, the input vertices restored as given: every
length, threshold and tie is then the same wherever and at whatever scale the
domain is given, up to the rounding of the input itself.

References
----------
Methods text §8.5.1 (advancing-front quads), Remark 8.9 (even counts);
T. D. Blacker, M. B. Stephenson, "Paving: a new approach to automated
quadrilateral mesh generation", IJNME 32 (1991).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from meshcore.domain.planar import as_domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.quality import quad_quality
from meshcore.mesh.topology import isin_ints, unique_edges, unique_ints
from meshcore.partition import (
    SizeMap,
    boundary_edges,
    boundary_points,
    partition_polygon,
    resample_boundary,
    size_map,
    smooth_quads,
    square_corners,
)
from meshcore.partition.recursive import FALLBACK_SCALE, stuck_error
from meshcore.partition.smoothing import SWEEPS
from meshcore.quads import paving_kernel as pk
from meshcore.quads.optimization import optimize_quads
from meshcore.quads.paving_checks import _front_table, _good_quads
from meshcore.quads.paving_fronts import (
    _angles,
    _chains,
    _close,
    _polygons,
    _pred,
    _succ,
    _trace,
)
from meshcore.quads.splitting import split_all

__all__ = ["PavingResult", "clean_up", "paving"]

_END, _SIDE, _CORNER, _REVERSAL, _WEDGE = 0, 1, 2, 3, 4
_STRETCH = 1.15  # a new front edge longer than this times h counts toward a wedge
_SMALL_FRONT = 8  # fronts with this many nodes or fewer go to the closure
_SEAM = 0.4  # new nodes closer than this times h are seamed
_SNAP = 0.6  # a row's new node this close (times h) to a node of a front joins it
_LADDER_REACH = 6.5  # facing front nodes this far apart (times h) may be joined by a rung
_LADDER_TURN = 38.0  # ... when each lies within this many degrees of the other's bisector
_LADDER_Q = 0.35  # least quality (8.4) of a ladder's quad
_LADDER_TAPER = (0.4, 2.5)  # a strip's rungs stay within these times its first rung
_MEET_REACH = 2.6  # between rows, strips join fronts this close (times h)
_MEETINGS = 8  # rounds of strips between rows at most
_BOW = 0.2  # a strip's end rungs bow this far (times the distance between rungs) inward
_LADDER_TRIES = 2  # strips made at most this many times (again around stuck polygons)
_CLEAN_Q = 0.85  # quads below this quality (8.4) seed the clean-up region
_CLEAN_RINGS = 2  # rings of quads around the seeds in the clean-up region
_SQUARE_SWEEPS = 10  # sweeps of square_corners after the clean-up
_RELAX = 3  # sweeps evening out a new front (wedges) before its checks
_RETRIES = 2  # a failed row tried again this many times with its failed nodes made sides...
_RETRY_BAD = 12  # ... when at most this many of its quads failed...
_RETRY_SHARE = 0.04  # ... or this share of them
_STUCK_SHARE = 0.06  # a row with nothing left to give up is laid partially up to this share
_PARTIAL = 0.25  # a row failing only on the gap, on at most this share of its quads, stops there
_FEW_BAD = 0.05  # ... and so does one failing on at most this share, on any check
_LEFT_SHARE = 0.5  # rows leaving more than this share of the area to the closure...
_LEFT_CELLS = 20000  # ... and more than this many cells of the least size: guaranteed route
_TIE = 1e-6  # lengths within this share of each other tie (broken by index)
_PAIRS = 2e7  # neighbour pairs along the boundary rings within _LADDER_REACH h at most


@dataclass(frozen=True)
class PavingResult:
    """Result of :func:`paving`.

    Attributes
    ----------
    mesh : Mesh
        Only quads, counter-clockwise, strictly convex, conforming.
    quality : dict
        :func:`meshcore.mesh.quality.report` of the mesh.
    stats : dict
        ``rows``, ``row_quads``, ``node_classes`` (end, side, corner,
        reversal, wedge counts over all rows), ``seams``, ``snaps`` (new
        nodes joined to a node), ``merges`` (fronts joined to another),
        ``splits`` (fronts cut in two), ``frozen`` (fronts frozen
        by a failed check), ``partial_rows`` (rows committed without the
        quads failing only the gap), ``strips`` and ``strip_quads`` (laid between
        rows), ``ladders`` and ``ladder_quads`` (strips laid at the closure),
        ``rows_taken_back``, ``closure`` (the partition's stats: patterns,
        separators; ``templates``, ``rings``, ``coarse_splits``, ``cavities``,
        ``polygon_splits``), ``evened`` (1 when the
        rows were laid again with every new front evened out, module
        docstring step 6), ``fallback``,
        ``parity_repairs``, ``valence`` (histogram of interior vertex
        valences), ``smoothing`` (sweeps, moves undone),
        ``clean_up`` (``region``: quads handed to the clean-up,
        ``operators``: applications), ``seconds`` per phase.
    """

    mesh: Mesh
    quality: dict
    stats: dict = field(default_factory=dict)


def _turned(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The vectors v turned by the angles t counter-clockwise."""
    c, s = np.cos(t), np.sin(t)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])


def _classify(theta: np.ndarray) -> np.ndarray:
    deg = np.degrees(theta)
    cls = np.full(len(theta), _SIDE)
    cls[deg < 135] = _END
    cls[(deg >= 225) & (deg < 315)] = _CORNER
    cls[deg >= 315] = _REVERSAL
    # row ends need side neighbours and at least two nodes between them
    n = len(cls)
    for i in np.flatnonzero(cls == _END):
        for d in (1, 2):
            for j in ((i - d) % n, (i + d) % n):
                if cls[j] == _END and j < i or (d == 1 and cls[j] in (_CORNER, _REVERSAL)):
                    cls[i] = _SIDE
    return cls


def _row(P: np.ndarray, f: np.ndarray, sizes: SizeMap, sides: np.ndarray, even: bool):
    """One row on front f: (new points, new front, quads) with new ids from len(P).

    ``sides`` (bool, one per node of f) forces those nodes to be sides; the new
    front is evened out (:func:`_relax`) when the row has wedges, or always
    when ``even``.
    """
    n = len(f)
    theta = _angles(P, f)
    cls = np.where(sides, _SIDE, _classify(theta))
    X = P[f]
    h = sizes(X)
    prv, nxt = _pred(np.arange(n)), _succ(np.arange(n))
    e_in = X - X[prv]
    e_out = X[nxt] - X
    e_in /= np.hypot(e_in[:, 0], e_in[:, 1])[:, None]
    e_out /= np.hypot(e_out[:, 0], e_out[:, 1])[:, None]

    turned = _turned
    bis = turned(e_out, theta / 2)
    dist = np.minimum(h / np.maximum(np.sin(theta / 2), 1e-12), 2 * h)
    side_pt = X + dist[:, None] * bis
    left = lambda v: np.column_stack([-v[:, 1], v[:, 0]])  # noqa: E731
    a_pt = X + h[:, None] * left(e_in)
    b_pt = X + h[:, None] * left(e_out)
    d_pt = a_pt + b_pt - X
    # reversal: a, d1, m, d2, b; m on the normal of e_out turned half-way to e_in's
    m_pt = X + h[:, None] * turned(left(e_out), (theta - np.pi) / 2)
    base = len(P)
    ends = cls == _END
    near_end = ends[prv] | ends[nxt]
    # wedges (the front grows longer than its nodes can span): one per 2 h of excess
    # length of the new front, at sides between sides; +2 nodes each
    span = np.hypot(*(side_pt[nxt] - side_pt).T) / h
    excess = np.cumsum(np.where(span > _STRETCH, span - 1.0, 0.0))
    plain = (cls == _SIDE) & ~near_end & ~sides
    plain &= (cls[prv] == _SIDE) & (cls[nxt] == _SIDE)
    wedge = plain & (np.floor(excess / 2) > np.floor(_pred(excess) / 2))
    wedge[0] = False
    wedge &= ~_pred(wedge)
    cls = np.where(wedge, _WEDGE, cls)
    t_dir = e_in + e_out
    t_dir /= np.maximum(np.hypot(t_dir[:, 0], t_dir[:, 1]), 1e-300)[:, None]
    half = (h / 2)[:, None] * t_dir
    a_pt = np.where(wedge[:, None], X + h[:, None] * bis - half, a_pt)
    b_pt = np.where(wedge[:, None], X + h[:, None] * bis + half, b_pt)
    d_pt = np.where(wedge[:, None], X + (1.3 * h)[:, None] * bis, d_pt)
    # new nodes: one per side, three per corner, five per reversal (none next to a
    # row end), then one per end
    rev = (cls == _REVERSAL) & ~near_end
    corner = ((cls == _CORNER) & ~near_end) | wedge
    side = (cls == _SIDE) & ~near_end
    count = np.where(rev, 5, np.where(corner, 3, np.where(side, 1, 0)))
    first = base + np.cumsum(count) - count
    n_own = int(count.sum())
    end_at = np.flatnonzero(ends)
    x_end = base + n_own + np.arange(len(end_at))
    # L[i], R[i]: new node ids at the left (edge from prev) and right (edge to next) of node i
    L = np.where(count > 0, first, -1)
    R = np.where(count > 0, first + count - 1, -1)
    L[prv[end_at]] = R[prv[end_at]] = x_end
    L[nxt[end_at]] = R[nxt[end_at]] = x_end
    pts = np.empty((n_own + len(end_at), 2))
    pts[first[side] - base] = side_pt[side]
    ci = np.flatnonzero(corner)
    pts[first[ci] - base] = a_pt[ci]
    pts[first[ci] + 1 - base] = d_pt[ci]
    pts[first[ci] + 2 - base] = b_pt[ci]
    ri = np.flatnonzero(rev)
    for k, xy in enumerate(
        (a_pt[ri], a_pt[ri] + m_pt[ri] - X[ri], m_pt[ri], m_pt[ri] + b_pt[ri] - X[ri], b_pt[ri])
    ):
        pts[first[ri] + k - base] = xy
    pts[n_own:] = X[prv[end_at]] + X[nxt[end_at]] - X[end_at]
    ei = np.flatnonzero(~ends & ~ends[nxt])
    quads = np.concatenate(
        [
            np.column_stack([f[ci], R[ci], first[ci] + 1, L[ci]]),
            np.column_stack([f[ri], R[ri], first[ri] + 3, first[ri] + 2]),
            np.column_stack([f[ri], first[ri] + 2, first[ri] + 1, L[ri]]),
            np.column_stack([f[prv[end_at]], f[end_at], f[nxt[end_at]], x_end]),
            np.column_stack([f[ei], f[nxt[ei]], L[nxt[ei]], R[ei]]),
        ]
    )
    # the new front, in order: the new nodes of each node (1, 3 or 5), repeats dropped
    seq = np.full((n, 5), -1, np.int64)
    seq[:, 0] = L
    for k in range(1, 5):
        seq[:, k] = np.where(count > k, first + k, -1)
    seq = seq[~ends]
    seq = seq[seq >= 0]
    if len(seq) > 1:
        seq = seq[np.append(True, seq[1:] != seq[:-1])]
        if seq[0] == seq[-1]:
            seq = seq[:-1]
    free = np.zeros(len(pts), bool)
    wi = np.flatnonzero(wedge)
    free[first[side] - base] = True
    free[first[wi] - base] = free[first[wi] + 2 - base] = True
    if even or wedge.any():
        _relax(pts, seq.astype(np.int64) - base, free)
    return pts, seq.astype(np.int64), quads.astype(np.int64), cls


def _relax(pts: np.ndarray, seq: np.ndarray, free: np.ndarray) -> None:
    """Even out the new front in place: ``_RELAX`` Jacobi sweeps moving each free
    new node half-way to the midpoint of its neighbours along the new front.

    A wedge's kite (its middle node ``1.3 h`` ahead) would otherwise be a bump
    that the next row reads as corners, each adding two more nodes. The row's
    quads are checked after this (exact), so it only shapes the row.
    """
    if len(seq) < 4:
        return
    mov = free[seq]
    if not mov.any():
        return
    at = seq[mov]
    for _ in range(_RELAX):
        X = pts[seq]
        mid = (_pred(X) + _succ(X)) / 2
        pts[at] += 0.5 * (mid[mov] - X[mov])


def _snap(Q, f, nf, quads, table, n_old, h, boxes: list):
    """Join the new row to fronts it meets: (Q, quads, dropped mask, snaps).

    A new node within ``_SNAP * h`` of a node ``t`` is snapped to it when
    ``t`` is a node of another front (the fronts merge), a node of its own
    front out of its own quads (the front closes a thin gap and splits; the
    row's quads at ``t`` are dropped), or another new node of the row not
    next to it (both go to their midpoint; the front splits, or where it
    folds, two new nodes apart, the seam of the paving literature). A snap is
    kept only in a run: a neighbour along the new front snapped to a
    neighbour of ``t`` the other way round, so the joined fronts share an
    edge that cancels (no front touches itself at one node); the fold seam
    is its own run. Only new nodes move. ``table`` is
    :func:`~meshcore.quads.paving_checks._front_table` of the fronts and f's;
    the box of the front nodes the snaps looked at is appended to ``boxes``.
    """
    new = nf[nf >= n_old]
    none = Q, quads, np.zeros(len(quads), bool), 0
    if not len(new):
        return none
    hmax = float(h[new].max())
    r = 1.001 * _SNAP * hmax  # the targets: within _SNAP h of a new node
    boxes.append((Q[new].min(axis=0) - r, Q[new].max(axis=0) + r))
    N, n_f = len(Q), len(nf)
    pos = np.full(N, -1, np.int64)
    pos[nf] = np.arange(n_f)
    own_old = set(f.tolist())
    a, b, of_other = table
    targets = np.concatenate([a[of_other], f, new])
    ni, nj, nd = pk.near_pairs(Q[new], Q[targets], _SNAP * hmax)
    x, t = new[ni], targets[nj]
    near = nd <= _SNAP * h[x]
    x, t = x[near], t[near]
    # not the corners of x's quads (x among them), nor its neighbours on the new front
    mine = (quads[:, :, None] * N + quads[:, None, :]).ravel()
    step = (pos[t] - pos[x]) % n_f
    keep = (t != x) & ~((pos[t] >= 0) & ((step == 1) | (step == n_f - 1)))
    x, t = x[keep], t[keep]
    keep = ~isin_ints(x * N + t, mine)
    x, t = x[keep], t[keep]
    if not len(x):
        return none
    d = np.hypot(*(Q[t] - Q[x]).T)
    order = np.lexsort((t, x, d))
    cand = zip(d[order].tolist(), x[order].tolist(), t[order].tolist(), strict=True)
    corners: dict[int, set] = {}
    for q in np.flatnonzero(isin_ints(quads, x).any(axis=1)):
        for v in quads[q]:
            corners.setdefault(int(v), set()).update(quads[q].tolist())
    succ = np.full(N, -1, np.int64)
    succ[a] = b
    succ[nf] = _succ(nf)
    # greedy, nearest first: each node once; a node of its own front is taken only if
    # it is no source of a node snapped already, and conversely
    to: dict[int, int] = {}
    used: set[int] = set()
    taken: set[int] = set()
    sources: set[int] = set()
    for _, x, t in cand:
        if x in used or t in used:
            continue
        if t in own_old:
            src = corners.get(x, set()) & own_old
            if src & taken or t in sources:
                continue
            taken.add(t)
            sources.update(src)
        to[x] = t
        used.update((x, t))

    def partners(to):
        out = dict(to)
        out.update({t: x for x, t in to.items() if t >= n_old})
        return out

    def run(x: int, t: int, partner: dict) -> bool:
        if pos[t] >= 0 and (pos[t] - pos[x]) % n_f in (2, n_f - 2):
            return True  # fold seam
        p = pos[x]
        for d in (1, -1):
            u = partner.get(int(nf[(p + d) % n_f]))
            if u is not None and (succ[u] == t if d == 1 else succ[t] == u):
                return True
        return False

    for _ in range(2):
        partner = partners(to)
        to = {x: t for x, t in to.items() if run(x, t, partner)}
    if not to:
        return none
    dropped = isin_ints(quads, [t for t in to.values() if t in own_old]).any(axis=1)
    Q = Q.copy()
    remap = np.arange(len(Q))
    for x, t in to.items():
        if t >= n_old:  # two new nodes: both to the midpoint, the lower id kept
            lo, hi = min(x, t), max(x, t)
            Q[lo] = (Q[x] + Q[t]) / 2
            remap[hi] = lo
        else:
            remap[x] = t
    return Q, remap[quads], dropped, len(to)


def _try_row(P, fronts, which, sizes, even):
    """The row on ``fronts[which]``, when every quad of it passes every check.

    Returns ``(None, box)`` when some quad fails or the fronts left would not
    be simple even cycles, ``box`` the ``(lo, hi)`` corners of a box such that
    the same front fails again as long as the front edges whose bounding box
    meets it are the same (None when the failure depends on more: the trace
    of whole fronts); else ``(points, involved, loops, quads, classes, seams,
    snaps, partial)``: the fronts ``involved`` (the row's and those it snapped to) are
    replaced by ``loops``. A row failing on a few quads is tried again (up to
    ``_RETRIES`` times) with the front nodes of the failed quads made sides
    (a corner, reversal, wedge or row end there is given up), and without
    its snaps when a failed quad has a snapped node. When that is over, a
    row failing on at most ``_FEW_BAD`` of its quads, or only on the gap on
    at most ``_PARTIAL`` of them, is laid without them (``partial``).
    """
    f = fronts[which]
    n_old = len(P)
    sides = np.zeros(len(f), bool)
    snap = True
    partial = False
    boxes: list = []  # every box of front edges the row looked at (the snaps, the checks)
    table = _front_table(fronts, which)
    for attempt in range(_RETRIES + 1):
        pts, nf, quads, cls = _row(P, f, sizes, sides, even)
        Q = np.concatenate([P, pts])
        Q, nf, quads, seams = _seam(Q, nf, quads, sizes(Q[nf]), n_old)
        h = sizes(Q)
        snaps = 0
        moved = np.zeros(0, np.int64)
        if snap:
            before = quads
            Q, quads, dropped, snaps = _snap(Q, f, nf, quads, table, n_old, h, boxes)
            if snaps:
                h = sizes(Q)
                moved = unique_ints(quads[quads != before])
            quads = quads[~dropped]
        if not len(quads):
            return None, _union(boxes)
        ok = _good_quads(Q, quads, table, n_old, h, boxes=boxes)
        if ok.all():
            break
        bad = quads[~ok]
        nbad = int((~ok).sum())
        last = attempt == _RETRIES or nbad > max(_RETRY_BAD, _RETRY_SHARE * len(ok))
        pos = np.full(len(Q), -1, np.int64)
        pos[f] = np.arange(len(f))
        at = pos[bad[bad < n_old]]
        at = at[at >= 0]
        again = np.zeros(len(f), bool)
        again[at] = True
        again &= cls != _SIDE
        drop_snaps = snap and bool(isin_ints(bad, moved).any())
        stuck = not again.any() and not drop_snaps  # nothing left to give up
        if stuck and not last and nbad > _STUCK_SHARE * len(ok):
            return None, _union(boxes)
        if last or stuck:
            few = nbad <= _FEW_BAD * len(ok)
            if not few and (
                nbad > _PARTIAL * len(ok)
                or not _good_quads(Q, quads, table, n_old, h, 0.0, boxes).all()
            ):
                return None, _union(boxes)
            quads = quads[ok]  # a few failed, or only on the gap: the row stops short there
            partial = True
            break
        sides |= again
        snap = snap and not drop_snaps
    owner = np.full(len(Q), -1, np.int64)
    for k, g in enumerate(fronts):
        owner[g] = k
    involved = sorted({which, *owner[quads[quads < n_old]].tolist()} - {-1})
    loops = _trace([fronts[k] for k in involved], quads, len(Q))
    if loops is None:
        return None, None
    return Q, involved, loops, quads, cls, seams, snaps, partial


def _union(boxes: list) -> tuple[np.ndarray, np.ndarray] | None:
    """The least box ``(lo, hi)`` holding every box of ``boxes`` (None for no box)."""
    if not boxes:
        return None  # no check looked at the fronts: nothing to key a repeat on
    lo, hi = zip(*boxes, strict=True)
    return np.min(lo, axis=0), np.max(hi, axis=0)


def _edges_in(P: np.ndarray, fronts: list, box) -> bytes:
    """The front edges whose bounding box meets ``box``, in a canonical order (a key)."""
    fa, fb = _chains(fronts)
    near = pk.front_near(P, fa, fb, *box)
    e = np.column_stack([fa[near], fb[near]])
    return e[np.lexsort((e[:, 1], e[:, 0]))].tobytes()


def _by_length(group: np.ndarray, length: np.ndarray, index: np.ndarray) -> np.ndarray:
    """The order by group, then length, lengths within ``_TIE`` of the previous tying.

    Tied lengths (a symmetric domain's, equal but for rounding) are ordered
    by index, so that rounding never chooses.
    """
    order = np.lexsort((length, group))
    g, d = group[order], length[order]
    step = np.ones(len(order), bool)
    step[1:] = (g[1:] != g[:-1]) | (d[1:] - d[:-1] > _TIE * d[1:])
    return order[np.lexsort((index[order], np.cumsum(step)))]


def _rungs(P: np.ndarray, fronts: list, sizes: SizeMap, reach: float):
    """Facing front nodes: (nodes, succ, pred, partner, nrm), local indices into ``nodes``.

    ``nodes`` are the front nodes in order, ``succ``/``pred`` their neighbours
    on their front, ``nrm`` their inward bisectors (unit), ``partner[i]`` the
    node ``i`` faces (-1 if none): its nearest front node within ``reach h``
    that lies within ``_LADDER_TURN`` of its inward bisector and sees it
    within its own, on another front or at least 4 nodes away along the same
    one, when that choice is mutual.
    """
    nodes = np.concatenate(fronts)
    lens = np.array([len(g) for g in fronts], np.int64)
    start = np.cumsum(lens) - lens
    loop = np.repeat(np.arange(len(fronts)), lens)
    pos = np.arange(len(nodes)) - start[loop]
    succ = start[loop] + (pos + 1) % lens[loop]
    pred = start[loop] + (pos - 1) % lens[loop]
    X = P[nodes]
    e_out = X[succ] - X
    e_out /= np.hypot(e_out[:, 0], e_out[:, 1])[:, None]
    nrm = _turned(e_out, np.concatenate([_angles(P, g) for g in fronts]) / 2)
    h = sizes(X)
    i, j, d = pk.near_pairs(X, X, reach * float(h.max()))
    keep = (d > 0) & (d <= reach * h[i])
    along = np.abs(pos[i] - pos[j])
    along = np.minimum(along, lens[loop[i]] - along)
    keep &= (loop[i] != loop[j]) | (along > 3)
    i, j, d = i[keep], j[keep], d[keep]
    u = (X[j] - X[i]) / d[:, None]
    cos = np.cos(np.radians(_LADDER_TURN))
    keep = (np.einsum("ij,ij->i", u, nrm[i]) > cos) & (np.einsum("ij,ij->i", u, nrm[j]) < -cos)
    i, j, d = i[keep], j[keep], d[keep]
    order = _by_length(i, d, j)
    i, j = i[order], j[order]
    first = np.ones(len(i), bool)
    first[1:] = i[1:] != i[:-1]
    best = np.full(len(nodes), -1, np.int64)
    best[i[first]] = j[first]
    partner = np.where((best >= 0) & (best[best.clip(0)] == np.arange(len(nodes))), best, -1)
    return nodes, succ, pred, partner, nrm


def _ladders(P: np.ndarray, fronts: list, sizes: SizeMap, banned: np.ndarray, reach: float):
    """Close the bands between facing fronts by strips: (points, fronts left, quads, strips).

    *Rungs* join facing front nodes. A strip starts at a mutual pair of
    :func:`_rungs` (shortest first) and grows both ways along the two fronts,
    rung ``(a, b)`` to ``(succ a, pred b)``, while the quad ``(a, succ a, pred
    b, b)`` is strictly convex (exact), of quality (8.4) at least
    ``_LADDER_Q``, its nodes not in another strip, the new rung within
    ``_LADDER_TURN`` of both bisectors and within ``_LADDER_TAPER`` times
    the first rung's length. Quads failing the row checks of
    :func:`_good_quads` (a rung touching a front edge or another rung except
    at a shared node, a front node inside) cut their strip. Each strip of
    rungs about ``k h`` long is a ``k``-wide grid: every rung cut in ``k``
    equal parts, each quad in ``k`` quads between them (the parts of a
    strictly convex quad are strictly convex). Strips, longest first, are cut
    out of the fronts they touch by the chain arithmetic of :func:`_trace`,
    with ``k``, ``k + 1`` or ``k - 1`` parts (each strip's end rungs add ``k``
    edges to the fronts left, so this choice sets the parity of the fronts it
    splits), and kept only when the fronts left are simple even cycles (a
    strip along the whole of a thin front closes it; one between two fronts
    merges them). Every quad is positive and a strip's boundary chain is the
    front edges it removes plus its end rungs, so the strips cover exactly
    the region they take out of the fronts (the winding-number argument).
    """
    empty = P, fronts, np.zeros((0, 4), np.int64), 0
    if not fronts:
        return empty
    nodes, succ, pred, partner, nrm = _rungs(P, fronts, sizes, reach)
    X = P[nodes]
    cos = np.cos(np.radians(_LADDER_TURN))

    def facing(a: int, b: int) -> bool:
        u = X[b] - X[a]
        d = float(np.hypot(*u))
        return d > 0 and u @ nrm[a] > cos * d and u @ nrm[b] < -cos * d

    def good(a: int, b: int, c: int, e: int) -> bool:
        q = nodes[[a, b, c, e]][None, :]
        return bool(pk.convex_and_good(P, q, _LADDER_Q)[0])

    seeds = np.flatnonzero((partner >= 0) & (np.arange(len(nodes)) < partner))
    length = np.hypot(*(X[partner[seeds]] - X[seeds]).T)
    seeds = seeds[_by_length(np.zeros(len(seeds), np.int64), length, seeds)]
    used = banned[nodes].copy()
    strips: list[list[tuple[int, int]]] = []
    for s in seeds.tolist():
        b0 = int(partner[s])
        if used[s] or used[b0]:
            continue
        rungs = [(s, b0)]
        used[[s, b0]] = True
        reach = float(np.hypot(*(X[b0] - X[s]))) * np.array(_LADDER_TAPER)
        for forward in (True, False):
            while True:
                a, b = rungs[-1] if forward else rungs[0]
                a2, b2 = (int(succ[a]), int(pred[b])) if forward else (int(pred[a]), int(succ[b]))
                if used[a2] or used[b2] or a2 == b2 or not facing(a2, b2):
                    break
                if not reach[0] <= float(np.hypot(*(X[b2] - X[a2]))) <= reach[1]:
                    break
                if not (good(a, a2, b2, b) if forward else good(a2, a, b, b2)):
                    break
                used[[a2, b2]] = True
                if forward:
                    rungs.append((a2, b2))
                else:
                    rungs.insert(0, (a2, b2))
        if len(rungs) > 1:
            strips.append(rungs)
    if not strips:
        return empty
    # the row checks on every strip quad; a failing quad cuts its strip
    coarse = np.array(
        [[r[i][0], r[i + 1][0], r[i + 1][1], r[i][1]] for r in strips for i in range(len(r) - 1)]
    )
    ok = _good_quads(P, nodes[coarse], _front_table(fronts, -1), len(P), sizes(P)).tolist()
    pieces: list[list[tuple[int, int]]] = []
    at = 0
    for r in strips:
        cur = [r[0]]
        for i in range(len(r) - 1):
            if ok[at + i]:
                cur.append(r[i + 1])
            else:
                if len(cur) > 1:
                    pieces.append(cur)
                cur = [r[i + 1]]
        if len(cur) > 1:
            pieces.append(cur)
        at += len(r) - 1
    pieces.sort(key=len, reverse=True)
    owner = np.full(len(P), -1, np.int64)
    loops = list(fronts)
    for k, g in enumerate(loops):
        owner[g] = k
    new_pts: list[np.ndarray] = []
    kept: list[np.ndarray] = []
    n_pts = len(P)
    for r in pieces:
        a = nodes[[x for x, _ in r]]
        b = nodes[[y for _, y in r]]
        involved = unique_ints(owner[np.concatenate([a, b])]).tolist()
        if -1 in involved:
            continue
        length = float(np.median(np.hypot(*(P[b] - P[a]).T) / sizes(P[a])))
        k0 = max(1, int(round(length)))
        for k in (k0, k0 + 1, k0 - 1):
            if k < 1:
                continue
            # grid[i, j]: point j of rung i, from a (j = 0) to b (j = k)
            t = np.arange(1, k) / k
            inner = P[a][:, None, :] + t[None, :, None] * (P[b] - P[a])[:, None, :]
            inner = _bow(P[a], P[b], inner, t)
            ids = n_pts + np.arange(len(r) * (k - 1)).reshape(len(r), k - 1)
            grid = np.column_stack([a, ids, b])
            q = np.stack(
                [grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]], axis=2
            ).reshape(-1, 4)
            new = _trace([loops[i] for i in involved], q, n_pts + inner.size // 2)
            if new is not None:
                break
        else:
            continue
        new_pts.append(inner.reshape(-1, 2))
        n_pts += len(new_pts[-1])
        kept.append(q)
        gone = set(involved)
        loops = [g for i, g in enumerate(loops) if i not in gone] + new
        owner = np.concatenate([owner, np.full(len(new_pts[-1]), -1, np.int64)])
        owner[q.ravel()] = -1
        for i, g in enumerate(loops):
            owner[g] = i
    if not kept:
        return empty
    P = np.concatenate([P, *new_pts])
    try:
        _polygons(P, loops)
    except AlgorithmError:  # a clockwise front left outside every other: not kept
        return empty
    return P, loops, np.concatenate(kept), len(kept)


def _bow(A: np.ndarray, B: np.ndarray, inner: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The inner points of a strip's two end rungs bowed into the strip.

    ``inner[i, j]`` is point ``t[j]`` of rung ``A[i] -> B[i]``. A cut rung is
    a straight run of flat vertices on the front it leaves, which the
    partition cannot use as quad corners; its points move toward the next
    rung by ``_BOW`` times the rungs' distance (a parabola along the rung),
    so the front left turns at each of them. Kept only when the end columns
    of the strip's quads stay strictly convex (exact).
    """
    if len(inner) < 2 or not inner.shape[1]:
        return inner
    G = np.concatenate([A[:, None, :], inner, B[:, None, :]], axis=1)
    bent = G.copy()
    mid = (A + B) / 2
    for end, nb in ((0, 1), (-1, -2)):
        bent[end, 1:-1] += _BOW * (4 * t * (1 - t))[:, None] * (mid[nb] - mid[end])
    cols = np.arange(4 * G.shape[1]).reshape(4, -1)  # the first two rungs and the last two
    q = np.stack([cols[:-1, :-1], cols[1:, :-1], cols[1:, 1:], cols[:-1, 1:]], axis=2)
    q = q[[0, 2]].reshape(-1, 4)
    pts = np.concatenate([bent[:2], bent[-2:]]).reshape(-1, 2)
    if pk.strictly_convex_rows(pts, q).all():
        return bent[:, 1:-1]
    return inner


def _ladder_closure(P: np.ndarray, fronts: list, sizes: SizeMap, strategy: str, rows):
    """The fronts closed by strips (:func:`_ladders`), then the partition's quads.

    When the partition is stuck on some polygons the strips leave, their
    front nodes are barred from strips and the strips made again (up to
    ``_LADDER_TRIES`` times). ``rows`` are the quads laid before (a stuck
    polygon's cavity may take some of them, :func:`_close`). Returns
    ``(points, cells, stats, gone)`` with ``stats["ladders"]`` = (strips,
    their quads) and ``gone`` marking the rows taken; cells None when no
    strip is kept or the partition is still stuck.
    """
    banned = np.zeros(len(P), bool)
    none = P, None, {}, np.zeros(len(rows), bool)
    for attempt in range(_LADDER_TRIES):
        P1, cut, ladder_q, n_ladders = _ladders(P, fronts, sizes, banned, _LADDER_REACH)
        if not n_ladders:
            return none
        found = {"ladders": (n_ladders, len(ladder_q))}
        if not cut:
            return P1, ladder_q, found, none[3]
        around = np.concatenate([rows, ladder_q])
        last = attempt == _LADDER_TRIES - 1
        P2, cells, cstats, gone = _close(P1, cut, sizes, strategy, around, last)
        if cells is not None:
            kept = ladder_q[~gone[len(rows) :]]
            return P2, np.concatenate([kept, cells]), {**cstats, **found}, gone[: len(rows)]
        loops, ring_polygon = _polygons(P1, cut)
        for k in range(ring_polygon.max() + 1):
            mine = [g for g, r in zip(loops, ring_polygon, strict=True) if r == k]
            # the polygon on its own points (indices in the same order): the partition
            # sizes its buffers by its points' box, not the domain's
            used = unique_ints(np.concatenate(mine))
            local = [np.searchsorted(used, g) for g in mine]
            ring_k = np.zeros(len(mine), np.int64)
            if (
                partition_polygon(P1[used], local, ring_k, sizes, quad=True, strategy=strategy)[1]
                is None
            ):
                for g in mine:
                    banned[g[g < len(P)]] = True
    return none


def _seam(P: np.ndarray, front: np.ndarray, quads: np.ndarray, h: np.ndarray, n_old: int):
    """Merge pairs of consecutive new front nodes closer than _SEAM h into their midpoint.

    Seams come in pairs so that the front stays even; a seam is kept only when
    every quad stays strictly convex. Only new nodes (ids >= n_old) move.
    """
    n = len(front)
    if n <= _SMALL_FRONT + 2:
        return P, front, quads, 0
    nxt = _succ(front)
    d = np.hypot(*(P[nxt] - P[front]).T)
    close = np.flatnonzero((d < _SEAM * h) & (front >= n_old) & (nxt >= n_old))
    picked: list[int] = []
    used: set[int] = set()
    for i in close:  # a few per row: a short loop
        j = (i + 1) % n
        if i in used or j in used:
            continue
        picked.append(int(i))
        used.update((int(i), j, (int(i) - 1) % n, (j + 1) % n))
    picked = picked[: 2 * (len(picked) // 2)]
    if not picked:
        return P, front, quads, 0
    Q = P.copy()
    remap = np.arange(len(P))
    drop = np.zeros(n, bool)
    for i in picked:
        a, b = front[i], front[(i + 1) % n]
        Q[a] = (P[a] + P[b]) / 2
        remap[b] = a
        drop[(i + 1) % n] = True
    q2 = remap[quads]
    if not pk.strictly_convex_rows(Q, q2).all():
        return P, front, quads, 0
    return Q, front[~drop], q2, len(picked)


def _valence(cells: np.ndarray, n: int, boundary: np.ndarray) -> dict:
    vals, cnt = np.unique(_degrees(cells, n)[_interior(cells, n, boundary)], return_counts=True)
    return {str(int(v)): int(c) for v, c in zip(vals, cnt, strict=True)}


def _degrees(cells: np.ndarray, n: int) -> np.ndarray:
    """(n,) the number of mesh edges at each point."""
    e, _ = unique_edges(cells, "quad")
    return np.bincount(e.ravel(), minlength=n)


def _interior(cells: np.ndarray, n: int, boundary: np.ndarray) -> np.ndarray:
    inner = np.zeros(n, bool)
    inner[cells.ravel()] = True
    inner[boundary] = False
    return inner


def clean_up(P: np.ndarray, cells: np.ndarray, boundary: np.ndarray):
    """The topological clean-up of the paving literature, where it is needed (§8.4.3).

    Parameters
    ----------
    P : (n, 2) float64
    cells : (m, 4) int64
        Quads, counter-clockwise, strictly convex, conforming.
    boundary : (b,) int64
        The points on the mesh's boundary (never moved nor removed).

    Returns
    -------
    points : (n', 2) float64
        The points of the quads (removed ones dropped, the rest in order).
    cells : (m', 4) int64
        Still only quads, strictly convex, conforming, the same boundary.
    operators : dict
        Applications per operator of :func:`~meshcore.quads.optimize_quads`.
    region : int
        Quads in the region handed to it.

    Notes
    -----

    The quads below ``_CLEAN_Q`` or at an interior point of valence other
    than 4, and ``_CLEAN_RINGS`` rings of quads around them, are handed to
    :func:`~meshcore.quads.optimization.optimize_quads` (§8.4.3: valence-2 and
    valence-3 removal, doublet collapse, hexagon rebuilds, edge swaps,
    smoothing, every cell kept strictly convex, the least quality never
    lowered). The points on the region's border never move nor go, so the
    region fits back in place.
    """
    n = len(P)
    deg = _degrees(cells, n)
    odd = _interior(cells, n, boundary) & (deg != 4)
    mark = (quad_quality(P, cells) < _CLEAN_Q) | odd[cells].any(axis=1)
    if not mark.any():
        return (*_compact(P, cells), {}, 0)
    for _ in range(_CLEAN_RINGS):
        near = np.zeros(n, bool)
        near[cells[mark]] = True
        mark = near[cells].any(axis=1)
    used, local = unique_ints(cells[mark], return_inverse=True)
    sub = Mesh(P[used], (CellBlock("quad", local.reshape(-1, 4)),))
    res = optimize_quads(sub)
    kept = res.point_map >= 0
    P = P.copy()
    P[used[kept]] = res.mesh.points[res.point_map[kept]]
    back = used[np.flatnonzero(kept)]  # new sub index -> global index
    new = back[res.mesh.cells_by_type["quad"]]
    ops = {k: int(v) for k, v in res.operators.items() if v}
    return (*_compact(P, np.concatenate([cells[~mark], new])), ops, int(mark.sum()))


def _pave(bnd, sizes: SizeMap, max_rows: int | None, quad_closure: bool, strategy: str, even: bool):
    P = bnd.points
    fronts = [np.asarray(lp, np.int64) for lp in bnd.loops]
    active = [len(f) > _SMALL_FRONT for f in fronts]
    quads: list[np.ndarray] = []
    stats = {"rows": 0, "row_quads": 0, "seams": 0, "snaps": 0, "merges": 0, "splits": 0}
    stats["frozen"] = stats["strips"] = stats["strip_quads"] = stats["partial_rows"] = 0
    classes = np.zeros(5, np.int64)
    rows = 0
    history: list[tuple[list[np.ndarray], int]] = []
    lo, hi = P.min(axis=0), P.max(axis=0)
    limit = int(4 * float(np.hypot(*(hi - lo))) / sizes.smallest) + 16
    if max_rows is not None:
        limit = min(limit, max_rows)
    meetings = 0
    # a front whose row failed: (box, front edges in it); tried again only when they change
    failed: dict[bytes, tuple] = {}
    checkpoint = None  # the history entry of the fronts before their first meeting
    while rows < limit:
        if not any(active):
            if not quad_closure or meetings >= _MEETINGS:
                break
            # the fronts meet: strips across the bands between them, rows go on
            meetings += 1
            if checkpoint is None:
                checkpoint = len(history)
            free = np.zeros(len(P), bool)
            P2, cut, strip_q, n_strips = _ladders(P, fronts, sizes, free, _MEET_REACH)
            if not n_strips:
                break
            history.append((list(fronts), len(quads)))
            P, fronts = P2, cut
            quads.append(strip_q)
            stats["strips"] += n_strips
            stats["strip_quads"] += len(strip_q)
            active = [len(g) > _SMALL_FRONT for g in fronts]
            continue
        rows += 1
        history.append((list(fronts), len(quads)))
        ids = [id(g) for g, a in zip(fronts, active, strict=True) if a]
        for key in ids:
            k = next((i for i, g in enumerate(fronts) if id(g) == key), None)
            if k is None or not active[k]:
                continue  # merged into another front this round
            nodes = fronts[k].tobytes()
            if nodes in failed and failed[nodes][1] == _edges_in(P, fronts, failed[nodes][0]):
                res = (None, None)  # failed before, with the same front edges around
            else:
                res = _try_row(P, fronts, k, sizes, even)
                if res[0] is None and res[1] is not None:
                    failed[nodes] = res[1], _edges_in(P, fronts, res[1])
            if res[0] is None:
                active[k] = False
                stats["frozen"] += 1
                continue
            P, involved, loops, q, cls, seams, snaps, partial = res
            stats["partial_rows"] += partial
            stats["seams"] += seams
            stats["snaps"] += snaps
            stats["merges"] += max(len(involved) - 1, 0)
            stats["splits"] += max(len(loops) - len(involved), 0)
            classes += np.bincount(cls, minlength=5)
            quads.append(q)
            stats["row_quads"] += len(q)
            keep = [i for i in range(len(fronts)) if i not in involved]
            fronts = [fronts[i] for i in keep] + loops
            active = [active[i] for i in keep] + [len(g) > _SMALL_FRONT for g in loops]
        stats["rows"] = rows
    stats["node_classes"] = dict(
        zip(("end", "side", "corner", "reversal", "wedge"), classes.tolist(), strict=True)
    )
    if quad_closure and max_rows is None and _left_large(P, bnd.loops, quads, sizes):
        return None  # the rows stopped early: the guaranteed route is better and faster
    # closure; when the quad closure is stuck, rows are taken back: one round, then
    # two more, four more... (a stuck closure is costly; a few tries at most)
    stats["rows_taken_back"] = 0
    back = 1
    while True:
        row_q = np.concatenate(quads) if quads else np.zeros((0, 4), np.int64)
        loops, ring_polygon = _polygons(P, fronts) if fronts else ([], np.zeros(0, np.int64))
        if not loops:
            P2, cells, cstats = P, np.zeros((0, 4 if quad_closure else 3), np.int64), {}
            break
        stats["ladders"] = stats["ladder_quads"] = 0
        P2, cells, cstats = P, None, {}
        if quad_closure:
            P2, cells, cstats, gone = _ladder_closure(P, fronts, sizes, strategy, row_q)
        if cells is not None:
            stats["ladders"], stats["ladder_quads"] = cstats.pop("ladders")
            row_q = row_q[~gone]
            break
        if quad_closure:
            P2, cells, cstats, gone = _close(P, fronts, sizes, strategy, row_q)
            row_q = row_q[~gone]
        else:
            P2, cells, cstats = partition_polygon(
                P, loops, ring_polygon, sizes, quad=False, strategy=strategy
            )
        if cells is not None:
            break
        if not history:
            return None
        if checkpoint is not None and checkpoint < len(history):
            # first back to where the fronts first met (the rows alone), then as before
            fronts, nq = history[checkpoint]
            stats["rows_taken_back"] += len(history) - checkpoint
            del history[checkpoint:]
            quads = quads[:nq]
            checkpoint = None
            continue
        take = min(back, len(history))
        fronts, nq = history[-take]
        del history[-take:]
        quads = quads[:nq]
        stats["rows_taken_back"] += take
        back *= 2
    stats["closure"] = cstats
    return P2, row_q, cells, stats


def _left_large(P: np.ndarray, rings: list, quads: list, sizes: SizeMap) -> bool:
    """Whether the rows and strips left more than ``_LEFT_SHARE`` of the domain's area,
    and over ``_LEFT_CELLS`` cells of the least size, to the closure."""
    total = 0.0
    for r in rings:
        r = np.asarray(r, np.int64)
        fan = np.column_stack([np.full(len(r) - 2, r[0]), r[1:-1], r[2:]])
        total += float(quality.signed_area(P, fan).sum())
    laid = float(quality.signed_area(P, np.concatenate(quads), "quad").sum()) if quads else 0.0
    left = total - laid
    return left > _LEFT_SHARE * total and left > _LEFT_CELLS * sizes.smallest * sizes.smallest


def _compact(P: np.ndarray, cells: np.ndarray):
    used = np.flatnonzero(np.bincount(cells.ravel(), minlength=len(P)))
    remap = np.full(len(P), -1, np.int64)
    remap[used] = np.arange(len(used))
    return P[used], remap[cells]


def _local(dom, sizes: SizeMap):
    """The domain and size map in local coordinates, with (origin, scale) to undo them.

    The origin is the least corner of the domain's box and the scale its
    diagonal: every length, threshold and tie of the paving is then the same,
    up to rounding of the input itself, wherever and at whatever scale the
    domain is given (module docstring, *Local coordinates*).
    """
    o = dom.points.min(axis=0)
    s = dom.diameter
    local = replace(
        dom, points=(dom.points - o) / s, area=dom.area / s**2, diameter=dom.diameter / s
    )
    grid = sizes.grid
    if not sizes.uniform:
        grid = np.concatenate([(grid[:2] - o) / s, grid[2:] / s])
    return local, SizeMap(sizes.H / s, grid), o, s


def _dense_boundary(dom, sizes: SizeMap) -> None:
    """Refuse rings far denser than the size (module docstring, *Dense boundaries*).

    The rows and strips look for neighbours within up to ``_LADDER_REACH h``
    of each front node; a ring of ``n`` vertices and length ``L`` has about
    ``2 _LADDER_REACH h n^2 / L`` such pairs along itself. Above ``_PAIRS``
    (about 2 GB of pairs; a 100,000-vertex unit circle at size 0.05 would
    need 2e9) the domain is refused before any work, naming the densest ring.
    """
    P, S, off = dom.points, dom.segments, dom.ring_offsets
    length = np.hypot(*(P[S[:, 1]] - P[S[:, 0]]).T)
    worst, pairs, total = 0, 0.0, 0.0
    for k in range(len(off) - 1):
        n = int(off[k + 1] - off[k])
        h = float(sizes(P[off[k] : off[k + 1]]).max())
        est = 2 * _LADDER_REACH * h * n * n / float(length[off[k] : off[k + 1]].sum())
        total += est
        if est > pairs:
            worst, pairs = k, est
    if total <= _PAIRS:
        return
    a, b = int(off[worst]), int(off[worst + 1])
    h = float(sizes(P[a:b]).max())
    raise InputError(
        f"paving keeps every boundary vertex, and {dom.ring_name(worst)} has {b - a} "
        f"vertices {float(length[a:b].mean()):.3g} apart on average, far below the size "
        f"{h:.6g}: the rows' neighbour searches would need about {total:.3g} pairs (at most "
        f"{_PAIRS:.0e}); give a size near the boundary's spacing, a size_field, or fewer "
        "boundary vertices",
        loc=("domain",),
        code="boundary_denser_than_size",
    )


def paving(
    domain,
    *,
    size: float | None = None,
    size_field=None,
    smooth: bool = True,
    max_rows: int | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> PavingResult:
    """All-quad mesh of a planar domain by paving: rows from the boundary inward (§8.5.1).

    Parameters
    ----------
    domain : Domain or dict
        Holes allowed; interior constraints are refused.
    size : float, optional
        Target edge length.
    size_field : dict, optional
        ``{"points": (k, 2), "values": (k,)}`` (as :func:`recursive_partition`).
    smooth : bool
        Length-weighted Laplacian smoothing with the boundary angle
        correction, the topological clean-up, then the corners squared
        (module docstring, steps 7 to 9); none inverts a cell nor lowers the
        least quality.
    max_rows : int, optional
        Rows laid at most on each front (default: until every front is
        frozen).
    progress : callable, optional
        ``progress(fraction, message)``; may raise to cancel.

    Returns
    -------
    PavingResult
        Guarantees: only quads, each strictly convex (exact test),
        conforming, their areas adding up to the domain's, every input
        segment a chain of mesh edges (module docstring: why).

    Raises
    ------
    InputError
        Bad domain or sizes (``loc`` names them), interior constraints
        (``code="unsupported"``), ``max_rows`` below 0; ``features_below_size``
        (:func:`meshcore.partition.recursive.stuck_error`) when even the guaranteed
        route is stuck; ``boundary_denser_than_size`` when a ring is far denser than
        the size (module docstring, *Dense boundaries*).

    References
    ----------
    Methods text §8.5.1, Remark 8.9; module docstring.
    """
    dom = as_domain(domain)
    if len(dom.constraints):
        raise InputError(
            "paving does not take interior constraint segments",
            loc=("segments",),
            code="unsupported",
        )
    if max_rows is not None and (not isinstance(max_rows, int) or max_rows < 0):
        raise InputError(
            "max_rows must be an integer >= 0", loc=("max_rows",), code="bad_parameter"
        )
    given = dom
    sizes = size_map(dom, size, size_field)
    _dense_boundary(dom, sizes)
    dom, sizes, origin, scale = _local(dom, sizes)
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - clock
        clock = now

    def report(fraction: float, message: str) -> None:
        if progress is not None:
            progress(fraction, message)

    report(0.0, "boundary")
    bnd = resample_boundary(dom, sizes, even=True)
    lap("boundary")
    report(0.1, "rows")
    res = _pave(bnd, sizes, max_rows, True, "balanced", False)
    evened = 0
    if res is None:  # every new front evened out: the rows may go on where they froze
        res = _pave(bnd, sizes, max_rows, True, "balanced", True)
        evened = int(res is not None)
    fallback = 0
    if res is not None:
        P, row_q, closure, stats = res
        cells = np.concatenate([row_q, closure])
    else:
        fallback = 1
        twice = SizeMap(FALLBACK_SCALE * sizes.H, sizes.grid)
        bnd = resample_boundary(dom, twice, even=True)
        res = _pave(bnd, twice, max_rows, False, "balanced", False)
        if res is None:
            raise stuck_error(given, twice.smallest * scale)  # in the input's units
        P, row_q, closure, stats = res
        P, cells, _ = split_all(P, row_q, closure)  # quads into four, triangles into three
    lap("rows and closure")
    P, cells = _compact(P, cells)
    fixed = boundary_points(P, cells)
    undone = squared = 0
    clean: dict = {"region": 0, "operators": {}}
    if smooth:
        report(0.7, "smoothing")
        P, undone = smooth_quads(P, cells, fixed)
        lap("smoothing")
        report(0.8, "clean-up")
        P, cells, ops, region = clean_up(P, cells, np.flatnonzero(fixed))
        clean = {"region": region, "operators": ops}
        lap("clean-up")
        P, squared = square_corners(P, cells, boundary_points(P, cells), _SQUARE_SWEEPS)
        lap("corners")
    P = P * scale + origin
    P[: len(given.points)] = given.points  # the input vertices, as given
    mesh = Mesh(P, (CellBlock("quad", cells),))
    # the edges of one cell are the resampled rings (tested: input segments as chains)
    rings = boundary_edges(cells)
    fixed = np.zeros(len(P), bool)
    fixed[rings.ravel()] = True
    q = quality.report(mesh, rings)
    lap("quality")
    stats = {
        **stats,
        "quads": int(len(cells)),
        "points": int(len(P)),
        "fallback": fallback,
        "evened": evened,
        "parity_repairs": bnd.repairs,
        "valence": _valence(cells, len(P), np.flatnonzero(fixed)),
        "smoothing": {
            "sweeps": SWEEPS if smooth else 0,
            "undone": int(undone),
            "squared": int(squared),
        },
        "clean_up": clean,
        "seconds": timings,
    }
    report(1.0, "done")
    return PavingResult(mesh, q, stats)
