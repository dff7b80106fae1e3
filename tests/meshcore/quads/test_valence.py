"""The valence clean-up of all-quad pairings (:mod:`meshcore.quads.valence`): exact counts.

The defect of a pairing is ``sum |cells - ideal|`` over its vertices plus one
per leftover triangle; after the split (Figure 8.13) it is the final mesh's
``sum |valence - ideal|``. Checked by hand on two triangles, recomputed from
scratch on random meshes, and read off the final mesh of a disk.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.quads import combination, combine
from meshcore.quads.paths import heap_kernel
from meshcore.quads.valence import fewer_defects
from meshcore.triangulation.refinement import triangulate
from tests.meshcore.quads.test_combination import star_domain


def _defect(P, tri, nb, mate) -> int:
    """The defect of a pairing, counted on the mixed mesh's cells (independently)."""
    n, m = len(P), len(tri)
    cells = np.zeros(n, np.int64)
    for t in range(m):
        s = int(mate[t])
        if s >= 0 and s < t:
            continue
        verts = set(tri[t].tolist()) | (set(tri[s].tolist()) if s >= 0 else set())
        for v in verts:
            cells[v] += 1
    bnd = np.zeros(n, bool)
    t_b, k_b = np.nonzero(nb < 0)
    bnd[tri[t_b, k_b]] = True
    bnd[tri[t_b, (k_b + 1) % 3]] = True
    total = np.zeros(n)
    np.add.at(total, tri.ravel(), quality.triangle_angles(P, tri).ravel())
    ideal = np.where(bnd, np.maximum(np.rint(total / 90), 1), 4)
    return int(np.abs(cells - ideal)[np.unique(tri)].sum() + np.count_nonzero(mate < 0))


def test_two_leftover_triangles_with_a_flat_corner_pair_under_the_wider_bound():
    # A(0) and B(1) end the common edge; C2(3) is nearly on AB (a 176-degree corner): the
    # all-quad bound refuses the pair (w < 0), the merge bound allows it
    P = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [1.0, -0.07]])
    tri = np.array([[0, 1, 2], [1, 0, 3]])
    nb = np.array([[1, -1, -1], [0, -1, -1]])
    w = np.full((2, 3), -1.0)
    mate = np.full(2, -1)
    assert _defect(P, tri, nb, mate) == 5  # A and B: 2 cells for 1; C2: 1 for 2; 2 leftovers
    same = fewer_defects(P, tri, nb, w, w, mate)
    assert same == {"defect_before": 5, "defect_after": 5, "merged": 0, "moved": 0}
    w_merge = np.array([[0.1, -1, -1], [0.1, -1, -1]])
    out = fewer_defects(P, tri, nb, w, w_merge, mate)
    assert out == {"defect_before": 5, "defect_after": 1, "merged": 1, "moved": 0}
    assert mate.tolist() == [1, 0]
    assert _defect(P, tri, nb, mate) == 1


def _heap_pairing(seed):
    """A triangulated random star, its all-quad and merge weights, and the heap's pairing."""
    rng = np.random.default_rng(seed)
    dom = parse_domain(star_domain(rng, int(rng.integers(8, 20)), int(rng.integers(0, 3))))
    mesh = triangulate(dom, size=0.12, min_angle=25).mesh
    P, tri = mesh.points, mesh.cells[0].data.astype(np.int64)
    tol = combination.TOL
    nb = combination._neighbours(mesh, P, tri)
    _, w = combination._candidates(P, tri, nb, "angle", None, 0.0, tol.all_quad_flat_corner)
    _, w_merge = combination._candidates(P, tri, nb, "angle", None, 0.0, tol.flat_corner)
    valid = np.flatnonzero((w.ravel() >= 0) & (np.arange(w.size) // 3 < nb.ravel()))
    order = valid[np.argsort(-w.ravel()[valid], kind="stable")]
    mate = np.full(len(tri), -1, np.int64)
    heap_kernel(nb, w, order, mate, True)
    return P, tri, nb, w, w_merge, mate


def _check_cleanup(P, tri, nb, w, w_merge, mate) -> dict:
    """fewer_defects on a pairing: its counts recomputed from scratch, and still a pairing:
    mutual, adjacent, every new pair allowed (a merge under the wider bound)."""
    before = _defect(P, tri, nb, mate)
    pairs_before = {(t, int(s)) for t, s in enumerate(mate) if s >= 0}
    out = fewer_defects(P, tri, nb, w, w_merge, mate)
    assert out["defect_before"] == before
    assert out["defect_after"] == _defect(P, tri, nb, mate) <= before
    for t, s in enumerate(mate.tolist()):
        if s < 0:
            continue
        assert mate[s] == t
        k = int(np.flatnonzero(nb[t] == s)[0])
        if (t, s) not in pairs_before:
            assert w[t, k] >= 0 or (w_merge[t, k] >= 0 and out["merged"] > 0)
    return out


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1))
def test_random_pairings_lose_defect_and_stay_valid(seed):
    _check_cleanup(*_heap_pairing(seed))


def test_boundary_vertices_in_too_many_cells_are_searched_from():
    # star 0: the paths from the leftover triangles reach 60; the alternating cycles
    # from the boundary vertices holding more cells than their ideal take it to 54
    P, tri, nb, w, w_merge, mate = _heap_pairing(0)
    out = _check_cleanup(P, tri, nb, w, w_merge, mate)
    assert (out["defect_before"], out["defect_after"]) == (72, 54)


def test_disk_split_has_the_defect_counted_before_it():
    # the final mesh's sum |valence - ideal| (4 inside, 2 on the smooth boundary) is the
    # defect the clean-up counted on the inner pairing, and it went down
    n = 42
    th = 2 * np.pi * np.arange(n) / n
    ring = np.column_stack([np.cos(th), np.sin(th)])
    geo = {"type": "Polygon", "coordinates": [np.vstack([ring, ring[:1]]).tolist()]}
    res = combine(domain=geo, size=0.15, all_quad=True, twice_size=True)
    v = res.stats["valence"]
    assert v["defect_after"] < v["defect_before"]
    P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
    m = Mesh(P, (CellBlock("quad", Q),))
    val = np.bincount(m.cells[0].data.ravel(), minlength=len(P))
    a, b = Q.ravel(), np.roll(Q, -1, axis=1).ravel()
    key = np.minimum(a, b) * len(P) + np.maximum(a, b)
    uk, cnt = np.unique(key, return_counts=True)
    bnd = np.zeros(len(P), bool)
    bnd[uk[cnt == 1] // len(P)] = True
    bnd[uk[cnt == 1] % len(P)] = True
    assert int(np.abs(val - np.where(bnd, 2, 4)).sum()) == v["defect_after"]
