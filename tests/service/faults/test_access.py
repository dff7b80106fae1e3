"""With API keys set, every /v1 route needs one; /metrics needs its own token."""

from __future__ import annotations

import pytest

from tests.service.test_jobs import assert_problem

KEYS = {"MESHSERVICE_API_KEYS": "k1:alice", "MESHSERVICE_METRICS_TOKEN": "m1"}
JOB = "0" * 32
V1_ROUTES = [
    ("GET", "/v1/methods"),
    ("GET", "/v1/methods/quality"),
    ("POST", "/v1/jobs"),
    ("GET", "/v1/jobs"),
    ("GET", f"/v1/jobs/{JOB}"),
    ("GET", f"/v1/jobs/{JOB}/events"),
    ("POST", f"/v1/jobs/{JOB}/cancel"),
    ("DELETE", f"/v1/jobs/{JOB}"),
    ("GET", f"/v1/jobs/{JOB}/result"),
    ("GET", f"/v1/jobs/{JOB}/preview.svg"),
    ("GET", f"/v1/jobs/{JOB}/preview.png"),
    ("POST", "/v1/convert"),
]


@pytest.fixture(scope="module")
def keyed(tmp_path_factory):
    from tests.service.conftest import LiveServer

    server = LiveServer(tmp_path_factory.mktemp("keyed") / "data", **KEYS).start()
    yield server
    server.stop()


def test_the_route_list_is_every_v1_route(keyed):
    with keyed.client() as c:
        spec = c.get("/openapi.json").json()
    listed = {(m, p.replace(JOB, "{job_id}").replace("quality", "{name}")) for m, p in V1_ROUTES}
    routes = {
        (method.upper(), path)
        for path, ops in spec["paths"].items()
        if path.startswith("/v1/")
        for method in ops
    }
    assert routes <= listed, routes - listed


@pytest.mark.parametrize(("method", "path"), V1_ROUTES)
def test_every_v1_route_needs_a_key(keyed, method, path):
    with keyed.client() as c:
        assert_problem(c.request(method, path), 401)
        wrong = c.request(method, path, headers={"Authorization": "Bearer nope"})
        assert_problem(wrong, 401)


def test_methods_answer_with_a_key(keyed):
    with keyed.client(headers={"Authorization": "Bearer k1"}) as c:
        assert c.get("/v1/methods").status_code == 200
        assert c.get("/v1/methods/quality").json()["name"] == "quality"


def test_metrics_need_the_metrics_token(keyed):
    with keyed.client() as c:
        assert c.get("/metrics").status_code == 401
        assert c.get("/metrics", headers={"Authorization": "Bearer k1"}).status_code == 401
        ok = c.get("/metrics", headers={"Authorization": "Bearer m1"})
        assert ok.status_code == 200 and "meshservice_jobs" in ok.text


def test_health_stays_open(keyed):
    with keyed.client() as c:
        assert c.get("/healthz").status_code == 200
        assert c.get("/readyz").status_code == 200


def test_keys_without_a_metrics_token_close_the_metrics(start_server):
    server = start_server(MESHSERVICE_API_KEYS="k1:alice")
    with server.client() as c:
        doc = assert_problem(c.get("/metrics", headers={"Authorization": "Bearer k1"}), 401)
        assert "MESHSERVICE_METRICS_TOKEN" in doc["detail"]


def test_without_keys_the_metrics_are_open(client):
    assert client.get("/metrics").status_code == 200
