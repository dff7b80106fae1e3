"""The container set-up, short of building images (no Docker engine on these machines).

The Dockerfile passes hadolint, and the exact commands of docker/compose.yaml
(the API, ``dask scheduler``, ``dask worker``) run as separate processes on
loopback and serve a job with an API key from the example env file.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import httpx
import yaml

from tests.service.conftest import ROOT, spawn_listening
from tests.service.testing_methods import SQUARE

DOCKER = ROOT / "docker"
BIN = Path(sys.executable).parent


def test_dockerfile_passes_hadolint():
    hadolint = shutil.which("hadolint") or str(BIN / "hadolint")
    run = subprocess.run([hadolint, str(DOCKER / "Dockerfile")], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def _env_file() -> dict[str, str]:
    lines = (DOCKER / "meshservice.env.example").read_text().splitlines()
    return dict(line.split("=", 1) for line in lines if line and not line.startswith("#"))


def _command(spec: dict, ports: dict[str, str]) -> list[str]:
    """A compose service's command with the service names and public binds mapped to
    loopback and the ports in ``ports`` to the ones given."""
    out = [str(BIN / spec.get("entrypoint", ["meshservice"])[0])]
    for arg in spec["command"]:
        arg = arg.replace("0.0.0.0", "127.0.0.1")
        for old, new in ports.items():
            arg = arg.replace(old, new)
        out.append(arg)
    return out


def test_compose_commands_serve_a_job(tmp_path):
    services = yaml.safe_load((DOCKER / "compose.yaml").read_text())["services"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    deadline = time.monotonic() + 90
    procs = []
    try:
        # the scheduler and the API each on a free port that they listen on themselves
        scheduler, scheduler_port = spawn_listening(
            lambda port: _command(services["scheduler"], {"8786": str(port)}),
            tmp_path / "scheduler.log",
            deadline,
            cwd=ROOT,
            env=env,
        )
        procs.append(scheduler)
        to_scheduler = {"scheduler:8786": f"127.0.0.1:{scheduler_port}"}
        with open(tmp_path / "worker.log", "ab") as log:
            worker = _command(services["worker"], to_scheduler)
            procs.append(
                subprocess.Popen(worker, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
            )
        api, api_port = spawn_listening(
            lambda port: _command(services["api"], {"8000": str(port)}),
            tmp_path / "api.log",
            deadline,
            cwd=ROOT,
            env={
                **env,
                **_env_file(),
                "MESHSERVICE_DATA_DIR": str(tmp_path / "data"),
                **{
                    k: str(v).replace("scheduler:8786", to_scheduler["scheduler:8786"])
                    for k, v in services["api"].get("environment", {}).items()
                },
            },
        )
        procs.append(api)
        url = f"http://127.0.0.1:{api_port}"
        key = _env_file()["MESHSERVICE_API_KEYS"].split(",")[0].split(":")[0]
        with httpx.Client() as probe:
            while True:
                try:
                    ready = probe.get(url + "/readyz")
                    if ready.status_code == 200 and ready.json()["workers"] == 1:
                        break
                except httpx.HTTPError:
                    pass
                assert time.monotonic() < deadline, (tmp_path / "api.log").read_text()[-2000:]
                time.sleep(0.2)
        assert ready.json()["executor"] == "dask"
        r = httpx.post(
            url + "/v1/jobs",
            params={"wait": 30},
            headers={"Authorization": f"Bearer {key}"},
            json={"method": "quality", "params": {"mesh": SQUARE}},
            timeout=60,
        )
        assert r.status_code == 200 and r.json()["status"] == "succeeded", r.text
        assert httpx.get(url + "/v1/jobs").status_code == 401
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
