"""Facts about ``pattern`` (§8.2, Figures 8.6-8.7).

The Figure 8.7 domain, a disc with a rectangular hole off its centre, with
each pattern of Figure 8.6::

        ______
      /        \\      parallelogram, hexagon, radial (about a point off
     |   [  ]   |     the disc's centre); the gap between the retained
      \\______/       patterns and the boundary meshed, then merged

Each mesh goes through :func:`assert_fitted` (exact area, input segments as
chains of edges, input vertices kept, cells strictly convex, conforming);
the retained cells are exactly the pattern's (same shapes).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.grid import pattern
from tests.meshcore.grid.test_cartesian import assert_fitted, circle

DISC = {
    "type": "Polygon",
    "coordinates": [
        circle(0, 0, 1, 96),
        [[0.15, -0.2], [0.15, 0.25], [0.55, 0.25], [0.55, -0.2]],
    ],
}
PATTERNS = {
    "parallelogram": {"type": "parallelogram", "vectors": [[0.1, 0], [0.04, 0.09]]},
    "hexagon": {"type": "hexagon", "size": 0.07},
    "radial": {"type": "radial", "center": [-0.3, 0.1], "rings": 12, "segments": 48},
}


def _pattern_cells(mesh):
    P = mesh.points
    out = []
    for b, ids in zip(mesh.cells, mesh.cell_sets["pattern"], strict=True):
        out.append((b.type, P[b.data[ids]]))
    return out


class TestFigure87:
    @pytest.mark.parametrize("gap", ["triangles", "quads"])
    @pytest.mark.parametrize("name", PATTERNS)
    def test_each_pattern(self, name, gap):
        res = pattern(DISC, pattern=PATTERNS[name], gap=gap)
        assert_fitted(DISC, res.mesh)
        st_ = res.stats["steps"]
        assert st_["i"] > st_["ii"] > 0 and st_["iv"] == res.mesh.n_cells
        assert 0.3 < res.stats["pattern_area_share"] < 1
        if gap == "quads":
            assert [b.type for b in res.mesh.cells] == ["quad"]
            # the gap optimized with the patterns fixed (0.28 and 0.11 before)
            if name != "radial":
                assert res.stats["quality"]["quad"]["min"] > 0.45

    def test_parallelogram_cells_are_the_pattern(self):
        a, b = np.array([0.1, 0]), np.array([0.04, 0.09])
        res = pattern(DISC, pattern=PATTERNS["parallelogram"])
        [(kind, V)] = [c for c in _pattern_cells(res.mesh) if len(c[1])]
        assert kind == "quad"
        np.testing.assert_allclose(V[:, 1] - V[:, 0], np.broadcast_to(a, (len(V), 2)), atol=1e-12)
        np.testing.assert_allclose(V[:, 3] - V[:, 0], np.broadcast_to(b, (len(V), 2)), atol=1e-12)

    def test_hexagons_are_whole_and_equilateral(self):
        res = pattern(DISC, pattern=PATTERNS["hexagon"])
        [(kind, V)] = _pattern_cells(res.mesh)
        assert kind == "triangle" and len(V) % 6 == 0
        sides = np.linalg.norm(V - np.roll(V, -1, axis=1), axis=2)
        np.testing.assert_allclose(sides, 0.07, rtol=1e-12)

    def test_radial_quads_about_the_centre(self):
        res = pattern(DISC, pattern=PATTERNS["radial"])
        [(kind, V)] = [c for c in _pattern_cells(res.mesh) if len(c[1])]
        r = np.linalg.norm(V - np.array([-0.3, 0.1]), axis=2)
        np.testing.assert_allclose(r[:, 0], r[:, 3], rtol=1e-12)  # corners 0, 3 on one circle
        np.testing.assert_allclose(r[:, 1], r[:, 2], rtol=1e-12)

    def test_margin_keeps_patterns_away(self):
        near = pattern(DISC, pattern=PATTERNS["hexagon"], margin=0.1)
        far = pattern(DISC, pattern=PATTERNS["hexagon"], margin=1.5)
        assert far.stats["steps"]["ii"] < near.stats["steps"]["ii"]
        assert_fitted(DISC, far.mesh)

    @settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def test_random_polygons_with_holes(self, data):
        rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
        n = data.draw(st.integers(6, 30))
        th = np.sort((np.arange(n) + rng.uniform(-0.4, 0.4, n)) * 2 * np.pi / n)
        outer = (
            np.column_stack([np.cos(th), np.sin(th)]) * rng.uniform(0.55, 1.0, (n, 1))
        ).tolist()
        rings = [outer]
        for k in range(data.draw(st.integers(0, 2))):
            c = 0.3 * np.array([math.cos(2 * math.pi * k / 3), math.sin(2 * math.pi * k / 3)])
            rings.append((c + np.asarray(circle(0, 0, rng.uniform(0.05, 0.12), 8))).tolist())
        domain = {"type": "Polygon", "coordinates": rings}
        name = data.draw(st.sampled_from(sorted(PATTERNS)))
        spec = {
            "parallelogram": {"type": "parallelogram", "vectors": [[0.06, 0.01], [0.02, 0.07]]},
            "hexagon": {"type": "hexagon", "size": 0.05},
            "radial": {"type": "radial", "center": [0.1, -0.05], "rings": 10, "segments": 40},
        }[name]
        res = pattern(domain, pattern=spec, gap=data.draw(st.sampled_from(["triangles", "quads"])))
        assert_fitted(domain, res.mesh)


class TestBadInput:
    @pytest.mark.parametrize(
        "spec, loc",
        [
            ({"type": "parallelogram", "vectors": [[1, 0], [2, 0]]}, ("pattern", "vectors")),
            ({"type": "parallelogram", "vectors": [[0, 0], [0, 1]]}, ("pattern", "vectors", 0)),
            ({"type": "hexagon", "size": 0}, ("pattern", "size")),
            ({"type": "hexagon", "size": 10**400}, ("pattern", "size")),  # not an OverflowError
            ({"type": "hexagon"}, ("pattern", "size")),
            ({"type": "parallelogram", "vectors": [[10**400, 0], [0, 1]]}, ("pattern", "vectors")),
            (
                {"type": "radial", "center": [0, 0], "radii": [0, 0.5], "segments": 8},
                ("pattern", "radii", 0),
            ),
            (
                {"type": "radial", "center": [0, 0], "radii": [0.5, 0.2], "segments": 8},
                ("pattern", "radii", 1),
            ),
            (
                {"type": "radial", "center": [0, 0], "radii": [0.5, 10**400], "segments": 8},
                ("pattern", "radii"),
            ),
            (
                {"type": "radial", "center": [10**400, 0], "radii": [0.5, 1], "segments": 8},
                ("pattern", "center"),
            ),
            (
                {"type": "radial", "center": [0, 0], "rings": 3, "segments": 2},
                ("pattern", "segments"),
            ),
            ({"type": "spiral"}, ("pattern", "type")),
        ],
    )
    def test_bad_pattern(self, spec, loc):
        with pytest.raises(InputError) as err:
            pattern(DISC, pattern=spec)
        assert tuple(err.value.errors[0]["loc"]) == loc

    def test_bad_margin_and_gap(self):
        with pytest.raises(InputError) as err:
            pattern(DISC, pattern=PATTERNS["hexagon"], margin=0)
        assert err.value.errors[0]["loc"] == ["margin"]
        with pytest.raises(InputError) as err:
            pattern(DISC, pattern=PATTERNS["hexagon"], gap="hexes")
        assert err.value.errors[0]["loc"] == ["gap"]
