"""The ``local`` executor: one killable child process per job on this machine.

Each job runs through :func:`service.executors.child.run_in_child` on a
thread of a pool sized to the executor's capacity; cancelling
:meth:`LocalExecutor.run` (a user's cancel, the time limit, shutdown) tells
that thread to kill the child, which it does within one poll interval.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from service.executors import Task
from service.executors.child import context, run_in_child, warm_up


class LocalExecutor:
    """Jobs in killable child processes on this machine, ``capacity`` at a time."""

    name = "local"

    def __init__(self, workers: int, memory_limit: int) -> None:
        self.capacity = workers
        self.memory_limit = memory_limit
        self._ctx = context()
        self._threads = ThreadPoolExecutor(workers, thread_name_prefix="job")
        self._stops: set[threading.Event] = set()
        self._started = False

    async def start(self) -> None:
        await asyncio.to_thread(warm_up, self._ctx)
        self._started = True

    async def close(self) -> None:
        self._started = False
        for stop in list(self._stops):
            stop.set()
        await asyncio.to_thread(self._threads.shutdown, wait=True)

    def ready(self) -> bool:
        return self._started

    def describe(self) -> dict:
        return {"executor": self.name, "workers": self.capacity}

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
