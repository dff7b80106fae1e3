"""The ``local`` executor: one killable child process per job on this machine.

Each job runs in a fresh process forked from a ``forkserver`` that has
already imported meshcore, so a job starts in milliseconds with a clean
interpreter and dies alone: a segfault, ``os._exit`` or the out-of-memory
killer fails that job with the reason, and the next job gets a new process
(``ProcessPoolExecutor`` instead breaks every job once one child dies).
The child gets an address-space limit and a CPU-time limit, and dies with
the service (``PR_SET_PDEATHSIG``). Progress and the result come back over
a pipe; cancelling :meth:`LocalExecutor.run` kills the child.
"""

from __future__ import annotations

import asyncio
import ctypes
import logging
import multiprocessing
import multiprocessing.forkserver
import os
import resource
import signal
import threading
import time
from collections.abc import Callable
from multiprocessing.connection import Connection

from service.executors import Task
from service.problems import problem_document
from service.runner import JobFailed, run_job

log = logging.getLogger("meshservice.local")

PROGRESS_INTERVAL = 0.1  # seconds between progress messages a job sends
_PRELOAD = ["service.executors.local", "service.executors.preload", "service.methods"]


try:
    _LIBC = ctypes.CDLL(None, use_errno=True)
except OSError:
    _LIBC = None


def _die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent (the fork server) exits."""
    if _LIBC is not None:
        _LIBC.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def _child(task: Task, conn: Connection, memory_limit: int) -> None:
    """Body of a job's process: limits, run, send the outcome, exit."""
    _die_with_parent()
    resource.setrlimit(resource.RLIMIT_AS, (memory_limit, memory_limit))
    cpu = int(task.time_limit) + 5
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    last = 0.0

    def progress(fraction: float, message: str) -> None:
        nonlocal last
        now = time.monotonic()
        if now - last >= PROGRESS_INTERVAL:
            last = now
            conn.send(("progress", min(max(float(fraction), 0.0), 1.0), str(message)[:200]))

    try:
        conn.send(("ok", run_job(task.spec, task.params, progress)))
    except JobFailed as exc:
        conn.send(("error", exc.problem))
    conn.close()
    os._exit(0)  # the answer is sent: skip interpreter teardown


def _death_problem(exitcode: int | None) -> dict:
    """The problem document of a job process that died without an answer."""
    if exitcode is not None and exitcode < 0:
        sig = signal.Signals(-exitcode)
        reasons = {
            signal.SIGKILL: "it was killed (SIGKILL), most likely by the out-of-memory killer",
            signal.SIGSEGV: "it crashed (SIGSEGV, a segmentation fault)",
            signal.SIGXCPU: "it exceeded its CPU-time limit (SIGXCPU)",
            signal.SIGABRT: "it aborted (SIGABRT)",
        }
        reason = reasons.get(sig, f"it was stopped by signal {sig.name}")
    else:
        reason = f"it exited with status {exitcode} before answering"
    return problem_document(
        500, "worker_died", "The job's process died", f"the job's process died: {reason}"
    )


class LocalExecutor:
    """Jobs in killable child processes on this machine, ``capacity`` at a time."""

    name = "local"

    def __init__(self, workers: int, memory_limit: int) -> None:
        self.capacity = workers
        self.memory_limit = memory_limit
        self._ctx = multiprocessing.get_context("forkserver")
        self._ctx.set_forkserver_preload(_PRELOAD)
        self._children: set[multiprocessing.process.BaseProcess] = set()
        self._started = False

    async def start(self) -> None:
        await asyncio.to_thread(multiprocessing.forkserver.ensure_running)
        self._started = True

    async def close(self) -> None:
        self._started = False
        for proc in list(self._children):
            proc.kill()
        for proc in list(self._children):
            proc.join(5)
        self._children.clear()

    def ready(self) -> bool:
        return self._started

    async def run(self, task: Task, progress: Callable[[float, str], None]) -> bytes:
        loop = asyncio.get_running_loop()
        outcome: asyncio.Future = loop.create_future()
        receiver, sender = self._ctx.Pipe(duplex=False)
        proc = self._ctx.Process(
            target=_child, args=(task, sender, self.memory_limit), name=f"job-{task.job_id}"
        )
        proc.daemon = True
        await asyncio.to_thread(proc.start)
        self._children.add(proc)
        sender.close()

        def settle(value: tuple) -> None:
            if not outcome.done():
                outcome.set_result(value)

        def read() -> None:
            # Sequential by nature: one blocking reader per job's pipe.
            try:
                while True:
                    message = receiver.recv()
                    if message[0] == "progress":
                        loop.call_soon_threadsafe(progress, message[1], message[2])
                    else:
                        loop.call_soon_threadsafe(settle, message)
                        return
            except (EOFError, OSError):
                loop.call_soon_threadsafe(settle, ("died", None))
            finally:
                receiver.close()

        threading.Thread(target=read, name=f"pipe-{task.job_id}", daemon=True).start()
        try:
            kind, payload = await outcome
            if kind == "ok":
                return payload
            if kind == "error":
                raise JobFailed(payload)
            await asyncio.to_thread(proc.join, 5)
            log.warning("job %s: process died with exit code %s", task.job_id, proc.exitcode)
            raise JobFailed(_death_problem(proc.exitcode))
        finally:
            if proc.is_alive():
                proc.kill()
            proc.join(5)
            self._children.discard(proc)
