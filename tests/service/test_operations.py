"""Restart, authentication, health, methods, CORS and start-up checks, on live servers."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import httpx
import pytest

from service.methods.registry import default_registry
from tests.service.conftest import ROOT, LiveServer, wait_status
from tests.service.test_jobs import assert_problem, submit, wait_file
from tests.service.testing_methods import SQUARE


class TestRestart:
    @pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
    def test_nothing_is_lost(self, start_server, tmp_path, sig):
        """Stop the server with a finished, a running and a queued job; start it again."""
        server = start_server(MESHSERVICE_WORKERS="1")
        marker = tmp_path / "started"
        with server.client() as c:
            done = submit(c, "quality", {"mesh": SQUARE}, wait=10).json()
            running = submit(c, "sleep", {"seconds": 1.5, "marker": str(marker)}).json()
            wait_file(marker)
            queued = submit(c, "sleep", {"seconds": 0}).json()
            assert c.get(f"/v1/jobs/{queued['id']}").json()["status"] == "queued"
        server.stop(sig)
        # what a server killed while its fork server warmed up leaves (it was in /tmp,
        # where the tests' SIGKILLs had piled up hundreds): the next start removes it
        stale = server.data_dir / "warmup" / "tmpkilled"
        stale.mkdir(parents=True)
        (stale / "status.json").write_text("{}")

        again = start_server(data_dir=server.data_dir, MESHSERVICE_WORKERS="1")
        assert not stale.parent.exists()
        with again.client() as c:
            assert (
                c.get(f"/v1/jobs/{done['id']}/result").json()["quality"]["triangle"]["count"] == 2
            )
            for job in (running, queued):
                assert wait_status(c, job["id"], {"succeeded", "failed"})["status"] == "succeeded"
            assert c.get(f"/v1/jobs/{running['id']}").json()["attempt"] == 2
            assert c.get(f"/v1/jobs/{queued['id']}").json()["attempt"] == 1
            assert len(marker.read_text().split()) == 2  # ran again from the start

    def test_job_interrupted_too_often_fails_with_the_reason(self, start_server, tmp_path):
        server = start_server(MESHSERVICE_MAX_ATTEMPTS="1")
        marker = tmp_path / "started"
        with server.client() as c:
            job = submit(c, "sleep", {"seconds": 30, "marker": str(marker)}).json()
            wait_file(marker)
        server.stop(signal.SIGKILL)
        again = start_server(data_dir=server.data_dir, MESHSERVICE_MAX_ATTEMPTS="1")
        with again.client() as c:
            job = c.get(f"/v1/jobs/{job['id']}").json()
            assert job["status"] == "failed"
            assert job["error"]["type"] == "/problems/interrupted"


@pytest.fixture(scope="module")
def keyed(tmp_path_factory):
    """A server with two clients' API keys."""
    server = LiveServer(
        tmp_path_factory.mktemp("auth") / "data", MESHSERVICE_API_KEYS="alice-key:alice,bob-key:bob"
    ).start()
    yield server
    server.stop()


class TestAuth:
    @pytest.fixture
    def server(self, keyed):
        return keyed

    def test_missing_key_is_401_with_www_authenticate(self, server):
        with server.client() as c:
            r = c.get("/v1/jobs")
            assert_problem(r, 401)
            assert r.headers["www-authenticate"].startswith("Bearer")

    def test_wrong_key_is_401(self, server):
        with server.client(headers={"Authorization": "Bearer nope"}) as c:
            assert_problem(c.get("/v1/jobs"), 401)
            assert_problem(submit(c, "quality", {"mesh": SQUARE}), 401)

    def test_another_clients_job_is_404_and_not_listed(self, server):
        with (
            server.client(headers={"Authorization": "Bearer alice-key"}) as alice,
            server.client(headers={"Authorization": "Bearer bob-key"}) as bob,
        ):
            job = submit(alice, "quality", {"mesh": SQUARE}, wait=10).json()
            assert alice.get(f"/v1/jobs/{job['id']}").status_code == 200
            for path in ("", "/result", "/events", "/preview.svg"):
                assert_problem(bob.get(f"/v1/jobs/{job['id']}{path}"), 404)
            assert_problem(bob.post(f"/v1/jobs/{job['id']}/cancel"), 404)
            assert_problem(bob.delete(f"/v1/jobs/{job['id']}"), 404)
            assert bob.get("/v1/jobs").json()["jobs"] == []
            assert [j["id"] for j in alice.get("/v1/jobs").json()["jobs"]] == [job["id"]]

    def test_health_needs_no_key(self, server):
        with server.client() as c:
            assert c.get("/healthz").status_code == 200


class TestStartup:
    def test_refuses_public_bind_without_keys(self, tmp_path):
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "service",
                "serve",
                "--host",
                "0.0.0.0",
                "--data-dir",
                str(tmp_path),
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert r.returncode == 2
        assert "refusing to listen on 0.0.0.0 without API keys" in r.stderr


class TestHealth:
    def test_healthz_readyz(self, client):
        assert client.get("/healthz").json() == {"status": "ok"}
        ready = client.get("/readyz")
        assert ready.status_code == 200 and ready.json()["executor"] == "local"

    def test_metrics(self, client):
        submit(client, "quality", {"mesh": SQUARE}, wait=10)
        text = client.get("/metrics").text
        assert 'meshservice_jobs{status="succeeded"}' in text
        assert "meshservice_queue_depth" in text
        assert 'meshservice_job_duration_seconds_count{method="quality",status="succeeded"}' in text

    def test_unknown_path_and_method_are_problems(self, client):
        assert_problem(client.get("/v2/nothing"), 404)
        assert_problem(client.put("/v1/jobs"), 405)


class TestMethods:
    def test_list_has_schema_section_and_example(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        quality = methods["quality"]
        assert quality["params_schema"]["properties"]["mesh"]
        assert quality["section"] and quality["summary"]
        assert_problem(client.get("/v1/methods/nope"), 404)
        assert client.get("/v1/methods/quality").json() == quality

    def test_every_product_example_is_valid_input(self, client):
        product = default_registry()
        examples = [m for m in client.get("/v1/methods").json() if m["name"] in product]
        jobs = [submit(client, m["name"], m["example"]).json()["id"] for m in examples]
        for method, job_id in zip(examples, jobs, strict=True):
            job = wait_status(client, job_id, {"succeeded", "failed"}, timeout=180)
            assert job["status"] == "succeeded", (method["name"], job)


class TestCors:
    def test_exposes_headers_to_allowed_origin(self, start_server):
        server = start_server(MESHSERVICE_CORS_ORIGINS="https://app.example")
        with server.client(headers={"Origin": "https://app.example"}) as c:
            r = submit(c, "quality", {"mesh": SQUARE})
            assert r.status_code == 202, r.text  # once seen without the header: say why
            assert r.headers["access-control-allow-origin"] == "https://app.example"
            exposed = r.headers["access-control-expose-headers"].lower()
            assert {"location", "retry-after", "etag"} <= set(map(str.strip, exposed.split(",")))


def test_sigterm_stops_promptly(start_server):
    server = start_server()
    t0 = time.monotonic()
    # uvicorn shuts down gracefully, then re-raises the signal it caught
    assert server.stop(signal.SIGTERM) in (0, -signal.SIGTERM)
    assert time.monotonic() - t0 < 15


class TestFirstStart:
    @pytest.mark.kernels  # the fork server warms every kernel up
    def test_port_answers_while_warming_and_queued_jobs_run_when_ready(self, tmp_path):
        """The port opens before the fork server is warm; a job submitted then waits and runs."""
        server = LiveServer(tmp_path / "data", MESHSERVICE_WORKERS="1", MESHSERVICE_WARMUP="1")
        server.spawn()
        try:
            warming, job = [], None
            deadline = time.monotonic() + 120
            with httpx.Client(base_url=server.url, timeout=2) as probe:
                while time.monotonic() < deadline:
                    try:
                        r = probe.get("/readyz")
                    except httpx.HTTPError:
                        time.sleep(0.05)
                        continue
                    if job is None:
                        job = probe.post(
                            "/v1/jobs",
                            json={"method": "quality", "params": {"mesh": SQUARE}},
                            timeout=5,
                        ).json()
                    if r.status_code == 200:
                        break
                    assert r.status_code == 503
                    warming.append(r.json()["warming"])
                    time.sleep(0.05)
            assert warming, "the port answered only once everything was warm"
            assert set(warming[-1]) == {"done", "total", "current", "left"}
            assert job["status"] in ("queued", "running", "succeeded")
            with server.client() as c:
                assert wait_status(c, job["id"], {"succeeded", "failed"})["status"] == "succeeded"
            assert "compiling kernels 1/" in server.log.read_text()
        finally:
            server.stop()

    def test_a_warm_up_no_one_waits_for_stops_quietly(self, tmp_path):
        """A service stopping while its fork server warms up (a second ``serve`` on a taken
        port) removes the status folder; the warm-up then stops before its next step. It
        wrote into the removed folder and died with a FileNotFoundError traceback."""
        env = {"MESHSERVICE_WARMUP": "1", "MESHSERVICE_WARMUP_STATUS": str(tmp_path / "gone/s")}
        done = subprocess.run(
            [sys.executable, "-c", "import service.executors.preload"],
            cwd=ROOT,
            env={**os.environ, **env},
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        assert done.stderr == "INFO:     warm-up abandoned: the service stopped\n"
