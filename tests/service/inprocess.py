"""The app in this process, on an executor the test drives, for races a live server cannot
time: the job function runs on the event loop's thread pool and may be held at a gate.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path

import httpx

import service.app
from service.app import create_app
from service.executors import Task
from service.runner import run_job
from service.settings import Settings
from tests.service.testing_methods import testing_registry


class GatedExecutor:
    """Runs jobs in this process; each run first waits for ``gate`` (open by default)."""

    name = "gated"

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.gate = asyncio.Event()
        self.gate.set()
        self.started = asyncio.Event()  # a run has begun (set on every start)

    async def start(self) -> None:
        pass

    async def close(self) -> None:
        pass

    def ready(self) -> bool:
        return True

    def describe(self) -> dict:
        return {"executor": self.name, "workers": self.capacity}

    async def forget(self, job_id: str, attempt: int) -> None:
        pass

    async def run(self, task: Task, progress: Callable, restarted: Callable) -> bytes:
        self.started.set()
        await self.gate.wait()
        return await asyncio.to_thread(
            run_job, task.spec, task.params, lambda f, m: None, (), task.arrays
        )


class App:
    """The running app: an httpx client on it, its manager, store and executor."""

    def __init__(self, app, client: httpx.AsyncClient, executor: GatedExecutor) -> None:
        self.app = app
        self.client = client
        self.executor = executor

    @property
    def manager(self):
        return self.app.state.manager

    @property
    def store(self):
        return self.manager.store

    async def submit(self, method: str, job_params: dict, **kwargs) -> httpx.Response:
        body = {"method": method, "params": job_params}
        return await self.client.post("/v1/jobs", json=body, **kwargs)


@asynccontextmanager
async def running_app(data_dir: Path, capacity: int = 1, **settings) -> AsyncIterator[App]:
    """The test app (product and testing methods) with its lifespan, on a GatedExecutor."""
    executor = GatedExecutor(capacity)
    original = service.app.LocalExecutor
    service.app.LocalExecutor = lambda *_: executor
    try:
        app = create_app(Settings(data_dir=data_dir, **settings), testing_registry())
        async with app.router.lifespan_context(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://app") as client:
                yield App(app, client, executor)
    finally:
        service.app.LocalExecutor = original


class Gate:
    """A threading gate for patched blocking functions: ``entered`` once called, then
    held until ``release()``."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self._open = threading.Event()

    def hold(self) -> None:
        self.entered.set()
        assert self._open.wait(30), "the gate was never released"

    def release(self) -> None:
        self._open.set()

    async def wait_entered(self, timeout: float = 30) -> None:
        assert await asyncio.to_thread(self.entered.wait, timeout), "nothing reached the gate"
