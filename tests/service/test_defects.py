"""One regression test per defect of issue 22, named after what it guards.

Races are timed in process (:mod:`tests.service.inprocess`): the write or
the conversion is held at a gate while the DELETE or the expiry runs. The
rest go through the same app and routes. The stray Dask cancel runs on a
real scheduler, in ``tests/service/test_dask.py`` (its cluster):
``test_run_cancelled_by_the_scheduler_is_requeued``.
"""

from __future__ import annotations

import asyncio
import base64
import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import service.downloads
import service.store
from meshcore.errors import InputError
from service.methods.registry import default_registry
from service.runner import JobFailed, run_job
from tests.meshcore.domain import shapes
from tests.service.conftest import ROOT
from tests.service.inprocess import Gate, running_app
from tests.service.testing_methods import SQUARE

RECT = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]}
TINY_TRIANGLE = {"type": "Polygon", "coordinates": [[[0, 0], [1e-300, 0], [0, 1e-300], [0, 0]]]}
MEDIAL_METHODS = ("medial_axis", "simplify", "partition", "quad_medial")

# most cases here run a method's kernels in this process: they wait for numba's cache
# (tests/conftest.py) instead of compiling them beside the warm-up
pytestmark = pytest.mark.kernels


def run(coro):
    return asyncio.run(coro)


def job_files(data_dir: Path, job_id: str) -> list[Path]:
    folder = data_dir / "jobs" / job_id
    return sorted(folder.rglob("*")) + ([folder] if folder.exists() else [])


def failed_with(method: str, params: dict) -> dict:
    """The problem of running ``method`` as a job (which must fail)."""
    spec = default_registry()[method]
    with pytest.raises(JobFailed) as info:
        run_job(spec, json.dumps(params).encode(), lambda f, m: None)
    return info.value.problem


# -- races ------------------------------------------------------------------------------


def test_delete_waits_for_the_result_write_in_flight(tmp_path, monkeypatch):
    gate = Gate()
    write = service.store.write_atomically

    def held(path, data, sync):
        if path.name == "result.json":
            gate.hold()
        write(path, data, sync)

    monkeypatch.setattr(service.store, "write_atomically", held)

    async def scenario():
        async with running_app(tmp_path) as app:
            job = (await app.submit("quality", {"mesh": SQUARE})).json()
            await gate.wait_entered()
            deleting = asyncio.create_task(app.client.delete(f"/v1/jobs/{job['id']}"))
            await asyncio.sleep(0.3)
            assert not deleting.done(), "DELETE answered while the result was being written"
            gate.release()
            assert (await deleting).status_code == 204
            assert job_files(tmp_path, job["id"]) == []

    run(scenario())


@pytest.mark.parametrize("remove", ["delete", "expire"])
def test_removal_during_a_conversion_answers_404_or_410(tmp_path, monkeypatch, remove):
    gate = Gate()
    convert = service.downloads.io.to_bytes

    def held(mesh, fmt):
        gate.hold()
        return convert(mesh, fmt)

    monkeypatch.setattr(service.downloads.io, "to_bytes", held)

    async def scenario():
        async with running_app(tmp_path) as app:
            job = (await app.submit("echo_mesh", {"mesh": SQUARE}, params={"wait": 10})).json()
            assert job["status"] == "succeeded"
            url = f"/v1/jobs/{job['id']}"
            download = asyncio.create_task(app.client.get(f"{url}/result?format=ply"))
            await gate.wait_entered()
            if remove == "delete":
                assert (await app.client.delete(url)).status_code == 204
            else:
                app.store.expire(time.time() + 1, 1)  # result expired, row kept
            gate.release()
            assert (await download).status_code == (404 if remove == "delete" else 410)
            assert job_files(tmp_path, job["id"]) == []

    run(scenario())


def test_max_queued_holds_under_concurrent_submits(tmp_path):
    async def scenario():
        async with running_app(tmp_path, max_queued=2) as app:
            app.executor.gate.clear()  # nothing finishes
            answers = await asyncio.gather(
                *(app.submit("quality", {"mesh": SQUARE}) for _ in range(20))
            )
            codes = sorted(r.status_code for r in answers)
            assert codes == [202] * 2 + [429] * 18
            assert app.store.unfinished_count("anonymous") == 2
            app.executor.gate.set()

    run(scenario())


def test_long_polls_leave_no_event_behind(tmp_path):
    async def scenario():
        async with running_app(tmp_path, capacity=4) as app:
            jobs = []
            for _ in range(30):
                r = await app.submit("quality", {"mesh": SQUARE}, params={"wait": 10})
                jobs.append(r.json()["id"])
            polls = []
            for job_id in jobs:
                etag = (await app.client.get(f"/v1/jobs/{job_id}")).headers["etag"]
                polls.append(
                    app.client.get(
                        f"/v1/jobs/{job_id}",
                        params={"wait": 0.1},
                        headers={"If-None-Match": etag},
                    )
                )
            assert {r.status_code for r in await asyncio.gather(*polls)} == {304}
            app.store.expire(time.time() + 10, 1)  # every job removed
            assert app.manager.watched == 0
            # a poll still waiting when its job is deleted is woken, and leaves nothing
            job_id = (await app.submit("quality", {"mesh": SQUARE}, params={"wait": 10})).json()
            etag = (await app.client.get(f"/v1/jobs/{job_id['id']}")).headers["etag"]
            poll = asyncio.create_task(
                app.client.get(
                    f"/v1/jobs/{job_id['id']}", params={"wait": 20}, headers={"If-None-Match": etag}
                )
            )
            await asyncio.sleep(0.2)
            await app.client.delete(f"/v1/jobs/{job_id['id']}")
            assert (await asyncio.wait_for(poll, 5)).status_code == 404
            assert app.manager.watched == 0

    run(scenario())


def test_shutdown_as_runs_end_does_not_hang(tmp_path):
    """Found by these tests: close() cancelled the dispatcher while a stopped run woke it,
    Python 3.11's wait_for swallowed the cancel, and the dispatcher started the requeued
    job and ran on, so the shutdown never ended."""

    async def scenario():
        for i in range(3):
            async with running_app(tmp_path / str(i)) as app:
                await app.submit("quality", {"mesh": SQUARE})
                await app.submit("sleep", {"seconds": 0})

    run(asyncio.wait_for(scenario(), 60))


# -- inputs that answered 500 ---------------------------------------------------------------


@pytest.mark.parametrize("seq", ["9" * 30, str(2**63)])
def test_page_token_beyond_any_job_is_422(tmp_path, seq):
    token = base64.urlsafe_b64encode(f"seq:{seq}".encode()).decode().rstrip("=")

    async def scenario():
        async with running_app(tmp_path) as app:
            r = await app.client.get("/v1/jobs", params={"page_token": token})
            assert r.status_code == 422
            assert r.json()["errors"][0]["loc"] == ["query", "page_token"]
            assert (await app.client.get("/v1/jobs")).status_code == 200

    run(scenario())


def test_empty_idempotency_key_is_no_key(tmp_path):
    async def scenario():
        async with running_app(tmp_path) as app:
            empty = {"Idempotency-Key": ""}
            first = await app.submit("quality", {"mesh": SQUARE}, headers=empty)
            second = await app.submit("sleep", {"seconds": 0}, headers=empty)
            assert (first.status_code, second.status_code) == (202, 202)
            assert first.json()["id"] != second.json()["id"]
            assert "idempotent-replayed" not in second.headers

    run(scenario())


@pytest.mark.parametrize("size", [1e-300, 1e300])
def test_quad_medial_extreme_size_is_not_a_500(tmp_path, size):
    async def scenario():
        async with running_app(tmp_path) as app:
            example = default_registry()["quad_medial"].example
            r = await app.submit("quad_medial", {**example, "size": size}, params={"wait": 20})
            if size < 1:
                assert r.status_code == 422
                assert r.json()["errors"][0]["loc"] == ["body", "params", "size"]
            else:
                assert r.status_code == 200, r.text
                job = r.json()
                assert job["status"] == "succeeded" or job["error"]["status"] == 422, job

    run(scenario())


@pytest.mark.parametrize("h", [1e-300, 1e-6])  # 1e-6: 6e6 samples, 42 s and a 454 MB result
@pytest.mark.parametrize("method", MEDIAL_METHODS)
def test_medial_methods_with_a_tiny_h_fail_with_422(method, h):
    problem = failed_with(method, {"domain": RECT, "h": h})
    assert problem["status"] == 422, problem
    assert "h" in problem["detail"]


@pytest.mark.parametrize("method", MEDIAL_METHODS)
def test_medial_methods_on_a_1e300_small_triangle_fail_with_422(method):
    problem = failed_with(method, {"domain": TINY_TRIANGLE})
    assert problem["status"] == 422, problem
    assert problem["type"].endswith("out-of-range")


def test_radial_centre_beyond_float_range_is_422():
    params = {**default_registry()["radial"].example, "center": [1e300, 1e300]}
    problem = failed_with("radial", params)
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["params", "center"]


def test_radial_centre_too_far_for_its_spacing_is_422():
    params = {**default_registry()["radial"].example, "center": [1e12, 0]}
    assert failed_with("radial", params)["status"] == 422


def test_merge_of_points_beyond_float_range_is_refused_at_submit(tmp_path):
    huge = {
        "points": [[0, 0], [1e300, 0], [0, 1e300]],
        "cells": [{"type": "triangle", "data": [[0, 1, 2]]}],
    }

    async def scenario():
        async with running_app(tmp_path) as app:
            r = await app.submit("merge", {"meshes": [huge, SQUARE]})
            assert r.status_code == 422
            loc = r.json()["errors"][0]["loc"]
            assert loc == ["body", "params", "meshes", 0, "points", 1, 0]

    run(scenario())


def test_mesh_validation_refuses_a_3d_cell_on_2d_points(tmp_path):
    tetra = {
        "points": [[0, 0], [1, 0], [0, 1], [0.2, 0.2]],
        "cells": [{"type": "tetra", "data": [[0, 1, 2, 3]]}],
    }

    async def scenario():
        async with running_app(tmp_path) as app:
            r = await app.submit("merge", {"meshes": [tetra, SQUARE]})
            assert r.status_code == 422
            loc = r.json()["errors"][0]["loc"]
            assert loc == ["body", "params", "meshes", 0, "cells", 0, "type"]

    run(scenario())


# -- protocol ------------------------------------------------------------------------------


def test_weak_and_star_if_none_match_give_304(tmp_path):
    async def scenario():
        async with running_app(tmp_path) as app:
            job = await app.submit("quality", {"mesh": SQUARE}, params={"wait": 10})
            url, etag = f"/v1/jobs/{job.json()['id']}", job.headers["etag"]
            for header in (f"W/{etag}", "*", f'"nope", W/{etag}'):
                r = await app.client.get(url, headers={"If-None-Match": header})
                assert r.status_code == 304, header
            assert (await app.client.get(url, headers={"If-None-Match": '"x"'})).status_code == 200
            # a weak tag also serves the long-poll: it waits, then 304
            r = await app.client.get(url, params={"wait": 0.2}, headers={"If-None-Match": etag})
            assert r.status_code == 304

    run(scenario())


def test_replayed_unfinished_job_answers_as_openapi_says(tmp_path):
    spec = yaml.safe_load((ROOT / "openapi.yaml").read_text())
    documented = spec["paths"]["/v1/jobs"]["post"]["responses"]
    replay_codes = [int(c) for c, r in documented.items() if "replayed" in r["description"]]
    assert replay_codes == [200]

    async def scenario():
        async with running_app(tmp_path) as app:
            app.executor.gate.clear()
            key = {"Idempotency-Key": "k1"}
            first = await app.submit("quality", {"mesh": SQUARE}, headers=key)
            again = await app.submit("quality", {"mesh": SQUARE}, headers=key)
            assert first.status_code == 202
            assert again.json()["status"] in ("queued", "running")
            assert again.status_code in replay_codes
            assert again.headers["idempotent-replayed"] == "true"
            app.executor.gate.set()

    run(scenario())


def test_store_close_waits_for_a_result_write_in_flight(tmp_path, monkeypatch):
    """A job's result write goes on in its thread after the job is cancelled at
    shutdown; closing the store under it crashed the process (SQLite segfault)."""
    store = service.store.Store(tmp_path / "data")
    job_id = store.write_params(b"{}")
    entered, release = threading.Event(), threading.Event()
    write = service.store.write_atomically

    def held(path, data, sync):
        entered.set()
        release.wait(10)
        write(path, data, sync)

    monkeypatch.setattr(service.store, "write_atomically", held)
    writer = threading.Thread(target=store.write_result, args=(job_id, b"{}"))
    writer.start()
    assert entered.wait(10)
    closer = threading.Thread(target=store.close)
    closer.start()
    time.sleep(0.2)
    assert closer.is_alive()  # waits for the write in flight
    release.set()
    writer.join(10)
    closer.join(10)
    assert not closer.is_alive()
    assert store.write_result(job_id, b"{}") is False  # closed: nothing written


@pytest.mark.parametrize(
    "params",
    [
        {"domain": RECT, "size": 1e-300},
        {"domain": RECT, "size": 1e-300, "insert_points": False, "keep_boundary": False},
        {"surface": "box", "size": 1e-300},
    ],
    ids=["domain", "domain_split_only", "surface"],
)
def test_optimize_with_a_tiny_size_fails_with_422(params):
    """The size checks divide step by step (size ** 3 overflowed: a 500)."""
    if params.get("surface") == "box":
        P, T = shapes.box()
        params = {**params, "surface": {"points": P.tolist(), "triangles": T.tolist()}}
    problem = failed_with("optimize", params)  # the job, as a worker runs it
    assert problem["status"] == 422, problem
    assert "size" in problem["detail"]
    with pytest.raises(InputError) as info:  # the check made at submission
        default_registry()["optimize"].params.model_validate(params).check()
    assert info.value.errors[0]["loc"][0] == "size"


def test_optimize_with_a_huge_size_keeps_the_boundary_points():
    spec = default_registry()["optimize"]
    params = {"domain": RECT, "size": 1e300}  # size**2 overflowed: a 500
    spec.params.model_validate(params).check()
    assert run_job(spec, json.dumps(params).encode(), lambda f, m: None) is not None


# -- the probe sweep: each method's example mutated (sizes, coordinates, tiny features) ----

SPIKE = {  # the rectangle with a 1e-6 degree spike out of its bottom side
    "type": "Polygon",
    "coordinates": [
        [[0, 0], [0.99999999, 0], [1, -2], [1.00000001, 0], [2, 0], [2, 1], [0, 1], [0, 0]]
    ],
}
THIN = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1e-9], [0, 0]]]}


def refused_at_submit(method: str, params: dict) -> dict:
    """The error of ``method``'s submit checks (which must refuse ``params``)."""
    with pytest.raises(InputError) as info:
        default_registry()[method].params.model_validate(params).check()
    return info.value.errors[0]


def translated(params: dict, offset: float) -> dict:
    """``params`` with every position of its domain moved by ``offset``."""
    coords = params["domain"]["coordinates"]
    rings = [[[x + offset, y + offset] for x, y in ring] for ring in coords]
    return {**params, "domain": {"type": "Polygon", "coordinates": rings}}


@pytest.mark.parametrize("method", ["paving", "recursive_partition"])
@pytest.mark.parametrize("size", [1e300, 1e-300])
def test_sized_domain_extreme_size_is_checked_without_overflow(method, size):
    """size**2 overflowed (1e300) or underflowed to a division by zero (1e-300): 500s."""
    params = {**default_registry()[method].example, "size": size}
    if size < 1:
        error = refused_at_submit(method, params)
        assert (error["loc"], error["type"]) == (["size"], "too_many_cells")
    else:
        default_registry()[method].params.model_validate(params).check()


def test_recursive_partition_with_a_huge_size_runs():
    spec = default_registry()["recursive_partition"]
    params = {**spec.example, "size": 1e300}  # h**2 in the cell estimate overflowed
    assert run_job(spec, json.dumps(params).encode(), lambda f, m: None) is not None


@pytest.mark.parametrize("size", [1e300, 1e-300])
def test_recursive_partition_3d_extreme_size_is_checked_without_overflow(size):
    params = {"surface": shapes_surface(), "size": size}
    spec = default_registry()["recursive_partition"]
    if size < 1:
        error = refused_at_submit("recursive_partition", params)
        assert (error["loc"], error["type"]) == (["size"], "too_many_cells")
    else:
        spec.params.model_validate(params).check()


def shapes_surface() -> dict:
    P, T = shapes.box()
    return {"points": P.tolist(), "triangles": T.tolist()}


@pytest.mark.parametrize(
    "method, domain",
    [("recursive_partition", SPIKE), ("recursive_partition", THIN), ("paving", THIN)],
    ids=["recursive_partition-spike", "recursive_partition-thin", "paving-thin"],
)
def test_partition_stuck_on_a_tiny_feature_is_a_located_422(method, domain):
    """Even the triangle recursion finds no separator by a 1e-6 degree spike or in a 1e-9
    thin triangle; the job unpacked its None result (a TypeError, a 500)."""
    problem = failed_with(method, {"domain": domain, "size": 0.05})
    assert problem["status"] == 422, problem
    assert problem["errors"][0]["loc"] == ["params", "domain"]
    assert problem["type"].endswith("features-below-size")
    assert "sharpest corner" in problem["detail"]


@pytest.mark.parametrize(
    "pattern, loc",
    [
        ({"margin": 1e-300}, ["params", "margin"]),  # negative repeat counts: a 500
        ({"margin": 1e-6}, ["params", "margin"]),  # 2e8 boundary samples: minutes
        ({"pattern": {"type": "hexagon", "size": 1e-300}}, ["params", "pattern"]),
        (
            {"pattern": {"type": "parallelogram", "vectors": [[1, 0], [1, 1e-300]]}},
            ["params", "pattern"],
        ),
    ],
    ids=["margin_1e-300", "margin_1e-6", "hexagon_1e-300", "flat_parallelogram"],
)
def test_pattern_runaway_counts_are_a_located_422(pattern, loc):
    problem = failed_with("pattern", {**default_registry()["pattern"].example, **pattern})
    assert problem["status"] == 422, problem
    assert problem["errors"][0]["loc"] == loc


def test_quad_grid_merge_failure_names_no_params_it_does_not_have():
    """The band's internal merge located its error at params.meshes.1.cells..."""
    problem = failed_with("quad_grid", {"domain": SPIKE, "size": 0.05})
    assert problem["status"] == 422, problem
    assert problem["type"].endswith("merge-failed") and not problem.get("errors")


@pytest.mark.parametrize(
    "method",
    ["grid", "quad_grid", "paving", "recursive_partition", "quad_medial", "optimize"],
)
def test_size_below_the_coordinates_resolution_is_refused(method):
    """A grid at 1e15 with cells of 0.05 had coincident corners and a NaN quality (a 500)."""
    params = translated({**default_registry()[method].example, "domain": RECT}, 1e15)
    params["size"] = 0.05
    error = refused_at_submit(method, params)
    assert (error["loc"], error["type"]) == (["size"], "below_resolution")


@pytest.mark.parametrize("method", ["tetrahedralize", "optimize", "recursive_partition"])
def test_size_below_a_surface_coordinates_resolution_is_refused(method):
    """tetrahedralize at 1e15 with size 0.25: recovery did not finish (a 422 naming nothing)."""
    surface = shapes_surface()
    surface["points"] = [[c + 1e15 for c in p] for p in surface["points"]]
    error = refused_at_submit(method, {"surface": surface, "size": 0.25})
    assert (error["loc"], error["type"]) == (["size"], "below_resolution")


def test_size_at_a_1e6_offset_is_not_refused():
    params = translated(default_registry()["grid"].example, 1e6)
    default_registry()["grid"].params.model_validate(params).check()


@pytest.mark.parametrize("method", MEDIAL_METHODS)
def test_medial_methods_locate_a_geometry_error_under_domain(method):
    """meshcore's loc ["coordinates", ring, vertex] came out as params.coordinates."""
    params = translated({"domain": RECT}, 1e15)
    problem = failed_with(method, params)
    assert problem["status"] == 422, problem
    assert problem["errors"][0]["loc"][:3] == ["params", "domain", "coordinates"]


def test_medial_axis_point_cloud_beyond_float_range_is_refused():
    points = [[1e300 * x, 1e300 * y] for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
    error = refused_at_submit("medial_axis", {"points": points})  # an IndexError: a 500
    assert (error["loc"], error["type"]) == (["points", 1], "out_of_range")


def test_relax_quads_with_nodes_off_their_segment():
    """Sliding nodes projecting before their segment's start (rounding at 1e12 did it in
    quad_medial) made a lower bound above the upper one: scipy's ValueError, a 500."""
    from meshcore.quads.relaxation import relax_quads

    P = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [0, 1], [1, 1], [2, 1], [3, 1], [10, 0], [20, 0]])
    Q = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6]])
    fixed = np.ones(10, bool)
    fixed[[1, 2]] = False
    slide = (np.array([1, 2]), np.array([8, 8]), np.array([9, 9]))
    out = relax_quads(P.astype(float), Q, fixed, slide=slide)
    assert np.isfinite(out).all()
    assert out[1, 0] < out[2, 0] < 10  # order kept, neither moved onto the segment's end


# -- the sweep's leftovers: booleans as numbers, locations, warnings, thin strips ------------


def numeric_leaves(value, path=()):
    """Paths of the numbers (not booleans) in a JSON value."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from numeric_leaves(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from numeric_leaves(v, (*path, i))
    elif isinstance(value, int | float) and not isinstance(value, bool):
        yield path


def test_true_is_not_a_number_in_any_params():
    """pydantic's lax mode read true as 1 (and false as 0) in every numeric field."""
    from pydantic import ValidationError

    for name, spec in default_registry().items():
        for path in numeric_leaves(spec.example):
            params = json.loads(json.dumps(spec.example))
            target = params
            for key in path[:-1]:
                target = target[key]
            target[path[-1]] = True
            with pytest.raises(ValidationError) as info:
                spec.params.model_validate_json(json.dumps(params))
            loc = [k for k in info.value.errors()[0]["loc"] if k not in ("translate", "radial")]
            assert tuple(loc) == path, (name, path, loc)
    radial = default_registry()["radial"]  # an integer where a float goes, 8.0 for an int
    params = radial.params.model_validate_json(
        json.dumps({"outer_radius": 2, "radial_layers": 8.0, "segments": 32})
    )
    assert (params.outer_radius, params.radial_layers) == (2.0, 8)


@pytest.mark.parametrize("inner", [1e-300, 1e-12])
def test_radial_tiny_inner_radius_is_located_at_inner_radius(inner):
    params = {**default_registry()["radial"].example, "inner_radius": inner}
    problem = failed_with("radial", params)
    assert problem["status"] == 422
    assert problem["errors"][0]["loc"] == ["params", "inner_radius"]


def test_triangulate_with_a_1e300_size_warns_nothing():
    """The interior lattice's capsules squared 1e300 (an overflow, then a NaN cast)."""
    import warnings

    spec = default_registry()["triangulate"]
    meshes = []
    for size in (1e300, 10.0):  # both larger than the domain: the same mesh
        params = {"domain": RECT, "size": size}
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            spec.params.model_validate(params).check()
            files = run_job(spec, json.dumps(params).encode(), lambda f, m: None)
        meshes.append(json.loads(files["json"])["mesh"])
    assert meshes[0] == meshes[1]


def test_meshcore_medial_axis_point_cloud_beyond_float_range_is_an_input_error():
    """meshcore's own point-cloud domain had no range check (an IndexError at 1e300)."""
    from meshcore.medial.axis import medial_axis

    points = [[1e300 * x, 1e300 * y] for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
    with pytest.raises(InputError) as info:
        medial_axis(points=points)
    assert (info.value.errors[0]["loc"], info.value.code) == (["points", 1], "out_of_range")


def strip(width: float) -> dict:
    return {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, width], [0, width], [0, 0]]]}


def test_thin_strip_estimate_counts_the_triangles_the_angle_bound_forces():
    """Estimated by area only, a 1 x 1e-3 strip at size 0.1 was 0 triangles (it makes 1,216:
    edges about as long as the strip is wide); at 1e-6 triangulate made 1.25M in 12 s."""
    from meshcore.triangulation import estimated_triangles

    spec = default_registry()["triangulate"]
    params = {"domain": strip(1e-3), "size": 0.1}
    result = json.loads(run_job(spec, json.dumps(params).encode(), lambda f, m: None)["json"])
    made = result["stats"]["triangles"]
    domain = spec.params.model_validate(params).domain.to_domain()
    estimate = estimated_triangles(domain, size=0.1).triangles
    assert made / 2 <= estimate <= 2 * made, (made, estimate)


@pytest.mark.parametrize("method", ["triangulate", "quad_grid", "quad_combine", "pattern"])
def test_strip_too_thin_for_any_size_is_refused_up_front(method):
    """A 1 x 1e-8 strip needs about 2e8 triangles whatever the size (quad_grid on a 1e-9
    thin triangle ran 27 s into the refinement's point budget)."""
    example = default_registry()[method].example
    params = {**{k: v for k, v in example.items() if k != "curves"}, "domain": strip(1e-8)}
    error = refused_at_submit(method, params)
    assert (error["loc"], error["type"]) == (["domain"], "too_many_triangles")


def test_thin_strip_without_angle_bound_is_meshed():
    # triangulate's empty=true adds no interior point: the 1 x 1e-8 strip is two triangles
    spec = default_registry()["triangulate"]
    params = {"domain": strip(1e-8), "empty": True}
    spec.params.model_validate(params).check()  # the submit's checks
    result = json.loads(run_job(spec, json.dumps(params).encode(), lambda f, m: None)["json"])
    assert result["stats"]["triangles"] == 2
