"""Facts about ``quad_grid`` (§8.5.2): only quads, exact area, corners kept, conforming.

Each mesh goes through :func:`assert_fitted` of ``test_cartesian`` (cells
strictly convex by exact orientation, input vertices present, input
segments chains of edges, border edges exactly those chains, area exact),
and holds only quads. The named domains take the projection route (the
band built by projecting the core's outline); a constraint segment takes
the triangulation fallback, which must hold the same facts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.errors import InputError
from meshcore.grid import quad_grid
from tests.meshcore.grid.test_cartesian import NAMED, assert_fitted, circle, square_with_hole


def _only_quads(mesh):
    assert [b.type for b in mesh.cells] == ["quad"]


class TestQuadGrid:
    @pytest.mark.parametrize("smooth", [False, True])
    @pytest.mark.parametrize("name", NAMED)
    def test_named_domains(self, name, smooth):
        domain, h = NAMED[name]
        res = quad_grid(domain, size=h / 2, smooth=smooth)
        assert res.stats["band"] == "projection", res.stats["fallback"]
        _only_quads(res.mesh)
        assert_fitted(domain, res.mesh)
        assert res.stats["min_scaled_jacobian"] > 0

    def test_corner_pattern(self):
        """Each corner of the square is a vertex of one quad only (the corner quad)."""
        domain, h = NAMED["aligned_square"]
        res = quad_grid(domain, size=h / 2, smooth=False)
        assert res.stats["band"] == "projection"
        P, Q = res.mesh.points, res.mesh.cells[0].data
        for corner in domain["coordinates"][0]:
            (v,) = np.flatnonzero((P == corner).all(axis=1))
            assert (Q == v).any(axis=1).sum() == 1

    def test_constraint_takes_the_fallback(self):
        rings = square_with_hole()["coordinates"]
        dom = parse_domain({"type": "Polygon", "coordinates": rings}, [[[0.05, 0.5], [0.2, 0.5]]])
        res = quad_grid(dom, size=0.02, smooth=False)
        assert res.stats["band"] == "triangulation" and res.stats["fallback"]
        _only_quads(res.mesh)
        assert_fitted(dom, res.mesh)

    def test_interior_cells_are_squares(self):
        domain, h = NAMED["square_with_hole"]
        res = quad_grid(domain, size=h / 2)
        P = res.mesh.points
        q = res.mesh.cells[0].data[res.mesh.cell_sets["interior"][0]]
        assert len(q) == res.stats["interior_squares"] > 0
        np.testing.assert_allclose(np.linalg.norm(P[q] - P[np.roll(q, -1, axis=1)], axis=2), h / 2)

    def test_layers_widen_the_band(self):
        domain, h = NAMED["square_with_hole"]
        one = quad_grid(domain, size=h / 2, layers=1)
        two = quad_grid(domain, size=h / 2, layers=2)
        assert two.stats["band"] == "projection"
        assert two.stats["interior_squares"] < one.stats["interior_squares"]
        assert_fitted(domain, two.mesh)

    def test_translation_and_scale(self):
        domain, h = NAMED["l_shape"]
        base = quad_grid(domain, size=h / 2)
        moved = {
            "type": "Polygon",
            "coordinates": [[[1e-6 * x, 1e-6 * y] for x, y in r] for r in domain["coordinates"]],
        }
        res = quad_grid(moved, size=1e-6 * h / 2)
        assert_fitted(moved, res.mesh)
        assert res.stats["quads"] == base.stats["quads"]
        assert res.stats["band"] == base.stats["band"] == "projection"
        shifted = {
            "type": "Polygon",
            "coordinates": [[[x + 1e6, y + 1e6] for x, y in r] for r in domain["coordinates"]],
        }
        res = quad_grid(shifted, size=h / 2)
        assert_fitted(shifted, res.mesh)
        assert res.stats["quads"] == base.stats["quads"]
        assert res.stats["band"] == "projection"
        np.testing.assert_allclose(
            np.sort(res.mesh.points - 1e6, axis=0), np.sort(base.mesh.points, axis=0), atol=1e-8
        )

    @settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def test_random_polygons_with_holes(self, data):
        seed = data.draw(st.integers(0, 2**32 - 1))
        rng = np.random.default_rng(seed)
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
        res = quad_grid(domain, size=data.draw(st.floats(0.02, 0.08)))
        _only_quads(res.mesh)
        assert_fitted(domain, res.mesh)

    @settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def test_random_plates_with_holes(self, data):
        """Rectangles with round holes: the projection's home ground (either route holds)."""
        w = data.draw(st.floats(0.6, 1.5))
        size = data.draw(st.floats(0.02, 0.05))
        rings = [[[0, 0], [w, 0], [w, 1], [0, 1]]]
        for k in range(data.draw(st.integers(0, 2))):
            # the holes sit w / 4 from the sides and w / 2 apart: radii under w / 4 - 0.02
            # keep them off the sides and each other (0.15 at w = 0.6 touched the side)
            r = data.draw(st.floats(0.06, min(0.15, w / 4 - 0.02)))
            n = max(8, int(2 * math.pi * r / size))
            rings.append(circle((k + 0.5) * w / 2, data.draw(st.floats(0.3, 0.7)), r, n))
        domain = {"type": "Polygon", "coordinates": rings}
        res = quad_grid(domain, size=size, layers=data.draw(st.integers(1, 2)))
        _only_quads(res.mesh)
        assert_fitted(domain, res.mesh)

    @pytest.mark.parametrize(
        "kw, loc",
        [
            ({"size": 1e-6}, ("size",)),
            ({"size": 0}, ("size",)),
            ({"layers": 0}, ("layers",)),
            # no square fits a thin strip, and the fallback's band would be about 2 / w
            # triangles: refused before triangulating
            ({"domain": [[0, 0], [1, 0], [1, 1e-5], [0, 1e-5]], "size": 0.025}, ("domain",)),
            # a ring far denser than the grid: no projection, a band of 120k triangles
            ({"domain": circle(0.5, 0.5, 0.5, 60_000), "size": 0.025}, ("domain",)),
        ],
    )
    def test_bad_input(self, kw, loc):
        kw = dict(kw)
        ring = kw.pop("domain", None)
        domain = square_with_hole() if ring is None else {"type": "Polygon", "coordinates": [ring]}
        with pytest.raises(InputError) as err:
            quad_grid(domain, **kw)
        assert tuple(err.value.errors[0]["loc"]) == loc
        if ring is not None:
            assert err.value.code == "too_many_cells" and "triangulate" in str(err.value)
