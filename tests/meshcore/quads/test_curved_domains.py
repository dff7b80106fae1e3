"""All-quad meshes of smooth and spiky domains by both methods (issue 20).

Disks, annuli, ellipses (aspect up to 4), stadiums, gears and star polygons
with up to 80 % radial jitter, with and without a hole, sampled about
``size`` apart (so that every input vertex can be a mesh point), at sizes
giving 100 to 2,000 quads. ``quad_combine`` (``all_quad``, ``twice_size``,
``optimize``) and ``quad_medial`` must both succeed with only quads, the
boundary and the area kept exactly. The quality and count targets of the
issue are asserted where they hold (the README says which): ``quad_combine``
wherever its boundary layer is made (the smooth shapes, gears of up to 10 teeth
at these sizes, and stars whose offset ring is valid: one row with a quad at
each convex corner and a fan at each reflex one), away from input corners under
45 degrees: corners in [30, 150] degrees, least quality 0.5 and the count within
1.5x of area / size**2 (not asserted: gears of coarser teeth and spiky stars
whose offset ring crosses itself, meshed by the lattice: measured least
0.36-0.47, counts up to 1.82x; nor the mean of 0.9 asked on disks, annuli and
ellipses, reached from about 20 quads across: 0.83-0.94 on the smooth shapes at
these sizes); where the corner row misses those targets but beats the lattice's
mesh (a higher least quality away from sharp corners, at most 1.2 times its quads:
``stats["lattice_least"]``) it is kept, and that is asserted instead;
``quad_medial`` on disks, ellipses and stadiums (the butterfly), corners in
[30, 150] degrees, least quality 0.5 and the count within 1.5x of area / size**2; on
the annulus corners in [30, 150], least quality 0.5 and the count within 1.5x (0.88x
at size 0.15, 1.12x at 0.1: its regions are one patch each); on stars, away from
input corners under 45 degrees (forced), corners in [30, 150] and least quality 0.3,
and at size 0.1 the count within 1.5x (the issue's least quality 0.5 is not met
everywhere: 24 of the issue's first 32 stars at size 0.1, 20 at 0.15; at size 0.15
the partition's regions are about as small as ``size`` and 8 of those 32 stars pass
1.5x, up to 2.9x); one of the issue's stars asserts 0.5, and
a star with a 281-degree corner, opened, and a square with a spike of 4-6 degrees, away
from its tip. Gears (6-12 teeth): the count within 1.5x at size 0.1 (its axis pruned
more where it passed: a 12-tooth gear 2.46x -> 1.30x); not their quality (least
0.46-0.62 at 0.1, 0.5 on 4 of 7, after the O-grid at the hub and the merges at the
tooth gaps: those two are asserted on their own) nor the count at 0.15 (1.68-2.47x
on 6-9 teeth).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.geometry.predicates import orient2d
from meshcore.medial.partitioning import quad_medial
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.quads import combine
from meshcore.quads.boundary_layer import ROW_CHOICES, boundary_layer, targets_rank
from tests.meshcore.quads.stars import issue_star, star


def _ring(xy):
    return np.vstack([xy, xy[:1]]).tolist()


def _sampled(curve, size):
    """A closed curve (callable on [0, 1)) sampled about ``size`` apart."""
    t = np.linspace(0, 1, 4000, endpoint=False)
    xy = curve(t)
    s = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T))])
    n = max(8, int(round(s[-1] / size)))
    return curve(np.interp(np.arange(n) * s[-1] / n, s[:-1], t))


def _ellipse(a, b, c=(0.0, 0.0)):
    return lambda t: np.column_stack(
        [c[0] + a * np.cos(2 * np.pi * t), c[1] + b * np.sin(2 * np.pi * t)]
    )


def _stadium(half):
    def f(t):
        s = t * (4 * half + 2 * np.pi)
        out = np.empty((len(t), 2))
        for i, u in enumerate(s):
            if u < 2 * half:
                out[i] = (-half + u, -1.0)
            elif u < 2 * half + np.pi:
                a = u - 2 * half - np.pi / 2
                out[i] = (half + np.cos(a), np.sin(a))
            elif u < 4 * half + np.pi:
                out[i] = (half - (u - 2 * half - np.pi), 1.0)
            else:
                a = u - 4 * half - np.pi + np.pi / 2
                out[i] = (-half + np.cos(a), np.sin(a))
        return out

    return f


def _gear(teeth, depth):
    def f(t):
        r = 1 + depth * np.tanh(4 * np.sin(2 * np.pi * teeth * t))
        return np.column_stack([r * np.cos(2 * np.pi * t), r * np.sin(2 * np.pi * t)])

    return f


@st.composite
def curved_domains(draw):
    """(GeoJSON polygon, size) of a drawn smooth or spiky domain."""
    kind = draw(st.sampled_from(["disk", "annulus", "ellipse", "stadium", "gear", "star"]))
    size = draw(st.sampled_from([0.1, 0.15]))
    holes = []
    if kind == "disk":
        outer = _sampled(_ellipse(1, 1), size)
    elif kind == "annulus":
        outer = _sampled(_ellipse(1, 1), size)
        holes = [_sampled(_ellipse(0.45, 0.45), size)]
    elif kind == "ellipse":
        outer = _sampled(_ellipse(draw(st.sampled_from([1.5, 2.0, 4.0])), 1), size)
    elif kind == "stadium":
        outer = _sampled(_stadium(draw(st.sampled_from([0.5, 1.5]))), size)
    elif kind == "gear":
        teeth = draw(st.integers(6, 12))
        outer = _sampled(_gear(teeth, 0.12), size)
        kind = f"gear{teeth}"
    else:
        n = draw(st.integers(5, 40))
        jitter = draw(st.floats(0.1, 0.8))
        seed = draw(st.integers(0, 2**31))
        return _star_case(n, jitter, seed, draw(st.booleans()), size)
    rings = [_ring(outer)] + [_ring(h[::-1]) for h in holes]
    return {"type": "Polygon", "coordinates": rings}, size, kind


def _star_case(n, jitter, seed, hole, size):
    """(GeoJSON polygon, size, "star"): a random star of ``n`` vertices, radial jitter
    ``jitter / 2``, with a square hole or not."""
    geo = star(np.random.default_rng(seed), n, jitter / 2)
    if hole:
        square = np.array([[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]])
        geo["coordinates"].append(_ring(square[::-1]))
    return geo, size, "star"


def _corners(P, Q):
    p = P[Q]
    a, b = np.roll(p, 1, axis=1) - p, np.roll(p, -1, axis=1) - p
    cos = (a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def _check(mesh, dom, size):
    assert set(mesh.cells_by_type) == {"quad"}
    P, Q = mesh.points, mesh.cells_by_type["quad"]
    area = quality.signed_area(P, Q, "quad")
    assert (area > 0).all()
    assert abs(area.sum() - dom.area) <= 1e-9 * dom.area
    ratio = len(Q) * size**2 / dom.area
    return _corners(P, Q), quality.cell_quality(P, Q, "quad"), ratio


def _unforced(P, Q, dom, below=45.0, above=270.0):
    """(q,) bool: the quads with no corner at an input vertex whose angle in the
    domain is under ``below`` degrees (such a corner is held by one quad at best, its
    quality (8.4) then at most ``2 * angle / 180``: forced by the input) or over
    ``above`` (a reflex corner that ``quad_medial``'s subdivision gives two quads)."""
    angle = dom.corner_angles()
    sharp = dom.points[np.flatnonzero((angle < below) | (angle > above))]
    at = np.zeros(len(P), bool)
    for x in sharp:  # a loop over the input's sharp corners (exact matches)
        at |= (P == x).all(axis=1)
    return ~at[Q].any(axis=1)


def _meets_targets(res, dom, size):
    """Issue 20's targets on ``quad_combine``'s all-quad mesh (:func:`_check` too):
    corners 30-150 degrees and quality (8.4) at least 0.5 on the quads the input does not
    force (:func:`_unforced`), 1 / 1.5 to 1.5 times area / size² quads."""
    ang, q, ratio = _check(res.mesh, dom, size)
    ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom)
    assert ang[ok].min() >= 30 and ang[ok].max() <= 150
    assert q[ok].min() >= 0.5 and 1 / 1.5 <= ratio <= 1.5


SMOOTH = ("disk", "annulus", "ellipse", "stadium")

SETTINGS = settings(
    max_examples=4,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)


@SETTINGS
@given(curved_domains())
def test_quad_combine_all_quad_on_curved_domains(case):
    geo, size, kind = case
    dom = parse_domain(geo)
    res = combine(domain=dom, size=size, all_quad=True, twice_size=True, optimize=True)
    ang, q, ratio = _check(res.mesh, dom, size)
    # the boundary layer (README): smooth shapes, and gears of up to 10 teeth at these
    # sizes (coarser teeth: the offset rings cross and the lattice is kept)
    if kind in SMOOTH or (kind.startswith("gear") and int(kind[4:]) * size <= 1.0):
        assert "boundary_layer" in res.stats
    if "lattice_least" in res.stats:  # a row missing the targets, kept over the lattice
        _assert_beats_lattice(res, dom, size)
    elif "boundary_layer" in res.stats:  # stars too, where their offset ring is valid
        ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom)
        assert ang[ok].min() >= 30 and ang[ok].max() <= 150
        assert q[ok].min() >= 0.5
        assert 1 / 1.5 <= ratio <= 1.5


def _combined_seen(dom):
    """``combine`` of ``dom`` at size 0.1 (all_quad, twice_size, optimize) and the
    progress it reported, checked to rise within [0, 1]."""
    seen = []
    res = combine(
        domain=dom,
        size=0.1,
        all_quad=True,
        twice_size=True,
        optimize=True,
        progress=lambda f, msg: seen.append((f, msg)),
    )
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and 0 <= fractions[0] and fractions[-1] <= 1
    return res, seen


def _assert_beats_lattice(res, dom, size):
    """The row kept over the lattice: a higher least quality away from the input's
    sharp corners than the lattice's mesh (``corner_least`` 1 refuses every corner
    row), with at most 1.2 times its quads."""
    lat = combine(
        domain=dom, size=size, all_quad=True, twice_size=True, optimize=True, corner_least=1.0
    )
    assert "boundary_layer" not in lat.stats
    least = []
    for r in (res, lat):
        P, Q = r.mesh.points, r.mesh.cells_by_type["quad"]
        least.append(quality.quad_quality(P, Q[_unforced(P, Q, dom)]).min())
    assert least[0] > least[1] == pytest.approx(res.stats["lattice_least"], abs=1e-12)
    assert len(res.mesh.cells_by_type["quad"]) <= 1.2 * len(lat.mesh.cells_by_type["quad"])


@pytest.mark.parametrize(
    "star",
    [(21, 0.3, 1106653215, True), (5, 0.8, 104706386, False), (15, 0.78, 934042756, False)],
)
def test_quad_combine_row_along_star_corners(star):
    # the lattice alone left straight boundary points held by three quads and a corner
    # of 190 degrees by four here (least quality 0.44-0.56 after optimize): one row of
    # quads along the boundary, one quad at a convex corner and a fan at a reflex one
    geo, size, _ = _star_case(*star, 0.1)
    dom = parse_domain(geo)
    res = combine(domain=dom, size=size, all_quad=True, twice_size=True, optimize=True)
    assert "boundary_layer" in res.stats
    ang, q, ratio = _check(res.mesh, dom, size)
    ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom)
    assert ang[ok].min() >= 45 and ang[ok].max() <= 135
    assert q[ok].min() >= 0.55 and q.mean() >= 0.85
    assert 1 / 1.5 <= ratio <= 1.5


def test_quad_combine_keeps_a_row_that_beats_the_lattice():
    # random star 93 (issue 20's recipe) at size 0.1: the corner row laid at least quality
    # 0 misses the targets (1.68 times area / size² quads) and so does the lattice's mesh
    # (1.71x, least 0.489 away from the sharp corners, corners 45-136 degrees), also at
    # 1.02-1.2 times the size: the row is kept (least 0.519, corners 46.7-127.3)
    dom = parse_domain(issue_star(93)[0])
    res = combine(domain=dom, size=0.1, all_quad=True, twice_size=True, optimize=True)
    assert "boundary_layer" in res.stats and "lattice_least" in res.stats
    assert "size_factor" not in res.stats
    ang, _, _ = _check(res.mesh, dom, 0.1)
    _assert_beats_lattice(res, dom, 0.1)
    ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom)
    assert ang[ok].min() >= 45 and ang[ok].max() <= 130


def test_quad_combine_meets_the_targets_at_a_slightly_larger_size():
    # issue 20's random star 23 at size 0.1: neither mesh meets the targets at the size
    # nor at 1.02 times it, both do at 1.04 (least 0.521 away from the sharp corners);
    # the progress of the meshes never goes back. (Star 15, here before, now meets them
    # at the size: its corner relaxation ends at its minimum, least 0.501)
    dom = parse_domain(issue_star(23)[0])
    res, seen = _combined_seen(dom)
    assert res.stats["size_factor"] == 1.04
    assert any("again at 1.02 x size" in msg for _, msg in seen)
    _meets_targets(res, dom, 0.1)


def test_quad_combine_keeps_the_lattice_that_meets_the_targets():
    # issue 20's random star 9 at size 0.1: the retried corner row (least 0.575 away from
    # the sharp corners) has 1.519 times area / size² quads, the lattice's mesh meets
    # every target (least 0.545, 1.44x, corners 49-127 degrees): the lattice's is kept
    dom = parse_domain(issue_star(9)[0])
    res = combine(domain=dom, size=0.1, all_quad=True, twice_size=True, optimize=True)
    assert "boundary_layer" not in res.stats
    _meets_targets(res, dom, 0.1)


def test_quad_combine_lifts_the_quad_next_to_a_spike_tip():
    # issue 20's random star 15 at size 0.1 (spike tips): after the corner relaxation the
    # tips' quads, capped by their input corners, hold the nodes next to them; the lift,
    # judging only the quads away from them, makes its moves there and the mesh meets the
    # targets (least 0.501 away from the sharp corners). (Star 33 at size 0.05, here
    # before, meets them after the relaxation alone now that it ends at its minimum)
    dom = parse_domain(issue_star(15)[0])
    res = combine(domain=dom, size=0.1, all_quad=True, twice_size=True, optimize=True)
    assert res.operators["lift_off_sharp"] > 0
    _meets_targets(res, dom, 0.1)


@settings(SETTINGS, max_examples=3)
@given(curved_domains())
@example(_star_case(30, 0.8, 7, True, 0.1))  # a spiky star with a hole, whatever is drawn
def test_quad_medial_on_curved_domains(case):
    geo, size, kind = case
    dom = parse_domain(geo)
    res = quad_medial(dom, size=size)
    ang, q, ratio = _check(res.mesh, dom, size)
    if kind in ("disk", "stadium", "ellipse"):  # the butterfly (measured: least Q 0.61-0.66)
        assert res.stats["partition"] == "butterfly"
        assert ang.min() >= 30 and ang.max() <= 150 and q.min() >= 0.5
        assert 1 / 1.5 <= ratio <= 1.5
    if kind == "annulus":  # its ring regions one patch each (1.76x at 0.15 when halved)
        assert ang.min() >= 30 and ang.max() <= 150 and q.min() >= 0.5
        assert 1 / 1.5 <= ratio <= 1.5
    if kind.startswith("gear") and size == 0.1:
        assert 1 / 1.5 <= ratio <= 1.5
    if kind == "star":  # away from input corners under 45 degrees (docstring)
        ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom, above=360.0)
        assert ang[ok].min() >= 30 and ang[ok].max() <= 150 and q[ok].min() >= 0.3
        assert size > 0.1 or 1 / 1.5 <= ratio <= 1.5


@st.composite
def spiky_stars(draw):
    """(GeoJSON polygon) of a star with up to 80 % radial jitter, with or without a
    star-shaped hole inside its smallest radius (:func:`tests.meshcore.quads.stars.star`)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    return star(rng, draw(st.integers(5, 24)), draw(st.floats(0.1, 0.8)), draw(st.booleans()))


@settings(SETTINGS, max_examples=4)
@given(spiky_stars())
@example(issue_star(17)[0])  # 60 vertices, 95 regions: 1.74x before the larger stretches
def test_quad_medial_on_spiky_stars(geo):
    # every drawn star succeeds: the fill's folds at sharp reflex corners are untangled
    # (relax_quads, boundary points sliding), every quad strictly convex (exact orient2d)
    dom = parse_domain(geo)
    res = quad_medial(dom, size=0.1)
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
    ok = _unforced(P, Q, dom, above=360.0)
    assert ang[ok].min() >= 30 and ang[ok].max() <= 150 and q[ok].min() >= 0.3
    assert 1 / 1.5 <= ratio <= 1.5
    for k in range(4):
        assert (orient2d(P[Q[:, k - 1]], P[Q[:, k]], P[Q[:, (k + 1) % 4]]) > 0).all()


def test_quad_medial_slides_boundary_points():
    # the fill's boundary points lie on the input segments only to rounding: the exact
    # collinearity test of sliding_nodes let none slide, and strips along spikes kept
    # the slant of their bases (least quality 0.32 away from input corners under 45
    # degrees on this star; 0.504 with the points sliding)
    dom = parse_domain(issue_star(8)[0])
    res = quad_medial(dom, size=0.1)
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom, above=360.0)
    assert q[ok].min() >= 0.5 and 1 / 1.5 <= ratio <= 1.5


def _combined_annulus(size: float):
    """The annulus of radii 1 and 0.45 sampled at ``size``, and its all-quad combination."""
    geo = {
        "type": "Polygon",
        "coordinates": [
            _ring(_sampled(_ellipse(1, 1), size)),
            _ring(_sampled(_ellipse(0.45, 0.45), size)[::-1]),
        ],
    }
    dom = parse_domain(geo)
    return dom, combine(domain=dom, size=size, all_quad=True, twice_size=True, optimize=True)


def test_corner_relaxation_kept_on_a_coarse_annulus():
    # the 1 / sin energy alone does not see edge lengths: an interior node slid onto a
    # boundary node (a collapsed edge) and the whole relaxation was refused here
    dom, res = _combined_annulus(0.18)
    assert res.operators["relax"] == 1
    ang, q, _ = _check(res.mesh, dom, 0.18)
    assert ang.min() >= 30 and ang.max() <= 150 and q.min() >= 0.5


def test_layer_rows_keep_the_count_on_a_coarse_annulus():
    # three rows along the outer circle shrink inwards: with one along the hole too they
    # made 1.56 times area / size**2 quads here, so fewer rows are laid (the 1.4x guard)
    dom, res = _combined_annulus(0.15)
    assert "boundary_layer" in res.stats
    ang, q, ratio = _check(res.mesh, dom, 0.15)
    assert ratio <= 1.4 and q.min() >= 0.5 and ang.min() >= 30 and ang.max() <= 150


def test_quad_medial_opens_a_wide_reflex_corner():
    # a reflex corner of 281 degrees cut once was the corner of two quads (least quality
    # 0.49 on this star, corners up to 136 degrees): the edge between them is opened into
    # a third quad there (partitioning._opened)
    outer = [[0.674, 0.022], [1.171, 0.462], [0.683, 0.929], [-0.136, 1.002], [-0.487, 1.189]]
    outer += [[-0.838, 0.623], [-1.418, -0.201], [-0.621, -0.391], [-0.561, -0.886]]
    outer += [[0.004, -0.985], [0.472, -0.729], [0.897, -0.606]]
    hole = [[0.025, -0.076], [-0.042, -0.031], [-0.091, 0.066], [0.033, 0.102], [0.061, 0.0]]
    dom = parse_domain({"type": "Polygon", "coordinates": [_ring(outer), _ring(hole)]})
    res = quad_medial(dom, size=0.1)
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    assert res.stats["opened"] >= 1
    P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
    wide = ~_unforced(P, Q, dom, below=0.0, above=250.0)  # the quads at reflex corners
    assert wide.any() and ang[wide].max() <= 150
    assert q.min() >= 0.5 and ang.min() >= 30 and ang.max() <= 150 and ratio <= 1.5


def test_a_reflex_region_corner_is_opened_from_the_domain_angle():
    # a 295-degree input corner cut once: one region's corner there is reflex (204
    # degrees) and the fill's quad at it folded, its corner read as 156: the fan's
    # corners averaged 123.5 degrees, under OPEN_ANGLE, and the corner kept two quads of
    # 147 degrees (issue star 33 at size 0.1: least quality 0.36). From the domain's
    # angle there (147.5 on average) the edge between them is opened into a third quad
    from meshcore.geometry.constructions import coons_grid
    from meshcore.medial.fill import _opened

    def ray(deg, r):
        return r * np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])

    v, w, c, u = np.zeros(2), ray(-30, 1.5), ray(61, 1.5), ray(265, 1.5)
    m1, m2 = w + c, ray(163, 2.5)
    line = lambda a, b: a + np.linspace(0, 1, 4)[:, None] * (b - a)  # noqa: E731
    blocks = []
    for a, b, cc, d in ((v, w, m1, c), (v, c, m2, u)):  # counterclockwise coarse quads
        g = coons_grid(line(a, b), line(b, cc), line(d, cc), line(a, d))
        ids = np.arange(16).reshape(4, 4)
        cells = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1)
        blocks.append((g.reshape(-1, 2), cells.reshape(-1, 4)))
    allp = np.vstack([blocks[0][0], blocks[1][0]]).round(12)
    P, inv = np.unique(allp, axis=0, return_inverse=True)
    Q = np.vstack([inv.ravel()[blocks[0][1]], inv.ravel()[16 + blocks[1][1]]])
    at = int(np.flatnonzero((P == 0).all(axis=1))[0])
    assert (Q == at).any(axis=1).sum() == 2
    P2, Q2, done = _opened(P, Q)
    assert done == 1 and (Q2 == at).any(axis=1).sum() == 3 and len(Q2) == len(Q) + 1


@pytest.mark.parametrize("tip", [(2.5, 0.5), (2.2, 0.3)])
def test_quad_medial_cuts_off_a_spike(tip):
    # a spike of 4-6 degrees on a square: in the region of the axis node its tip was the
    # corner of a coarse quad as long as the spike, whose fill repeated the tip's angle
    # along its diagonal (corners 8-172 degrees, least quality 0.09 away from the tip);
    # cut off by a chord, it is a kite at the tip and two strips along the sides
    ring = [[0, 0], [1, 0], [1, 0.4], list(tip), [1, 0.6], [1, 1], [0, 1], [0, 0]]
    dom = parse_domain({"type": "Polygon", "coordinates": [ring]})
    res = quad_medial(dom, size=0.1)
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    ok = _unforced(res.mesh.points, res.mesh.cells_by_type["quad"], dom)
    assert ang[ok].min() >= 30 and ang[ok].max() <= 150 and q[ok].min() >= 0.5
    assert 1 / 1.5 <= ratio <= 1.5


_NARROW = math.tan(math.radians(0.25)) * 1.5


@pytest.mark.parametrize(
    "ring, size",
    [
        (
            np.column_stack(
                [np.cos(np.arange(32) * np.pi / 16), np.sin(np.arange(32) * np.pi / 16)]
            ),
            0.2,
        ),
        (
            np.array(
                [[0, 0], [1, 0], [1, 0.5 - _NARROW], [2.5, 0.5], [1, 0.5 + _NARROW], [1, 1], [0, 1]]
            ),
            0.1,
        ),
    ],
    ids=["32-gon", "spike-0.5-degrees"],
)
def test_quad_medial_same_cells_translated_or_scaled(ring, size):
    # at +1e6 the 32-gon was not a butterfly (its centroid from absolute coordinates,
    # its samples' count and feet decided by rounding: 312 quads for 325) and the
    # spike of 0.5 degrees was lost (its region's area, from absolute coordinates, <= 0).
    # The 32-gon's points agree to 1e-9 of the extent once moved back: its corner
    # relaxation stopped at its L-BFGS-B iterations amplified rounding to 1e-4 of it
    # (relax_quads now ends at the minimum). The spike's do not (6.8e-4): its fill's
    # points differ by 1.7e-3 before any relaxation
    cells, points = [], []
    for scale, offset in ((1.0, 0.0), (1.0, 1e6), (1e-6, 0.0)):
        dom = parse_domain({"type": "Polygon", "coordinates": [_ring(ring * scale + offset)]})
        res = quad_medial(dom, size=size * scale)
        _check(res.mesh, dom, size * scale)
        cells.append(res.mesh.cells_by_type["quad"])
        points.append((res.mesh.points - offset) / scale)
    assert all(np.array_equal(c, cells[0]) for c in cells[1:])
    if len(ring) == 32:
        for P in points[1:]:
            np.testing.assert_allclose(P, points[0], rtol=0, atol=2e-9)


def test_quad_medial_keeps_the_butterfly_where_the_medial_partition_fails():
    # a 2:1 ellipse sampled more finely than size: the butterfly passes 1.5x area /
    # size**2 (the boundary's count), and the medial partition tried instead raised
    # "a region ... has 2 sides": the job failed though the butterfly was valid
    t = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    dom = parse_domain({"type": "Polygon", "coordinates": [_ring(np.c_[2 * np.cos(t), np.sin(t)])]})
    res = quad_medial(dom, size=0.3)
    assert res.stats["partition"] == "butterfly"
    ang, q, _ = _check(res.mesh, dom, 0.3)
    assert ang.min() >= 30 and ang.max() <= 150


def _square_with_hole() -> dict:
    th = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    hole = 0.5 + 0.25 * np.column_stack([np.cos(th), np.sin(th)])
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return {"type": "Polygon", "coordinates": [_ring(square), _ring(hole[::-1])]}


@pytest.mark.parametrize("case", ["square_with_hole", "star8"])
def test_quad_combine_row_and_lattice_the_same_moved_or_scaled(case):
    # the corner row, the inner lattice and their combination give the same quads
    # translated by 1e6 or scaled by 1e-6: the sheared square was 10 lattice rows high
    # at size 0.1 and 9.9999999993 translated (another lattice), the triangulator's
    # numbering followed its refinement queue (another matching), and equal boundary
    # edges split by the longest went by rounding (with optimize: the next test)
    geo = _square_with_hole() if case == "square_with_hole" else issue_star(8)[0]
    frames = [(lambda p: p, 0.1), (lambda p: p + 1e6, 0.1), (lambda p: p * 1e-6, 1e-7)]
    out = []
    for move, size in frames:
        rings = [move(np.asarray(r)).tolist() for r in geo["coordinates"]]
        res = combine(
            domain=parse_domain({"type": "Polygon", "coordinates": rings}),
            size=size,
            all_quad=True,
            twice_size=True,
        )
        out.append((res.mesh.points, res.mesh.cells_by_type["quad"]))
    (P0, Q0), (Pt, Qt), (Ps, Qs) = out
    np.testing.assert_array_equal(Qt, Q0)
    np.testing.assert_array_equal(Qs, Q0)
    np.testing.assert_allclose(Pt - 1e6, P0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps * 1e6, P0, rtol=0, atol=1e-12)


def test_quad_combine_optimized_the_same_moved_or_scaled():
    # with optimize (the corner relaxation and the lift): the same quads and the same
    # points to 1e-9 translated by 1e6 or scaled by 1e-6. L-BFGS-B stopped at its 100
    # iterations amplified rounding (1e-9 of the normalized frame grew about 1.3 times an
    # iteration: points 9.5e-4 apart translated, 4e-4 scaled); relax_quads ends at the
    # minimum the run leads to (Newton's method), which moves with the input by rounding
    geo = _square_with_hole()
    out = []
    for scale, offset in ((1.0, 0.0), (1.0, 1e6), (1e-6, 0.0)):
        rings = [(np.asarray(r) * scale + offset).tolist() for r in geo["coordinates"]]
        dom = parse_domain({"type": "Polygon", "coordinates": rings})
        res = combine(domain=dom, size=0.1 * scale, all_quad=True, twice_size=True, optimize=True)
        out.append(((res.mesh.points - offset) / scale, res.mesh.cells_by_type["quad"]))
    (P0, Q0), *rest = out
    for P, Q in rest:
        np.testing.assert_array_equal(Q, Q0)
        np.testing.assert_allclose(P, P0, rtol=0, atol=1e-9)


def test_o_grid_at_a_vertex_of_ten_quads():
    # a crowded junction of the partition (a gear's hub) put every region's coarse quad
    # at one node: ten quads of 36 degrees there. The fan is an O-grid: a ring of 20
    # quads around a 5 x 5 grid, no vertex in more than 7 quads, the area kept
    from meshcore.medial.fill import MOST_VALENCE, _flowered

    t = np.arange(20) * np.pi / 10
    rim = np.c_[np.cos(t), np.sin(t)] * np.where(np.arange(20) % 2, 1.0, 0.9)[:, None]
    P = np.vstack([[0.0, 0.0], rim])
    Q = np.array([[0, 1 + 2 * i, 2 + 2 * i, 1 + (2 * i + 2) % 20] for i in range(10)])
    P2, Q2, done = _flowered(P, Q)
    assert done == 1 and len(Q2) == 20 + 25
    assert np.bincount(Q2.ravel()).max() <= MOST_VALENCE
    area = quality.signed_area(P2, Q2, "quad")
    assert (area > 0).all()
    assert area.sum() == pytest.approx(quality.signed_area(P, Q, "quad").sum(), rel=1e-12)


def test_lift_keeps_unjudged_quads_and_moves_alike_in_any_frame():
    # the shared lift (quad_combine judges only the quads away from sharp corners): a
    # quad not judged never falls, the judged least rises, and the same moves are made
    # on the grid moved by 1e6 or scaled by 1e-6 (the search runs in a normalized frame)
    from meshcore.quads.vertex_moves import lift_corners

    x = np.linspace(0, 1, 5)
    P = np.stack(np.meshgrid(x, x, indexing="ij"), axis=-1).reshape(-1, 2)
    ids = np.arange(25).reshape(5, 5)
    Q = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    inner = ((P > 0) & (P < 1)).all(axis=1)
    P[inner] += [0.12, 0.09]
    judged = np.ones(len(Q), bool)
    judged[[0, 15]] = False
    none = (np.zeros(0, np.int64),) * 3
    q0 = quality.quad_quality(P, Q)
    new, moves = lift_corners(P, Q, ~inner, none, judged, 0.6, 0.6)
    q1 = quality.quad_quality(new, Q)
    assert moves > 0 and q1[judged].min() > q0[judged].min() + 0.02
    assert (q1[~judged] >= q0[~judged]).all()
    assert (new[~inner] == P[~inner]).all()
    for shift, scale in ((1e6, 1.0), (0.0, 1e-6)):
        got, m = lift_corners(P * scale + shift, Q, ~inner, none, judged, 0.6, 0.6)
        assert m == moves
        np.testing.assert_allclose((got - shift) / scale, new, rtol=0, atol=1e-9)


def test_lift_raises_the_least_corner_and_keeps_the_boundary():
    # a 4 x 4 grid with its inner points pushed aside (corners of 27-153 degrees): the
    # pattern search lifts the least corner quality, the border stays on the square
    from meshcore.medial.fill import lift_least

    x = np.linspace(0, 1, 5)
    P = np.stack(np.meshgrid(x, x, indexing="ij"), axis=-1).reshape(-1, 2)
    ids = np.arange(25).reshape(5, 5)
    Q = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    inner = (P > 0) & (P < 1)
    P[inner.all(axis=1)] += [0.12, 0.09]
    fixed = ~inner.all(axis=1) & ~inner.any(axis=1)  # the square's corners
    before = quality.quad_quality(P, Q).min()
    new, moves = lift_least(P, Q, fixed, P[fixed], 0.6)
    assert moves > 0 and quality.quad_quality(new, Q).min() > before + 0.2
    border = ~inner.all(axis=1)
    assert ((new[border] == 0) | (new[border] == 1)).any(axis=1).all()
    assert quality.signed_area(new, Q, "quad").sum() == pytest.approx(1.0, rel=1e-12)


def test_quad_combine_keeps_the_rows_of_the_best_mean_on_a_disk():
    # one, two and three rows along the disk sampled at 0.1 gave means 0.900 / 0.902 /
    # 0.900 after the optimization (three, the first laid, was kept before: under 0.9);
    # the progress goes on through the other rows' meshes, after the first mesh's share
    dom = parse_domain({"type": "Polygon", "coordinates": [_ring(_sampled(_ellipse(1, 1), 0.1))]})
    res, seen = _combined_seen(dom)
    assert res.stats["layer_rows"] in ROW_CHOICES
    for rows in ("(rows 2, 1)", "(rows 1, 1)"):
        at = [f for f, msg in seen if msg.endswith(rows)]
        assert at and 0.9 <= min(at) < max(at) <= 0.95
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    assert q.mean() >= 0.9 and q.min() >= 0.5 and ang.min() >= 30 and ang.max() <= 150
    assert ratio <= 1.5


def test_boundary_layer_lays_exactly_the_rows_asked_or_none():
    # a disk with two holes at 0.07: three rows outside and two along the holes pass 1.4
    # times area / size² quads, so the layer falls back to two and two; with ``exact``
    # (best_rows' other choices) it is None, and no mesh is made for it
    size = 0.07
    holes = [_ring(_sampled(_ellipse(0.25, 0.25, (x, 0)), size)[::-1]) for x in (-0.45, 0.45)]
    dom = parse_domain(
        {"type": "Polygon", "coordinates": [_ring(_sampled(_ellipse(1, 1), size)), *holes]}
    )

    def inner(d):
        return combine(
            domain=d, size=size, keep_boundary=True, all_quad=True, twice_size=True, inner=True
        )

    assert boundary_layer(dom, size, inner, rows=3, hole_rows=2)[3] == (2, 2)
    assert boundary_layer(dom, size, inner, rows=3, hole_rows=2, exact=True) is None
    assert boundary_layer(dom, size, inner, rows=3, hole_rows=1, exact=True)[3] == (3, 1)


def test_quad_combine_lays_rows_across_an_annulus():
    # the lattice between rows along both circles left nine valence 3-5 pairs here
    # (mean 0.890 to 0.897); quads across from circle to circle have none
    dom, res = _combined_annulus(0.1)
    assert res.stats["layer_rows"] == (0, 0)
    ang, q, ratio = _check(res.mesh, dom, 0.1)
    assert q.mean() >= 0.9 and q.min() >= 0.5 and ang.min() >= 30 and ang.max() <= 150
    assert ratio <= 1.5
    geo = dom.as_geojson()
    moved = {**geo, "coordinates": [(np.array(r) + 1e6).tolist() for r in geo["coordinates"]]}
    again = combine(domain=moved, size=0.1, all_quad=True, twice_size=True, optimize=True)
    assert np.array_equal(again.mesh.cells_by_type["quad"], res.mesh.cells_by_type["quad"])


def _grid(n, shift=0.0):
    """The unit square cut into n x n quads (its corners first), the inner grid point
    nearest (0, 0) moved by ``shift`` along the diagonal."""
    x = np.linspace(0, 1, n + 1)
    X, Y = np.meshgrid(x, x)
    P = np.column_stack([X.ravel(), Y.ravel()])
    P[n + 2] += shift
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)).ravel()
    Q = np.column_stack([a, a + 1, a + n + 2, a + n + 1])
    corners = [0, n, (n + 1) * (n + 1) - 1, n * (n + 1)]
    order = np.concatenate([corners, np.setdiff1d(np.arange(len(P)), corners)])
    new = np.empty_like(order)
    new[order] = np.arange(len(order))
    return Mesh(P[order], (CellBlock("quad", new[Q]),))


def test_targets_rank_counts_the_targets_met_before_the_least_quality():
    """At size 0.5 on the unit square: 2 x 2 quads meeting every target, then 4 x 4
    squares (4x the count, least 1), then 2 x 2 with least 0.35 (the count and the
    corners met), then 4 x 4 with least 0.48 and a higher mean (only the corners)."""
    dom = parse_domain({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]})
    meshes = [_grid(2, 0.12), _grid(4), _grid(2, 0.18), _grid(4, 0.075)]
    ranks = [targets_rank(m, dom, 0.5) for m in meshes]
    assert [r[:2] for r in ranks] == [(True, 3), (False, 2), (False, 2), (False, 1)]
    assert ranks == sorted(ranks, reverse=True)
    assert ranks[3][2:] > ranks[2][2:]  # higher least and mean, fewer targets met
