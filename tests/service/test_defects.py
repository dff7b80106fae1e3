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


@pytest.mark.kernels
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


@pytest.mark.parametrize("method", MEDIAL_METHODS)
def test_medial_methods_with_a_tiny_h_fail_with_422(method):
    problem = failed_with(method, {"domain": RECT, "h": 1e-300})
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
