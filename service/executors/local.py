"""The ``local`` executor: jobs in killable child processes on this machine.

Each job runs through :func:`service.executors.child.run_in_child` on a
thread of a pool sized to the executor's capacity, in a process of its own
(a small job's process, done within 0.1 s, takes the next job); cancelling
:meth:`LocalExecutor.run` (a user's cancel, the time limit, shutdown) tells
that thread to kill the child, which it does within one poll interval.

The fork server warms up (:mod:`service.executors.preload`: numba kernels,
up to a minute on an empty cache) in the background: the service answers at
once, ``/readyz`` says ``warming`` with the kernels left, and the executor's
capacity is zero until it is done, so jobs submitted meanwhile stay queued
and start when it is ready. Without the warm-up (``warmup`` false) the
executor is ready at once and the fork server starts meanwhile: its imports
(about 1.4 CPU s) delay only a job that arrives before they are done.

The warm-up's progress file lives in a folder of its own in
``DATA_DIR/warmup/``, which is removed once the fork server is warm or the
service stops. A service killed meanwhile (SIGKILL, the out-of-memory killer) cannot
remove it: the next start on the same data directory removes every folder
there, and a fork server the killed service left warming stops before its
next step (:mod:`service.executors.preload`).
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import shutil
import tempfile
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from service.executors import WARMUP_ENV, WARMUP_STATUS_ENV, Task
from service.executors.child import context, forked_spares, run_in_child, warm_up

log = logging.getLogger("meshservice.executor")


class LocalExecutor:
    """Jobs in killable child processes on this machine, ``workers`` at a time."""

    name = "local"

    def __init__(self, workers: int, memory_limit: int, data_dir: Path, warm: bool = True) -> None:
        self.workers = workers
        self.memory_limit = memory_limit
        self.warm = warm
        self._ctx = context()
        self._spares = forked_spares(self._ctx, workers)
        self._threads = ThreadPoolExecutor(workers, thread_name_prefix="job")
        self._stops: set[threading.Event] = set()
        self._started = False
        self._warming: asyncio.Task | None = None
        self._status_root = Path(data_dir) / "warmup"
        self._status_dir: Path | None = None  # the warm-up's progress file, while warming

    @property
    def capacity(self) -> int:
        """Jobs run at once: none until the fork server is warm."""
        return self.workers if self._started else 0

    async def start(self) -> None:
        """Start warming the fork server (without the warm-up: ready now); returns at once.

        Removes the status folders a killed service left under ``DATA_DIR/warmup/``."""
        shutil.rmtree(self._status_root, ignore_errors=True)
        os.environ[WARMUP_ENV] = "1" if self.warm else "0"  # inherited by the fork server
        if self.warm:
            self._status_root.mkdir(parents=True, exist_ok=True)  # rmtree may leave it
            self._status_dir = Path(tempfile.mkdtemp(dir=self._status_root))
            os.environ[WARMUP_STATUS_ENV] = str(self._status_dir / "status.json")
        self._started = not self.warm
        self._warming = asyncio.create_task(self._warm(), name="warm-up")

    async def _warm(self) -> None:
        try:
            await asyncio.to_thread(warm_up, self._ctx)
        except Exception:  # jobs then fail one by one with their own reason
            log.exception("the fork server failed to warm up")
        self._forget_status()
        self._spares.fill()
        self._started = True
        log.info("executor ready: %d workers", self.workers)

    async def close(self) -> None:
        if self._warming is not None and not self._warming.done():
            self._warming.cancel()
        self._forget_status()  # a fork server still warming up stops (preload.warm)
        self._started = False
        for stop in list(self._stops):
            stop.set()
        await asyncio.to_thread(self._threads.shutdown, wait=True)
        await asyncio.to_thread(self._spares.close)

    def _forget_status(self) -> None:
        if self._status_dir is not None:
            shutil.rmtree(self._status_root, ignore_errors=True)
            self._status_dir = None

    def ready(self) -> bool:
        return self._started

    def warming(self) -> dict | None:
        """While warming: ``{"done", "total", "current", "left"}`` (None once ready)."""
        if self._started:
            return None
        try:
            if self._status_dir is not None:
                return json.loads((self._status_dir / "status.json").read_text())
        except (OSError, ValueError):
            pass
        return {
            "done": 0,
            "total": None,
            "current": "starting the job fork server (imports)",
            "left": [],
        }

    def describe(self) -> dict:
        return {"executor": self.name, "workers": self.workers}

    async def forget(self, job_id: str, attempt: int) -> None:
        """Nothing to do: a job's process dies with the service that started it."""

    async def run(
        self,
        task: Task,
        progress: Callable[[float, str], None],
        restarted: Callable[[], None],
    ) -> dict[str, bytes]:
        loop = asyncio.get_running_loop()
        stop = threading.Event()
        self._stops.add(stop)

        def report(fraction: float, message: str) -> None:
            loop.call_soon_threadsafe(progress, fraction, message)

        done = loop.run_in_executor(
            self._threads,
            run_in_child,
            self._ctx,
            task,
            self.memory_limit,
            report,
            stop.is_set,
            0.1,
            self._spares,
        )
        try:
            return await asyncio.shield(done)
        except asyncio.CancelledError:
            stop.set()
            await asyncio.wait([done])  # the child is killed within one poll interval
            done.exception()  # retrieved: Stopped, or the outcome that raced the stop
            raise
        finally:
            self._stops.discard(stop)
