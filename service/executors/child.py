"""A job in its own killable process: the piece every executor shares.

:func:`run_in_child` runs :func:`service.runner.run_job` in a fresh process
forked from a ``forkserver`` that has already imported meshcore and loaded
its compiled kernels, so a job starts in milliseconds with a clean
interpreter and dies alone: a segfault, ``os._exit`` or the out-of-memory
killer fails that job with the reason, and the next job gets a new process
(``ProcessPoolExecutor`` instead breaks every job once one child dies). The
child gets an address-space limit and a CPU-time limit and dies with its
parent (``PR_SET_PDEATHSIG``). Progress and the result come back over a
pipe. The call blocks; it kills the child as soon as ``should_stop()``
turns true (cancellation, time limit, shutdown) and raises :class:`Stopped`.

:func:`run_in_subprocess` does the same with a process started by
``subprocess`` (:mod:`service.executors.spawned`), for daemonic hosts such
as a stock Dask worker, where ``multiprocessing`` may not start children.
"""

from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import pickle
import resource
import select
import signal
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path

from service.executors import Task
from service.problems import problem_document
from service.runner import JobFailed, run_job

log = logging.getLogger("meshservice.child")

PROGRESS_INTERVAL = 0.1  # seconds between progress messages a job sends
# fastapi and uvicorn too: a forked child re-imports the server's main module (multiprocessing's
# main-module fixup), which imports them; preloaded, that costs the job nothing
PRELOAD = [
    "fastapi",
    "uvicorn",
    "service.executors.child",
    "service.methods.registry",
    "service.executors.preload",
]

try:
    _LIBC = ctypes.CDLL(None, use_errno=True)
except OSError:
    _LIBC = None


class Stopped(Exception):
    """The job's process was killed because ``should_stop()`` turned true."""


def context() -> multiprocessing.context.BaseContext:
    """The fork-server context, with meshcore and its kernels preloaded."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx


def _noop() -> None:
    """A child that does nothing: starting one waits for the fork server to be warm."""


def warm_up(ctx: multiprocessing.context.BaseContext) -> None:
    """Start the fork server and wait until it has preloaded everything (blocking)."""
    proc = ctx.Process(target=_noop, daemon=True)
    proc.start()
    proc.join()


def _die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent (the fork server) exits."""
    if _LIBC is not None:
        _LIBC.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def job_body(task: Task, memory_limit: int, send: Callable[[tuple], None]) -> None:
    """Body of a job's process (forked or spawned): limits, run, send the outcome, exit."""
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
            send(("progress", min(max(float(fraction), 0.0), 1.0), str(message)[:200]))

    try:
        send(("ok", run_job(task.spec, task.params, progress, task.formats)))
    except JobFailed as exc:
        send(("error", exc.problem))
    os._exit(0)  # the answer is sent: skip interpreter teardown


def _child(task: Task, conn: Connection, memory_limit: int) -> None:
    job_body(task, memory_limit, conn.send)


def death_problem(exitcode: int | None) -> dict:
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


def run_in_child(
    ctx: multiprocessing.context.BaseContext,
    task: Task,
    memory_limit: int,
    progress: Callable[[float, str], None],
    should_stop: Callable[[], bool],
    poll: float = 0.1,
) -> dict[str, bytes]:
    """Run ``task`` in a new child process and return its result files.

    Blocks until the child answers or dies; checks ``should_stop`` every
    ``poll`` seconds while waiting.

    Raises
    ------
    JobFailed
        the job failed (its problem document), or its process died.
    Stopped
        ``should_stop()`` turned true; the child has been killed.
    """
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(task, sender, memory_limit), name=f"job-{task.job_id}")
    proc.daemon = True
    proc.start()
    sender.close()
    try:
        # Sequential by nature: one blocking reader per job's pipe.
        while True:
            if not receiver.poll(poll):
                if should_stop():
                    raise Stopped(task.job_id)
                continue
            try:
                kind, *payload = receiver.recv()
            except EOFError:
                break
            if kind == "progress":
                progress(*payload)
            elif kind == "ok":
                return payload[0]
            else:
                raise JobFailed(payload[0])
        proc.join(5)
        log.warning("job %s: process died with exit code %s", task.job_id, proc.exitcode)
        raise JobFailed(death_problem(proc.exitcode))
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(5)
        receiver.close()


def _frames(proc: subprocess.Popen, poll: float, should_stop: Callable[[], bool], job_id: str):
    """The messages of a spawned job's stdout, checking ``should_stop`` every ``poll`` s."""
    fd = proc.stdout.fileno()
    buffer = bytearray()
    while True:
        ready, _, _ = select.select([fd], [], [], poll)
        if not ready:
            if should_stop():
                raise Stopped(job_id)
            continue
        chunk = os.read(fd, 1 << 20)
        if not chunk:
            return
        buffer += chunk
        while len(buffer) >= 8:
            (size,) = struct.unpack_from("<Q", buffer)
            if len(buffer) < 8 + size:
                break
            yield pickle.loads(bytes(buffer[8 : 8 + size]))
            del buffer[: 8 + size]


def run_in_subprocess(
    task: Task,
    memory_limit: int,
    progress: Callable[[float, str], None],
    should_stop: Callable[[], bool],
    poll: float = 0.1,
) -> dict[str, bytes]:
    """:func:`run_in_child`, but the job's process is a new interpreter started by ``subprocess``.

    For hosts where ``multiprocessing`` may not start children (daemonic
    processes such as a stock Dask worker). The job pays the interpreter's
    start and its imports (about a second, kernels from numba's disk cache);
    limits, death with the parent and kill on ``should_stop`` are the same.

    Raises
    ------
    JobFailed
        the job failed (its problem document), or its process died.
    Stopped
        ``should_stop()`` turned true; the process has been killed.
    """
    import service

    root = str(Path(service.__file__).resolve().parents[1])  # the same code as this process
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, "PYTHONPATH": root + (os.pathsep + path if path else "")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "service.executors.spawned"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
    )
    try:
        proc.stdin.write(pickle.dumps((task, memory_limit), protocol=pickle.HIGHEST_PROTOCOL))
        proc.stdin.close()
    except BrokenPipeError:
        pass  # it died at once: its exit code says why, below
    try:
        for kind, *payload in _frames(proc, poll, should_stop, task.job_id):
            if kind == "progress":
                progress(*payload)
            elif kind == "ok":
                return payload[0]
            else:
                raise JobFailed(payload[0])
        code = proc.wait(5)
        log.warning("job %s: process died with exit code %s", task.job_id, code)
        raise JobFailed(death_problem(code))
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(5)
        proc.stdout.close()
