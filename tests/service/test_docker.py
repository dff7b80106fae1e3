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

from tests.service.conftest import ROOT, _free_port
from tests.service.testing_methods import SQUARE

DOCKER = ROOT / "docker"


def test_dockerfile_passes_hadolint():
    hadolint = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    run = subprocess.run([hadolint, str(DOCKER / "Dockerfile")], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def _env_file() -> dict[str, str]:
    lines = (DOCKER / "meshservice.env.example").read_text().splitlines()
    return dict(line.split("=", 1) for line in lines if line and not line.startswith("#"))


def _local(args: list[str], ports: dict[str, str]) -> list[str]:
    """A compose command with the service names and public binds mapped to loopback."""
    out = []
    for arg in args:
        arg = arg.replace("0.0.0.0", "127.0.0.1")
        for old, new in ports.items():
            arg = arg.replace(old, new)
        out.append(arg)
    return out


def test_compose_commands_serve_a_job(tmp_path):
    compose = yaml.safe_load((DOCKER / "compose.yaml").read_text())["services"]
    scheduler_port, api_port = str(_free_port()), str(_free_port())
    ports = {
        "scheduler:8786": f"127.0.0.1:{scheduler_port}",
        "8786": scheduler_port,
        "8000": api_port,
    }
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = []

    def start(service: str, extra_env: dict) -> None:
        spec = compose[service]
        program = spec.get("entrypoint", ["meshservice"])[0]
        args = [str(bin_dir / program), *_local(spec["command"], ports)]
        environment = {
            k: _local([str(v)], ports)[0] for k, v in spec.get("environment", {}).items()
        }
        log = open(tmp_path / f"{service}.log", "wb")
        procs.append(
            subprocess.Popen(
                args,
                cwd=ROOT,
                env={**env, **extra_env, **environment},
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        )

    try:
        start("scheduler", {})
        start("worker", {})
        start("api", {**_env_file(), "MESHSERVICE_DATA_DIR": str(tmp_path / "data")})
        key = _env_file()["MESHSERVICE_API_KEYS"].split(",")[0].split(":")[0]
        url = f"http://127.0.0.1:{api_port}"
        deadline = time.monotonic() + 90
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
