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


def test_the_subfaces_split_in_a_round_are_those_its_centres_flagged(monkeypatch):
    """In a refinement round whose rejected centres ask for both subsegment and
    subface splits, the subsegment splits retriangulated their facets first, which
    renumbered the subfaces before the rows the centres had flagged were split:
    other subfaces were split (on star seed 6, 12 in 4 such rounds; the seeds 1-29
    were over-refined up to 18x, 23,438 tetrahedra instead of 1,289 on seed 10).
    Now the retriangulation waits for both splits: every subface split in such a
    round is one a centre encroached or a flat tetrahedron leaned on."""
    from meshcore.delaunay.recovery3d import SurfaceRecovery, face_keys
    from meshcore.tets import refinement

    seen = {"in_round": False, "flagged": set(), "segments": 0, "mixed": 0, "wrong": 0}
    protected, split_sub, split_seg = (
        SurfaceRecovery.protected_subfaces,
        SurfaceRecovery.split_subfaces,
        SurfaceRecovery.split_segments,
    )
    insert = refinement._insert_interior

    def flag(self, rows):  # every subface a centre encroaches or leans on is asked about
        if seen["in_round"]:
            seen["flagged"].update(face_keys(self.sub[rows]).tolist())
        return protected(self, rows)

    def subfaces(self, rows, *args):
        if seen["in_round"] and seen["segments"]:
            keys = face_keys(self.sub[rows]).tolist()
            seen["mixed"] += len(keys) > 0
            seen["wrong"] += sum(k not in seen["flagged"] for k in keys)
        return split_sub(self, rows, *args)

    def segments(self, rows, *args):
        n = split_seg(self, rows, *args)
        seen["segments"] += n if seen["in_round"] else 0
        return n

    def round_(*args):
        seen.update(in_round=True, flagged=set(), segments=0)
        try:
            return insert(*args)
        finally:
            seen["in_round"] = False

    monkeypatch.setattr(SurfaceRecovery, "protected_subfaces", flag)
    monkeypatch.setattr(SurfaceRecovery, "split_subfaces", subfaces)
    monkeypatch.setattr(SurfaceRecovery, "split_segments", segments)
    monkeypatch.setattr(refinement, "_insert_interior", round_)
    s = parse_surface(*star_by_seed(6))
    r = tetrahedralize(s, max_radius_edge=2.0)
    assert_valid(r, s)
    assert seen["mixed"] > 0
    assert seen["wrong"] == 0
