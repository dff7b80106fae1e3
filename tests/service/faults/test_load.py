"""Many concurrent clients holding event streams: every one completes, no reset.

CI runs 100 clients; ``MESHSERVICE_LOAD_CLIENTS=1000`` gives the long run.
The round is ``benchmarks/load.py``'s (one job each: a quarter
``triangulate``, the rest ``quality``; event stream to the end; result).
Times are reported by the benchmark, never asserted here.
"""

from __future__ import annotations

import asyncio
import importlib.util
import os

import httpx
import pytest

from tests.service.conftest import ROOT

pytestmark = pytest.mark.kernels  # a warmed-up server running triangulate

CLIENTS = int(os.environ.get("MESHSERVICE_LOAD_CLIENTS", "100"))


def _load_module():
    spec = importlib.util.spec_from_file_location("load_benchmark", ROOT / "benchmarks/load.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_many_streaming_clients_all_complete(start_server):
    load = _load_module()
    server = start_server(
        MESHSERVICE_MAX_QUEUED=str(10 * CLIENTS),
        MESHSERVICE_MAX_STREAMS=str(10 * CLIENTS),
        MESHSERVICE_WARMUP="1",  # as deployed: a hundred jobs share the loaded kernels
    )
    probe = httpx.post(
        server.url + "/v1/jobs", json=load.QUALITY, params={"wait": 20}, timeout=30
    ).json()["id"]
    with load.Prober(server.url, probe) as prober:
        row = asyncio.run(load.load_round(server.url, CLIENTS, prober))
    assert row["errors"] == 0, row
    assert row["done"] == CLIENTS
