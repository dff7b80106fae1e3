"""Random star polyhedra that once failed (``benchmarks/robustness3d.py``)."""

from __future__ import annotations

import pytest

from meshcore.domain.surface import parse_surface
from meshcore.tets import tetrahedralize
from tests.meshcore.tets.test_tetrahedralize import assert_valid, star_by_seed


@pytest.mark.parametrize("seed", [47, 95, 1097])
def test_circumcentre_beyond_its_facet_splits_the_crossed_subsegment(seed):
    """A subface whose circumcentre lies outside its facet, in no subsegment's
    diametral ball, was split at its centroid: on seed 95 that happened 710
    times, every split nearer the edge 0-7, until four points lay within 1e-9 of
    each other and the facet could not be triangulated in its plane
    (``recovery_failed``); seed 47 ran past 20 CPU s, 1097 failed the same way.
    Now the subsegment crossed on the way to the circumcentre is split: valid
    meshes, each in about a second or less."""
    s = parse_surface(*star_by_seed(seed))
    assert_valid(tetrahedralize(s, max_radius_edge=2.0), s)


def test_a_flat_tetrahedron_s_centroid_splits_what_it_encroaches():
    """A nearly flat tetrahedron (circumcentre outside the surface's box) with no
    face on the surface gets its centroid inserted; that centroid went in even
    inside a subface's equatorial ball, next to the facet, and made flatter
    tetrahedra whose centroids went nearer still: star seed 1046 inserted 59,429
    of them and reached the point limit. Now the centroid obeys the
    circumcentre's rule (it splits what it encroaches): 397 tetrahedra."""
    s = parse_surface(*star_by_seed(1046))
    assert_valid(tetrahedralize(s, max_radius_edge=2.0), s)
