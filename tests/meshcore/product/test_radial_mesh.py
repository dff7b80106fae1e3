"""Radial meshes (§8.7.1, Figure 8.16): the classical product mesh and the balanced one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.mesh import quality, topology
from meshcore.product.radial_mesh import radial


def area(mesh) -> float:
    """Total area; every cell must be counterclockwise."""
    total = 0.0
    for b in mesh.cells:
        if b.type in ("triangle", "quad"):
            a = quality.signed_area(mesh.points, b.data, b.type)
            assert (a > 0).all()
            total += a.sum()
    return total


def polygon(n: int, r: float, angle: float) -> float:
    """Area of the fan of n equal chords over ``angle`` radians on radius r."""
    return 0.0 if n == 0 or r == 0 else n * r * r * math.sin(angle / n) / 2


def min_quality(mesh) -> float:
    rep = quality.report(mesh)
    return min(rep[t]["quality"]["min"] for t in ("triangle", "quad") if t in rep)


class TestClassical:
    def test_disk_counts_and_centre_triangles(self):
        r = radial(outer_radius=1, radial_layers=8, segments=32)
        counts = {b.type: len(b) for b in r.mesh.cells}
        assert counts == {"quad": 7 * 32, "triangle": 32, "line": 32}
        assert len(r.mesh.points) == 1 + 8 * 32  # one centre point, no duplicates
        assert r.ring_segments.tolist() == [0] + [32] * 8

    def test_ring_covers_its_polygon(self):
        r = radial(inner_radius=0.5, outer_radius=2, radial_layers=3, segments=20)
        a = 2 * math.pi
        assert area(r.mesh) == pytest.approx(polygon(20, 2, a) - polygon(20, 0.5, a))
        assert sum(len(x) for x in r.mesh.cell_sets["inner"]) == 20
        assert sum(len(x) for x in r.mesh.cell_sets["outer"]) == 20

    def test_sector_has_straight_sides(self):
        r = radial(outer_radius=1, angle=90, radial_layers=4, segments=6)
        assert {k: sum(map(len, v)) for k, v in r.mesh.cell_sets.items()} == {
            "outer": 6,
            "start": 4,
            "end": 4,
        }
        assert area(r.mesh) == pytest.approx(polygon(6, 1, math.pi / 2))


class TestBalanced:
    def test_balance_improves_the_minimum_quality_of_a_disk(self):
        before = radial(outer_radius=1, radial_layers=10, segments=64)
        after = radial(outer_radius=1, radial_layers=10, segments=64, balance=True)
        assert min_quality(after.mesh) > min_quality(before.mesh)
        assert min_quality(after.mesh) > 0.6
        # the classical report travels with the balanced mesh
        assert after.classical_quality == quality.report(before.mesh)

    def test_the_count_varies_and_triangles_sit_where_it_changes(self):
        r = radial(outer_radius=1, radial_layers=10, segments=64, balance=True)
        counts = r.ring_segments
        assert counts[0] == 0 and counts[1] == 6 and counts[-1] == 64
        assert (np.diff(counts) >= 0).all()
        bands = {b.type: r.mesh.cell_data["ring"][i] for i, b in enumerate(r.mesh.cells)}
        tri_per_band = np.bincount(bands["triangle"], minlength=10)
        quad_per_band = np.bincount(bands["quad"], minlength=10)
        # band j holds n_j quads and n_{j+1} - n_j triangles
        assert tri_per_band.tolist() == np.diff(counts).tolist()
        assert quad_per_band.tolist() == counts[:-1].tolist()

    @settings(max_examples=20, deadline=None)
    @given(
        r0=st.sampled_from([0.0, 0.1, 0.5]),
        angle=st.sampled_from([360.0, 180.0, 45.0]),
        layers=st.integers(1, 12),
        segments=st.integers(3, 80),
    )
    def test_both_cover_their_polygon_exactly(self, r0, angle, layers, segments):
        a = math.radians(angle)
        for balance in (False, True):
            r = radial(
                inner_radius=r0,
                outer_radius=1,
                angle=angle,
                radial_layers=layers,
                segments=segments,
                balance=balance,
            )
            n_in = r.ring_segments[0]
            assert area(r.mesh) == pytest.approx(polygon(segments, 1, a) - polygon(n_in, r0, a))
            conf = topology.conformity(r.mesh)
            assert conf["nonmanifold"] == 0
            assert conf["boundary_edges"] == sum(
                len(x) for v in r.mesh.cell_sets.values() for x in v
            )
            r.mesh.check()


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"outer_radius": 0}, "outer_radius"),
        ({"inner_radius": 2, "outer_radius": 1}, "outer_radius"),
        ({"angle": 400}, "angle"),
        ({"radial_layers": 0}, "radial_layers"),
        ({"segments": 2}, "segments"),
        ({"center": [0, math.nan]}, "center"),
    ],
)
def test_bad_parameters_name_the_field(kwargs, field):
    with pytest.raises(InputError) as err:
        radial(**{"outer_radius": 1, **kwargs})
    assert err.value.errors[0]["loc"] == [field]
