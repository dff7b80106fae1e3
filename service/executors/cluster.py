"""The ``dask`` executor: jobs on a ``dask.distributed`` cluster.

Selected by ``MESHSERVICE_DASK_SCHEDULER=tcp://host:port``. The API node keeps
the store and the result files; workers never touch them. Each run of a job
is submitted under its own key (``pure=False`` and a random suffix: Dask
would otherwise merge identical submissions) and runs :func:`run_on_worker`,
which runs the same job function as the ``local`` executor in a killable
process of its own on the worker, because Dask cannot stop a running task.
That process is a new interpreter started by ``subprocess``
(:func:`service.executors.child.run_in_subprocess`), not by
``multiprocessing``: stock workers (``dask worker tcp://HOST:8786``, under
the nanny) are daemonic processes, which ``multiprocessing`` forbids to have
children. Limits, kill on cancel and time limit, and crash isolation are
those of the local executor.

- **Cancellation and time limits.** A ``distributed.Event`` per run
  (``meshservice-cancel-<job>-<attempt>``): the API sets it, the worker
  checks it four times a second, kills the child and clears it. The worker
  also stops the child by itself past the job's time limit, so a run
  outlives neither.
- **Progress.** The worker logs events on the topic
  ``meshservice-<job>-<attempt>``; the API subscribes to it for the run.
- **Worker deaths.** Dask reruns a task whose worker died (at most
  ``distributed.scheduler.allowed-failures`` times, then ``KilledWorker``);
  each start logs a ``started`` event, received by the scheduler before the
  job's process starts, and every start after the first counts as a new
  attempt of the job.
- **Restarts of the API.** Runs left over from before are told to stop
  (:meth:`DaskExecutor.forget`) before their jobs are queued again.
- **Spare runners.** A fresh interpreter's imports take 1-2 s; each worker
  keeps one job process started ahead, done with its imports and waiting
  for a job (:func:`service.executors.child.spawned_spares`). The API
  registers :class:`SpareRunners`, a worker plugin, so that every worker,
  stock ones included and those joining later, starts its spare at once.

"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import Callable

from distributed import Client, Event, get_client, get_worker
from distributed.client import FutureCancelledError
from distributed.diagnostics.plugin import WorkerPlugin
from distributed.scheduler import KilledWorker

from service.executors import Task
from service.executors.child import Stopped, run_in_subprocess, spawned_spares
from service.problems import problem_document
from service.runner import JobFailed

CANCEL_POLL = 0.25  # seconds between a worker's checks of the cancel event


def _topic(task: Task) -> str:
    return f"meshservice-{task.job_id}-{task.attempt}"


def _cancel_event(job_id: str, attempt: int) -> str:
    return f"meshservice-cancel-{job_id}-{attempt}"


def run_on_worker(task: Task, memory_limit: int) -> dict[str, bytes]:
    """The Dask task: run ``task`` in a killable child on this worker.

    Raises
    ------
    JobFailed
        the job failed or its process died.
    """
    worker = get_worker()
    topic = _topic(task)
    # through the scheduler before the job starts: a batched event (Worker.log_event) is
    # lost when the worker dies right after, and the rerun did not count as an attempt
    get_client().log_event(topic, {"kind": "started", "worker": worker.address})
    cancel = Event(_cancel_event(task.job_id, task.attempt))
    started = last_check = time.monotonic()

    def should_stop() -> bool:
        nonlocal last_check
        now = time.monotonic()
        if now - started > task.time_limit + 5:
            return True
        if now - last_check < CANCEL_POLL:
            return False
        last_check = now
        return cancel.is_set()

    def progress(fraction: float, message: str) -> None:
        worker.log_event(topic, {"kind": "progress", "fraction": fraction, "message": message})

    try:
        return run_in_subprocess(task, memory_limit, progress, should_stop, spares=spawned_spares())
    except Stopped:
        cancel.clear()  # acted upon: the scheduler may forget it
        raise JobFailed(
            problem_document(409, "stopped", "The run was stopped", "cancelled or out of time")
        ) from None


class SpareRunners(WorkerPlugin):
    """Worker plugin: start the worker's spare job process as soon as it has the plugin."""

    name = "meshservice-spare-runners"
    idempotent = True  # an API restart does not set the workers up again

    def setup(self, worker) -> None:
        spawned_spares().fill()


class DaskExecutor:
    """Jobs on the workers of a ``dask.distributed`` scheduler."""

    name = "dask"

    def __init__(self, address: str, memory_limit: int) -> None:
        self.address = address
        self.memory_limit = memory_limit
        self._client: Client | None = None

    async def start(self) -> None:
        self._client = await Client(
            self.address, asynchronous=True, name="meshservice-api", timeout=30
        )
        await self._client.register_plugin(SpareRunners())

    async def close(self) -> None:
        if self._client is not None:
            await self._client.close()
            self._client = None

    def _info(self) -> dict:
        """The scheduler's identity as the client last cached it (refreshed every 2 s)."""
        if self._client is None or self._client.status != "running":
            return {}
        return self._client.scheduler_info()

    @property
    def capacity(self) -> int:
        """Jobs to run at once: the cluster's worker threads (at least one)."""
        return max(1, self._info().get("total_threads", 0))

    def ready(self) -> bool:
        return self._info().get("n_workers", 0) > 0

    def describe(self) -> dict:
        workers = self._info().get("n_workers", 0)
        return {"executor": self.name, "scheduler": self.address, "workers": workers}

    async def forget(self, job_id: str, attempt: int) -> None:
        await Event(_cancel_event(job_id, attempt), client=self._client).set()

    async def run(
        self,
        task: Task,
        progress: Callable[[float, str], None],
        restarted: Callable[[], None],
    ) -> dict[str, bytes]:
        client = self._client
        topic = _topic(task)
        starts = 0

        def on_event(event: tuple) -> None:
            nonlocal starts
            message = event[1]
            if message["kind"] == "started":
                starts += 1
                if starts > 1:
                    restarted()
            else:
                progress(message["fraction"], message["message"])

        client.subscribe_topic(topic, on_event)
        key = f"meshservice-{task.job_id}-{task.attempt}-{uuid.uuid4().hex[:8]}"
        future = client.submit(run_on_worker, task, self.memory_limit, key=key, pure=False)
        cancel = Event(_cancel_event(task.job_id, task.attempt), client=client)
        try:
            return await future
        except asyncio.CancelledError:
            await cancel.set()
            await future.cancel()
            raise
        except FutureCancelledError:  # the scheduler dropped the run: stop its process too
            await cancel.set()
            raise
        except KilledWorker as exc:
            raise JobFailed(
                problem_document(
                    500,
                    "worker_died",
                    "The job's workers died",
                    f"every worker that ran the job died under it ({exc})",
                )
            ) from None
        finally:
            client.unsubscribe_topic(topic)
