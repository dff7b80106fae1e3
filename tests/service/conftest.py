"""Live-server fixtures: the test app under a real uvicorn on a loopback port."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest

from tests.conftest import kernels_ready

ROOT = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listens(pid: int, port: int) -> bool:
    """Whether process ``pid`` has a TCP socket listening on ``port``."""
    try:
        sockets = psutil.Process(pid).net_connections("tcp")
    except psutil.Error:  # it has exited
        return False
    return any(c.status == psutil.CONN_LISTEN and c.laddr.port == port for c in sockets)


def spawn_listening(
    command: Callable[[int], list[str]],
    log: Path,
    deadline: float,
    port: int | None = None,
    **popen: Any,
) -> tuple[subprocess.Popen, int]:
    """Start ``command(port)`` with its output appended to ``log``; return the process and
    the port once that process itself listens on the port.

    ``_free_port`` lets the port go before the process binds it, and another process
    may take it meanwhile (a server of another xdist worker or of another run on the
    machine). A server then exited unable to bind while the other one answered on its
    URL, and the test talked to that server until its own test stopped it. So nothing is
    asked of the port before this process listens on it, and a process whose port is
    taken (it exits saying "address already in use", as uvicorn and ``dask scheduler``
    do) starts again on another. A process that exits otherwise, or does not listen by
    ``deadline`` (``time.monotonic()``; then killed), raises RuntimeError.
    """
    if port is None:
        port = _free_port()
    while True:
        written = log.stat().st_size if log.exists() else 0
        with open(log, "ab") as out:
            proc = subprocess.Popen(command(port), stdout=out, stderr=subprocess.STDOUT, **popen)
        while not _listens(proc.pid, port):
            if proc.poll() is not None:
                with open(log, "rb") as f:  # what this process wrote
                    f.seek(written)
                    said = f.read().decode(errors="replace")
                if "address already in use" not in said.lower():
                    raise RuntimeError(f"exited: {said[-2000:]}")
                break
            if time.monotonic() > deadline:
                proc.kill()  # never leave a process behind
                proc.wait()
                raise RuntimeError(f"never listened on {port}: {log.read_text()[-2000:]}")
            time.sleep(0.05)
        else:
            return proc, port
        port = _free_port()


class LiveServer:
    """``python -m tests.service.server`` in a subprocess, with its own data dir."""

    def __init__(self, data_dir: Path, **env: str) -> None:
        self.data_dir = data_dir
        self.env = {k: str(v) for k, v in env.items()}
        self.port = _free_port()
        self.proc: subprocess.Popen | None = None
        self.log = data_dir.parent / f"server-{data_dir.name}.log"
        self.module = "tests.service.server"  # "service": the product alone

    def start(self) -> LiveServer:
        """Start the server; return once it answers ``/readyz`` on its port."""
        deadline = time.monotonic() + 120
        self.spawn(deadline)
        # one client for the whole poll: each httpx.get builds an SSL context (~30 ms of
        # CPU), ten times a second for every server a test starts
        with httpx.Client(timeout=1) as probe:
            while time.monotonic() < deadline:
                if self.proc.poll() is not None:
                    raise RuntimeError(f"server exited: {self.log.read_text()[-2000:]}")
                try:
                    if probe.get(self.url + "/readyz").status_code == 200:
                        return self
                except httpx.HTTPError:
                    pass
                time.sleep(0.1)
        self.stop(signal.SIGKILL)  # never leave a server behind that no test will stop
        raise RuntimeError(f"server did not start: {self.log.read_text()[-2000:]}")

    def spawn(self, deadline: float | None = None) -> subprocess.Popen:
        """Start the process; return it once it listens on ``self.port`` itself
        (``spawn_listening``: a port taken meanwhile moves the server to another)."""
        if deadline is None:
            deadline = time.monotonic() + 120
        # no warm-up unless asked: each job loads the kernels it uses from numba's cache
        # (filled by ``tests/conftest.py``); the warm-up itself is tested in TestFirstStart
        env = {**os.environ, "MESHSERVICE_WORKERS": "2", "MESHSERVICE_WARMUP": "0", **self.env}
        serve = ["serve"] if self.module == "service" else []
        self.proc, self.port = spawn_listening(
            lambda port: [
                sys.executable,
                "-m",
                self.module,
                *serve,
                "--port",
                str(port),
                "--data-dir",
                str(self.data_dir),
            ],
            self.log,
            deadline,
            port=self.port,
            cwd=ROOT,
            env=env,
        )
        return self.proc

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def stop(self, sig: int = signal.SIGTERM) -> int:
        assert self.proc is not None
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        return self.proc.wait(30)

    def client(self, **kwargs) -> httpx.Client:
        return httpx.Client(base_url=self.url, timeout=60, **kwargs)


@pytest.fixture(scope="session")
def live(tmp_path_factory) -> Iterator[LiveServer]:
    """One shared server: 2 workers, default limits, warmed up (it runs every method).

    It starts once numba's cache is filled (``tests/conftest.py``), or its warm-up
    would compile every kernel again.
    """
    kernels_ready()
    server = LiveServer(tmp_path_factory.mktemp("shared") / "data", MESHSERVICE_WARMUP="1")
    server.start()
    yield server
    server.stop()


@pytest.fixture
def client(live) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture
def start_server(tmp_path) -> Iterator:
    """Start servers with their own settings; all stopped at the end of the test."""
    servers: list[LiveServer] = []

    def start(data_dir: Path | None = None, **env: str) -> LiveServer:
        server = LiveServer(data_dir or tmp_path / f"data{len(servers)}", **env).start()
        servers.append(server)
        return server

    yield start
    for server in servers:
        if server.proc and server.proc.poll() is None:
            server.stop(signal.SIGKILL)


def wait_status(c: httpx.Client, job_id: str, statuses: set[str], timeout: float = 30) -> dict:
    """Poll until the job's status is one of ``statuses``."""
    deadline = time.monotonic() + timeout
    while True:
        job = c.get(f"/v1/jobs/{job_id}").json()
        if job["status"] in statuses or time.monotonic() > deadline:
            return job
        time.sleep(0.05)
