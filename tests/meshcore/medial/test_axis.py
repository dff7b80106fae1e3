r"""The medial axis (§9.4): analytic axes, radii, point clouds, pruning.

The rectangle 2 x 1 and its analytic axis::

    (0,1) +-----------------------+ (2,1)
          |  \                 /  |
          |   (0.5,.5)---(1.5,.5) |
          |  /                 \  |
    (0,0) +-----------------------+ (2,0)
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from meshcore.delaunay.kernel2d import delaunay
from meshcore.domain.planar import Domain, parse_domain
from meshcore.errors import InputError
from meshcore.medial.axis import medial_axis


# Domains built on first use, not at import: every pytest worker imports this module, and
# parse_domain at import compiled the domain checks in all of them at once on a cold cache.
@functools.cache
def rect() -> Domain:
    return parse_domain({"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1]]]})


RECT_AXIS = np.array(
    [
        [[0.5, 0.5], [1.5, 0.5]],
        [[0, 0], [0.5, 0.5]],
        [[0, 1], [0.5, 0.5]],
        [[2, 0], [1.5, 0.5]],
        [[2, 1], [1.5, 0.5]],
    ],
    dtype=float,
)


def circle(r: float, n: int, cw: bool = False) -> list[list[float]]:
    t = 2 * np.pi * np.arange(n) / n
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    return (ring[::-1] if cw else ring).tolist()


@functools.cache
def annulus() -> Domain:
    return parse_domain(
        {"type": "Polygon", "coordinates": [circle(1, 256), circle(0.5, 256, True)]}
    )


def segment_distance(x: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distance of each point of x (n, 2) to the nearest of segs (m, 2, 2), brute force."""
    a, b = segs[:, 0][None], segs[:, 1][None]
    ab = b - a
    t = np.clip(
        np.einsum("nmk,nmk->nm", x[:, None] - a, ab) / np.einsum("nmk,nmk->nm", ab, ab), 0, 1
    )
    foot = a + t[..., None] * ab
    return np.hypot(*(x[:, None] - foot).transpose(2, 0, 1)).min(axis=1)


def hausdorff_to(ax, segs: np.ndarray, step: float = 1e-3) -> float:
    """Symmetric Hausdorff distance between the axis polyline and analytic segments."""
    nodes_off = segment_distance(ax.nodes, segs).max()
    ours = ax.nodes[ax.edges]
    samples = np.concatenate(
        [
            a + np.linspace(0, 1, int(np.hypot(*(b - a)) / step) + 2)[:, None] * (b - a)
            for a, b in segs
        ]
    )
    # distance from analytic samples to our edges, via the edges near each sample
    tree = cKDTree(ours.mean(axis=1))
    reach = np.hypot(*(ours[:, 1] - ours[:, 0]).T).max() / 2 + step
    back = 0.0
    for chunk in np.array_split(samples, max(1, len(samples) // 2000)):
        d0, _ = tree.query(chunk)
        near = tree.query_ball_point(chunk, d0 + reach)
        back = max(
            back,
            max(
                segment_distance(c[None], ours[idx])[0] for c, idx in zip(chunk, near, strict=True)
            ),
        )
    return max(nodes_off, back)


def boundary_segments(dom) -> np.ndarray:
    return dom.points[dom.segments]


class TestRectangle:
    def test_topology_two_critical_four_terminal(self):
        ax = medial_axis(rect())
        crit = ax.nodes[ax.kind == "critical"]
        term = ax.nodes[ax.kind == "terminal"]
        assert len(crit) == 2 and len(term) == 4
        np.testing.assert_allclose(sorted(crit.tolist()), [[0.5, 0.5], [1.5, 0.5]], atol=1e-9)
        np.testing.assert_allclose(sorted(term.tolist()), [[0, 0], [0, 1], [2, 0], [2, 1]])
        assert ax.stats["branches"] == 5
        assert ax.stats["triangle_types"]["type2"] == 4

    def test_hausdorff_under_one_percent_of_the_width_at_the_default_h(self):
        assert hausdorff_to(medial_axis(rect()), RECT_AXIS) < 0.01 * 1.0

    def test_converges_as_h_shrinks(self):
        # h that do not divide the sides (different spacings on the sides): the error
        # falls like h**2 (measured 2.3e-4, 5.9e-5, 1.5e-5, 3.8e-6: rate 2.0)
        hs = [0.037, 0.0185, 0.00925, 0.004625]
        errors = [hausdorff_to(medial_axis(rect(), h=h), RECT_AXIS) for h in hs]
        rates = [math.log2(errors[i] / errors[i + 1]) for i in range(len(hs) - 1)]
        assert all(e < 0.01 * h for e, h in zip(errors, hs, strict=True))
        assert min(rates) > 1.8, (errors, rates)

    def test_radii_are_distances_to_the_boundary(self):
        ax = medial_axis(rect(), h=0.01)
        d = segment_distance(ax.nodes, boundary_segments(rect()))
        np.testing.assert_allclose(ax.radius, d, rtol=1e-9, atol=1e-15)

    def test_translated_and_scaled_inputs_give_the_same_axis(self):
        ax = medial_axis(rect(), h=0.01)
        for shift, scale in ((1e6, 1.0), (0.0, 1e-6)):
            coords = (np.array([[0, 0], [2, 0], [2, 1], [0, 1]]) * scale + shift).tolist()
            moved = medial_axis(
                parse_domain({"type": "Polygon", "coordinates": [coords]}), h=0.01 * scale
            )
            assert moved.stats["critical"] == 2 and moved.stats["terminal"] == 4
            assert len(moved.nodes) == len(ax.nodes)
            np.testing.assert_allclose(
                np.sort((moved.nodes - shift) / scale, axis=0), np.sort(ax.nodes, axis=0), atol=1e-6
            )

    def test_midpoints_approximation_has_the_same_topology(self):
        ax = medial_axis(rect(), approximation="midpoints")
        assert (ax.kind == "critical").sum() == 2 and (ax.kind == "terminal").sum() == 4

    def test_triangles_in_boundary_order_are_the_delaunay_ones(self):
        # Rows in increasing order of their smallest sample (the samples are
        # numbered along the boundary); the set is the kernel's (the whole
        # convex hull is the domain); each node's triangle is that node's.
        ax = medial_axis(rect(), h=0.01)
        assert (np.diff(ax.triangles.min(axis=1)) >= 0).all()
        kernel = delaunay(ax.samples).triangles
        assert sorted(map(tuple, np.sort(ax.triangles, axis=1).tolist())) == sorted(
            map(tuple, np.sort(kernel, axis=1).tolist())
        )
        own = np.flatnonzero(ax.node_triangle >= 0)
        np.testing.assert_array_equal(ax.triangle_node[ax.node_triangle[own]], own)

    def test_line_mesh_carries_the_radius(self):
        ax = medial_axis(rect(), h=0.05)
        mesh = ax.to_mesh()
        assert mesh.cells[0].type == "line" and len(mesh.cells[0].data) == len(ax.edges)
        np.testing.assert_array_equal(mesh.point_data["radius"], ax.radius)
        assert (mesh.cell_data["branch"][0] >= 0).all()


class TestAnnulus:
    def test_a_single_closed_loop_of_radius_075(self):
        ax = medial_axis(annulus())
        assert (ax.kind == "terminal").sum() == 0 and (ax.kind == "critical").sum() == 0
        assert len(ax.branches) == 1 and ax.branches[0][0] == ax.branches[0][-1]
        assert len(ax.edges) == len(ax.nodes)  # one cycle
        np.testing.assert_allclose(np.hypot(*ax.nodes.T), 0.75, atol=2e-3)
        np.testing.assert_allclose(ax.radius, 0.25, atol=2e-3)

    def test_radii_are_distances_to_the_boundary(self):
        ax = medial_axis(annulus(), h=0.02)
        d = segment_distance(ax.nodes, boundary_segments(annulus()))
        np.testing.assert_allclose(ax.radius, d, rtol=1e-9)

    def test_no_pruning_keeps_the_discretization_branches(self):
        assert (medial_axis(annulus(), prune=0).kind == "terminal").sum() > 0


class TestSmoothShapes:
    def test_a_disk_has_its_centre_for_axis(self):
        ax = medial_axis(parse_domain({"type": "Polygon", "coordinates": [circle(1, 400)]}))
        assert list(ax.kind) == ["isolated"]
        np.testing.assert_allclose(ax.nodes[0], [0, 0], atol=1e-9)

    def test_an_ellipse_axis_ends_near_its_centres_of_curvature(self):
        # axes 2 and 1: the axis is the segment between (-1.5, 0) and (1.5, 0);
        # trimming the tails at 25 degrees of contact ends it at 1.5 cos(6.3 deg)
        t = 2 * np.pi * np.arange(400) / 400
        ring = np.c_[2 * np.cos(t), np.sin(t)].tolist()
        ax = medial_axis(parse_domain({"type": "Polygon", "coordinates": [ring]}))
        assert (ax.kind == "critical").sum() == 0 and (ax.kind == "terminal").sum() == 2
        ends = np.sort(ax.nodes[ax.kind == "terminal"][:, 0])
        np.testing.assert_allclose(ends, [-1.5, 1.5], atol=0.02)
        np.testing.assert_allclose(ax.nodes[:, 1], 0, atol=1e-3)


class TestPointCloud:
    def test_reproduces_the_polygon_result_on_the_same_samples(self):
        ax = medial_axis(rect(), h=0.05)
        ring = ax.samples  # the samples, in order along the boundary
        polygon = parse_domain({"type": "Polygon", "coordinates": [ring.tolist()]})
        spacing = np.hypot(*np.diff(np.vstack([ring, ring[:1]]), axis=0).T).max()
        from_polygon = medial_axis(polygon, h=spacing)
        shuffled = np.random.default_rng(1).permutation(ring)
        from_cloud = medial_axis(points=shuffled)
        assert len(from_cloud.nodes) == len(from_polygon.nodes)
        np.testing.assert_allclose(
            np.sort(from_cloud.nodes, axis=0), np.sort(from_polygon.nodes, axis=0), atol=1e-12
        )
        np.testing.assert_allclose(np.sort(from_cloud.radius), np.sort(from_polygon.radius))

    def test_annulus_cloud_has_a_hole(self):
        pts = np.concatenate([circle(1, 200), circle(0.5, 100)])
        ax = medial_axis(points=pts)
        assert ax.domain.ring_count == 2 and len(ax.branches) == 1

    @pytest.mark.parametrize(
        "points, code",
        [
            ([[0, 0], [1, 0]], "too_few_points"),
            ([[0, 0], [1, 0], [0, 0], [0, 1]], "duplicate_points"),
            ([[0, 0], [1, 0], [float("nan"), 1]], "non_finite"),
        ],
    )
    def test_bad_clouds_are_refused_with_the_point(self, points, code):
        with pytest.raises(InputError) as exc:
            medial_axis(points=points)
        assert exc.value.code == code and exc.value.errors[0]["loc"][0] == "points"


class TestErrors:
    @pytest.mark.parametrize(
        "kwargs, loc",
        [({"h": -1}, "h"), ({"prune": 200}, "prune"), ({"approximation": "x"}, "approximation")],
    )
    def test_bad_parameters_name_the_field(self, kwargs, loc):
        with pytest.raises(InputError) as exc:
            medial_axis(rect(), **kwargs)
        assert exc.value.errors[0]["loc"] == [loc]

    def test_a_spike_thinner_than_rounding_is_refused_at_its_vertex(self):
        # vertex 12 turns back along its previous segment, off it by rounding only
        ring = [[0.35, 0.05], [0.65, 0.35], [0.25, 0.25], [0.05, 0.3], [-0.0, 0.5], [-0.05, 0.15],
                [-0.45, 0.4], [-0.3, 0.05], [-0.75, -0.15], [-0.4, -0.1], [-0.3, -0.1],
                [-0.2, -0.15], [-0.25, -0.2], [-0.15, -0.1], [-0.05, -0.65], [0.1, -0.55],
                [0.2, -0.95], [0.25, -0.95], [0.55, -0.65], [0.35, -0.1]]  # fmt: skip
        with pytest.raises(InputError) as exc:
            medial_axis(parse_domain({"type": "Polygon", "coordinates": [ring]}))
        assert exc.value.code == "degenerate_boundary"
        assert exc.value.errors[0]["loc"] == ["coordinates", 0, 12]

    def test_a_runaway_h_is_refused(self):
        with pytest.raises(InputError) as exc:
            medial_axis(rect(), h=1e-9)
        assert exc.value.code == "too_many_samples"


@st.composite
def stars(draw):
    """Random star-shaped polygons around the origin (valid domains)."""
    n = draw(st.integers(5, 14))
    radii = draw(st.lists(st.floats(0.3, 1.0), min_size=n, max_size=n))
    t = 2 * np.pi * np.arange(n) / n
    return (np.c_[np.cos(t), np.sin(t)] * np.array(radii)[:, None]).tolist()


class TestRandomDomains:
    @settings(max_examples=25, deadline=None)
    @given(stars())
    def test_axis_is_connected_inside_with_exact_radii(self, ring):
        dom = parse_domain({"type": "Polygon", "coordinates": [ring]})
        ax = medial_axis(dom, h=0.02)
        segs = boundary_segments(dom)
        d = segment_distance(ax.nodes, segs)
        np.testing.assert_allclose(ax.radius, d, rtol=1e-9, atol=1e-12)
        # a tree (no hole): one component, edges = nodes - 1
        assert len(ax.edges) == len(ax.nodes) - 1
        inside = shapely.contains_xy(shapely.Polygon(ring).buffer(1e-9), *ax.nodes.T)
        assert inside.all()


class TestAnyPolygon:
    @settings(max_examples=60, deadline=None)
    @given(
        st.lists(
            st.tuples(st.integers(0, 20), st.integers(0, 20)), min_size=3, max_size=9, unique=True
        )
    )
    def test_valid_or_refused_with_a_location(self, ring):
        # random rings: most cross themselves (refused with the ring and vertex),
        # the others get an axis whose radii are distances to the boundary
        from meshcore.errors import MeshcoreError

        coords = [[x / 20, y / 20] for x, y in ring]
        try:
            dom = parse_domain({"type": "Polygon", "coordinates": [coords]})
        except InputError as exc:
            assert exc.errors[0]["loc"][0] == "coordinates"
            return
        try:
            ax = medial_axis(dom, h=0.01)
        except MeshcoreError as exc:
            assert isinstance(exc, InputError) and exc.errors[0]["loc"][0] == "coordinates"
            return
        d = segment_distance(ax.nodes, boundary_segments(dom))
        np.testing.assert_allclose(ax.radius, d, rtol=1e-9, atol=1e-12)
        assert len(ax.edges) == len(ax.nodes) - 1  # one ring, no hole: a tree
