"""The job manager: queue, dispatch, cancellation, waiting, expiry.

Jobs are committed to the store before they reach the executor. A dispatcher
task starts the oldest queued jobs while the executor has room; each run is
an asyncio task around :meth:`Executor.run` with the job's time limit, so
cancelling the task (a user's cancel, the time limit, shutdown) stops the
job's process. Every change of a job wakes whoever waits on it (``?wait=``
long-polls and event streams) through a per-job event.

On start-up, jobs the store still shows as running were interrupted: they go
back to the queue unless they have used ``max_attempts`` runs. On shutdown,
running jobs are stopped and re-queued, so a restart loses nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable

from service.executors import Executor, Task
from service.methods.registry import Registry
from service.metrics import Metrics
from service.problems import problem_document
from service.runner import JobFailed
from service.settings import Settings
from service.store import Job, Store

log = logging.getLogger("meshservice.jobs")


class JobManager:
    """Runs the store's queued jobs on an executor."""

    def __init__(
        self,
        store: Store,
        executor: Executor,
        registry: Registry,
        settings: Settings,
        metrics: Metrics,
    ) -> None:
        self.store = store
        self.executor = executor
        self.registry = registry
        self.settings = settings
        self.metrics = metrics
        self._running: dict[str, asyncio.Task] = {}
        self._changed: dict[str, asyncio.Event] = {}
        self._wakeup = asyncio.Event()
        self._background: list[asyncio.Task] = []
        self._closing = False

    async def start(self) -> None:
        await self.executor.start()
        interrupted = self.store.running()
        for job in interrupted:
            await self.executor.forget(job.id, job.attempt)
        requeued, failed = self.store.recover(interrupted, self.settings.max_attempts)
        if requeued or failed:
            log.info("recovered interrupted jobs: %d requeued, %d failed", requeued, failed)
        self._background = [
            asyncio.create_task(self._dispatch(), name="dispatcher"),
            asyncio.create_task(self._expire(), name="expiry"),
        ]

    async def close(self) -> None:
        """Stop dispatching; stop running jobs and put them back in the queue."""
        self._closing = True
        for task in self._background:
            task.cancel()
        running = list(self._running.values())
        for task in running:
            task.cancel()
        await asyncio.gather(*self._background, *running, return_exceptions=True)
        await self.executor.close()

    # -- notifications ------------------------------------------------------------

    def _notify(self, job_id: str) -> None:
        event = self._changed.pop(job_id, None)
        if event is not None:
            event.set()

    def wake(self) -> None:
        """Tell the dispatcher that the queue changed."""
        self._wakeup.set()

    async def wait(self, job_id: str, until: Callable[[Job], bool], timeout: float) -> Job | None:
        """The job once ``until(job)`` holds or ``timeout`` seconds pass (None: deleted)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            job = self.store.get(job_id)
            remaining = deadline - loop.time()
            if job is None or until(job) or remaining <= 0:
                return job
            event = self._changed.setdefault(job_id, asyncio.Event())
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(event.wait(), remaining)

    # -- control ----------------------------------------------------------------------

    def cancel(self, job_id: str) -> None:
        """Cancel a queued or running job (no effect once it has ended)."""
        if self.store.cancel(job_id):
            task = self._running.get(job_id)
            if task is not None:
                task.cancel()
            self._notify(job_id)

    async def delete(self, job_id: str) -> None:
        """Cancel the job if needed, wait for its process to stop, remove it and its files."""
        self.cancel(job_id)
        task = self._running.get(job_id)
        if task is not None:
            await asyncio.gather(task, return_exceptions=True)
        self.store.delete(job_id)
        self._notify(job_id)

    # -- background tasks -----------------------------------------------------------

    async def _dispatch(self) -> None:
        while True:
            self._wakeup.clear()
            free = self.executor.capacity - len(self._running)
            if free > 0:
                for job in self.store.queued(free, exclude=set(self._running)):
                    if self.store.mark_running(job.id):
                        self._running[job.id] = asyncio.create_task(
                            self._execute(job.id, job.method, job.attempt + 1),
                            name=f"job-{job.id}",
                        )
                        self._notify(job.id)
            # the executor's capacity may change (workers join a cluster): look again soon
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wakeup.wait(), 1.0)

    async def _expire(self) -> None:
        interval = min(60.0, self.settings.retention / 4)
        while True:
            expired, removed = self.store.expire(time.time(), self.settings.retention)
            if expired or removed:
                log.info("expiry: %d results expired, %d jobs removed", expired, removed)
            await asyncio.sleep(interval)

    def _progress(self, job_id: str) -> Callable[[float, str], None]:
        def report(fraction: float, message: str) -> None:
            if self.store.set_progress(job_id, fraction, message):
                self._notify(job_id)

        return report

    def _restarted(self, job_id: str) -> Callable[[], None]:
        def count() -> None:
            if self.store.bump_attempt(job_id):
                self._notify(job_id)

        return count

    async def _execute(self, job_id: str, method: str, attempt: int) -> None:
        started = time.monotonic()
        status = "failed"
        try:
            spec = self.registry.get(method)
            if spec is None:
                raise JobFailed(
                    problem_document(
                        422, "unknown_method", "Unknown method", f"no method {method!r} here"
                    )
                )
            params = self.store.read_params(job_id)
            task = Task(
                job_id, attempt, spec, params, self.settings.job_time_limit, self.settings.formats
            )
            result = await asyncio.wait_for(
                self.executor.run(task, self._progress(job_id), self._restarted(job_id)),
                self.settings.job_time_limit,
            )
            await asyncio.to_thread(self.store.write_results, job_id, result)
            status = "succeeded"
            self.store.finish(job_id, status)
        except JobFailed as exc:
            self.store.finish(job_id, "failed", exc.problem)
        except TimeoutError:
            limit = self.settings.job_time_limit
            self.store.finish(
                job_id,
                "failed",
                problem_document(
                    504,
                    "time_limit",
                    "Time limit exceeded",
                    f"the job ran longer than the time limit of {limit:g} s and was stopped",
                ),
            )
        except asyncio.CancelledError:
            status = "cancelled"
            if self._closing:
                self.store.requeue(job_id)
        except Exception:
            log.exception("job %s: unexpected error in the service", job_id)
            self.store.finish(
                job_id,
                "failed",
                problem_document(500, "internal_error", "Internal error", "it has been logged"),
            )
        finally:
            self.metrics.job_duration.labels(method, status).observe(time.monotonic() - started)
            self._running.pop(job_id, None)
            self._notify(job_id)
            self.wake()
