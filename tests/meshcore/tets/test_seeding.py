"""Facets seeded with a lattice of their size (``meshcore.tets.seeding``)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from meshcore.delaunay.recovery3d import KNOBS, SurfaceRecovery, recover
from meshcore.domain import parse_surface
from meshcore.tets import tetrahedralize
from meshcore.tets.seeding import SPACING, far_facets, seed_facets
from tests.meshcore.domain import shapes
from tests.meshcore.tets.test_tetrahedralize import NONE_LEFT, assert_valid


def test_lattice_points_lie_in_their_facet_away_from_its_boundary():
    """On a box whose edges are split to the size: every seeded point in its facet's
    plane (to rounding) and inside it, in no subsegment's diametral ball, no two
    points of a facet closer than half the lattice's spacing."""
    b = SurfaceRecovery(parse_surface(*shapes.box((0, 0, 0), (1, 0.5, 0.25))), KNOBS)
    recover(b, None)
    h = 0.05
    while True:
        L = np.linalg.norm(b.P[b.seg[:, 0]] - b.P[b.seg[:, 1]], axis=1)
        if not b.split_segments(np.flatnonzero(L > h)):
            break
    recover(b, None)
    bound = np.full(len(b.facet_size), h)
    far = far_facets(b, KNOBS.size_radius * bound, np.zeros(len(bound), dtype=bool))
    assert far.size >= 2
    n0 = b.n
    added = seed_facets(b, far, bound[far])
    assert added == b.n - n0 > 0
    X, f = b.P[n0:], b.pt_facet[n0:]
    assert (b.pt_edge[n0:] == -1).all() and (f >= 0).all()
    assert b.in_facet(X, f).all()
    origin, e1, e2 = b.frame
    nrm = np.cross(e1[f], e2[f])
    assert np.abs(np.einsum("ij,ij->i", X - origin[f], nrm)).max() <= 1e-15
    assert b.encroached_segments(X)[0].size == 0
    for g in np.unique(f).tolist():
        pts = b.P[b.pt_facet == g]
        d, _ = cKDTree(pts).query(pts, k=2)
        assert d[:, 1].min() >= 0.5 * SPACING * h
    # The facets' subfaces are their 2D Delaunay triangulations with the lattice.
    assert np.isin(np.arange(n0, b.n), b.sub).all()


def test_a_thin_strip_at_a_size_finishes_in_few_rounds():
    """The strip 1 x 0.1 x 0.01 at size 0.01: its large faces are seeded at once (before,
    about 1.5 times more points a round: 23 rounds, now 16, 7 of them halving the
    edges); a valid mesh, every radius-edge ratio at most 2."""
    s = parse_surface(*shapes.box((0, 0, 0), (1, 0.1, 0.01)))
    r = tetrahedralize(s, size=0.01, max_radius_edge=2.0)
    assert_valid(r, s)
    assert r.given_up == 0
    assert r.left["radius_edge_above"] == NONE_LEFT
    assert r.rounds <= 17


def test_no_lattice_beyond_the_point_limit():
    """A lattice holding more points than the refinement may still add is not laid (a
    1 x 1 x 1e-5 plate's asked for 3e9): nothing added, the rounds go on to the limit."""
    b = SurfaceRecovery(parse_surface(*shapes.box((0, 0, 0), (1, 1, 1e-5))), KNOBS)
    n0 = b.n
    bottom = b.group[(b.P[b.facets][:, :, 2] == 0).all(axis=1)][:1]  # the 1 x 1 face
    assert seed_facets(b, bottom, np.array([2e-5])) == 0
    assert b.n == n0 == len(b.P)
