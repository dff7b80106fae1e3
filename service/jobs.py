"""The job manager: queue, dispatch, cancellation, waiting, expiry.

Jobs are committed to the store before they reach the executor. A dispatcher
task starts the oldest queued jobs while the executor has room; each run is
an asyncio task around :meth:`Executor.run` with the job's time limit, so
cancelling the task (a user's cancel, the time limit, shutdown) stops the
job's process. Every change of a job wakes whoever waits on it (``?wait=``
long-polls and event streams) through a per-job watch: the row is read once
per change and handed to every waiter of that job, so a thousand open
streams cost one SQLite read per change, not one per stream; the watch goes
when its last waiter leaves.

On start-up, jobs the store still shows as running were interrupted: they go
back to the queue unless they have used ``max_attempts`` runs. On shutdown,
running jobs are stopped and re-queued, so a restart loses nothing.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import time
from collections.abc import Callable, Iterator

from service.executors import Executor, Task
from service.methods.registry import Registry
from service.metrics import Metrics
from service.problems import TooManyStreams, problem_document
from service.runner import JobFailed
from service.settings import Settings
from service.store import DiskFull, Job, Store

#: Submits admitted at once (:meth:`JobManager.admission`): enough to keep the threads
#: that parse, check and store busy.
SUBMITS_AT_ONCE = 4

log = logging.getLogger("meshservice.jobs")


class _Watch:
    """The waiters of one job: an event set on each change, and the row read then."""

    __slots__ = ("event", "job", "waiters")

    def __init__(self) -> None:
        self.event = asyncio.Event()
        self.job: Job | None = None
        self.waiters = 0


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
        self._watches: dict[str, _Watch] = {}
        self._streams: dict[str, int] = {}
        self._wakeup = asyncio.Event()
        self._background: list[asyncio.Task] = []
        self._closing = False
        #: Submits between reading their body and storing their job, at most this many at
        #: once; the others wait without a step on the event loop (see :meth:`admission`).
        self._admission = asyncio.Semaphore(SUBMITS_AT_ONCE)

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
        watch = self._watches.get(job_id)
        if watch is not None:
            watch.job = self.store.get(job_id)  # one read, shared by every waiter
            event, watch.event = watch.event, asyncio.Event()
            event.set()

    def wake(self) -> None:
        """Tell the dispatcher that the queue changed."""
        self._wakeup.set()

    async def wait(self, job_id: str, until: Callable[[Job], bool], timeout: float) -> Job | None:
        """The job once ``until(job)`` holds or ``timeout`` seconds pass (None: deleted)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        job = self.store.get(job_id)
        if job is None or until(job) or timeout <= 0:
            return job
        watch = self._watches.setdefault(job_id, _Watch())
        watch.waiters += 1
        try:
            while True:
                remaining = deadline - loop.time()
                if remaining <= 0:
                    return job
                try:
                    await asyncio.wait_for(watch.event.wait(), remaining)
                except TimeoutError:
                    return job
                job = watch.job
                if job is None or until(job):
                    return job
        finally:
            watch.waiters -= 1
            if watch.waiters == 0 and self._watches.get(job_id) is watch:
                del self._watches[job_id]

    def check_stream(self, client: str) -> None:
        """Raise a 429 when ``client`` already holds ``max_streams`` streams and long-polls."""
        if self._streams.get(client, 0) >= self.settings.max_streams:
            raise TooManyStreams(
                f"you hold {self.settings.max_streams} open event streams and long-polls "
                "(MESHSERVICE_MAX_STREAMS); close some first",
                headers={"Retry-After": "5"},
            )

    def admission(self) -> asyncio.Semaphore:
        """Held by a submit from reading its body to storing its job.

        A thousand submits arriving at once would otherwise each add a step
        to the event loop's queue at every hop to a thread (parse, checks,
        files), and a status read would wait behind all of them at each of
        its own steps; with a few admitted at a time it waits behind those.
        """
        return self._admission

    @contextlib.contextmanager
    def stream(self, client: str) -> Iterator[None]:
        """Count one open stream or long-poll of ``client`` while the block runs (429 beyond)."""
        self.check_stream(client)
        self._streams[client] = self._streams.get(client, 0) + 1
        try:
            yield
        finally:
            left = self._streams[client] - 1
            if left:
                self._streams[client] = left
            else:
                del self._streams[client]

    @property
    def watched(self) -> int:
        """Jobs with at least one waiter (every watch goes with its last waiter)."""
        return len(self._watches)

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
        self.store.delete_row(job_id)
        self._notify(job_id)
        # a result write the cancel abandoned (or a conversion) may still run in its thread
        await asyncio.to_thread(self.store.remove_files, job_id)

    # -- background tasks -----------------------------------------------------------

    async def _dispatch(self) -> None:
        # not ``while True``: Python 3.11's wait_for below may swallow close()'s cancel
        # when the wakeup fires at the same moment (a run ending as it is stopped)
        while not self._closing:
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
            for job_id in (*expired, *removed):
                self._notify(job_id)
            if expired or removed:
                log.info("expiry: %d results expired, %d jobs removed", len(expired), len(removed))
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

    def _lost(self, job_id: str, exc: BaseException) -> None:
        """Requeue (or fail, out of attempts) a running job whose run was cancelled by
        neither a user nor the shutdown, e.g. a Dask future the scheduler cancelled."""
        job = self.store.get(job_id)
        if job is None or job.status != "running":
            return
        reason = str(exc) or type(exc).__name__
        log.warning("job %s: its run was cancelled by the executor (%s)", job_id, reason)
        if job.attempt < self.settings.max_attempts:
            self.store.requeue(job_id)
        else:
            self.store.finish(
                job_id,
                "failed",
                problem_document(
                    503,
                    "run_cancelled",
                    "The job's runs were cancelled",
                    f"the executor cancelled each of its {job.attempt} runs (last: {reason})",
                ),
            )

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
            arrays = b""
            if self.store.arrays_path(job_id).exists():  # tens of MB: off the event loop
                arrays = await asyncio.to_thread(self.store.read_arrays, job_id)
            task = Task(
                job_id,
                attempt,
                spec,
                params,
                self.settings.job_time_limit,
                self.settings.formats,
                arrays,
            )
            result = await asyncio.wait_for(
                self.executor.run(task, self._progress(job_id), self._restarted(job_id)),
                self.settings.job_time_limit,
            )
            try:
                await asyncio.to_thread(self.store.write_results, job_id, result)
            except DiskFull as exc:
                raise JobFailed(
                    problem_document(
                        507,
                        "disk_full",
                        "Not enough space to store the result",
                        f"the result did not fit in the data directory: {exc}; "
                        "no partial result was kept; free space and submit the job again",
                    )
                ) from None
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
        except (asyncio.CancelledError, concurrent.futures.CancelledError) as exc:
            status = "cancelled"
            if self._closing:
                self.store.requeue(job_id)
            else:  # not a user's cancel (the row would say so): the executor dropped the run
                self._lost(job_id, exc)
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
