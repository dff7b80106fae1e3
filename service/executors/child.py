"""A job in its own killable process: the piece every executor shares.

:func:`run_in_child` runs :func:`service.runner.run_job` in a fresh process
forked from a ``forkserver`` that has already imported meshcore and loaded
its compiled kernels, so a job starts in milliseconds with a clean
interpreter and dies alone: a segfault, ``os._exit`` or the out-of-memory
killer fails that job with the reason, and the next job gets a new process
(``ProcessPoolExecutor`` instead breaks every job once one child dies). The
child gets an address-space limit and a CPU-time limit and dies with its
parent (``PR_SET_PDEATHSIG``). It runs at the API's CPU priority for its first
:data:`NICE_AFTER` seconds, so that a small job answers at once on a busy
machine, then at a lower one (:data:`JOB_NICE`): with every core busy with
jobs, status reads and event streams still answer at once. Progress and the result come back over a
pipe. The call blocks; it kills the child as soon as ``should_stop()``
turns true (cancellation, time limit, shutdown) and raises :class:`Stopped`.

:func:`run_in_subprocess` does the same with a process started by
``subprocess`` (:mod:`service.executors.spawned`), for daemonic hosts such
as a stock Dask worker, where ``multiprocessing`` may not start children.

Both keep spare processes (:class:`Spares`): a job's process is started
before its job arrives and waits for it on a pipe, so a job does not wait
for a fork (about 10 ms from the fork server) or for a fresh interpreter's
imports (1-2 s). A forked process whose job succeeded within
:data:`NICE_AFTER` (a small job: the process is still at the API's
priority) goes back among the spares and waits for the next job, up to
:data:`JOBS_PER_PROCESS` jobs: a small job then costs neither a fork nor an
exit (together about 13 ms of CPU for the fork server's 280 MB, twice a
small job's own cost, on the cores the next jobs need). Any other job's
process (failed, killed, past :data:`NICE_AFTER`, a spawned one) is used
once; a new spare is started in the background when a job's process will
not come back (at :data:`NICE_AFTER`, at its end, or at the start of its
last job).
"""

from __future__ import annotations

import atexit
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
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from service.executors import Task
from service.methods.registry import METHOD_CODE
from service.problems import problem_document
from service.runner import JobFailed, run_job

log = logging.getLogger("meshservice.child")

#: Seconds between progress messages a job sends, the first one this long after it starts:
#: a small job sends none, only its answer (each message wakes the API and writes the row).
PROGRESS_INTERVAL = 0.1
#: Niceness added to a job's process: the API (and a Dask worker's own threads) run first.
JOB_NICE = 10
#: Seconds a job runs at the API's priority before :data:`JOB_NICE` is added to it: on a
#: machine busy with other work, a small job at +10 waited behind it for most of its round
#: trip (its few ms of CPU took 20 ms). A forked process whose job succeeded sooner takes
#: the next job (its niceness cannot be lowered again once raised).
NICE_AFTER = 0.1
#: Jobs a forked job process runs at most (see :data:`NICE_AFTER`): memory its jobs left
#: fragmented is given back at its end.
JOBS_PER_PROCESS = 100
# The server's main module's imports too: a forked child re-runs that module (multiprocessing's
# main-module fixup). ``service.cli`` (``meshservice`` and ``python -m service``) imports the
# batch client's httpx: each job's process imported it again, about 70 ms of CPU, two thirds
# of a small job's CPU, in the spare that the next job takes. Preloaded, that costs nothing.
# The methods' meshcore code (METHOD_CODE), which the API process does not import, too.
PRELOAD = [
    "fastapi",
    "uvicorn",
    "service.cli",
    "service.executors.child",
    "service.methods.registry",
    *METHOD_CODE,
    "service.executors.preload",
]

#: Set (unless the operator set them) in the environment job processes start from: one
#: BLAS thread per job, since jobs already run one per core. A multithreaded OpenBLAS made
#: scipy's L-BFGS-B (the quad relaxations) up to 100x slower on two busy cores.
JOB_THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

try:
    _LIBC = ctypes.CDLL(None, use_errno=True)
except OSError:
    _LIBC = None


class Stopped(Exception):
    """The job's process was killed because ``should_stop()`` turned true."""


def _job_environment() -> None:
    """:data:`JOB_THREADS` into this process's environment, which the fork server and
    the spawned job interpreters start from (this process's own BLAS is loaded already)."""
    for name, value in JOB_THREADS.items():
        os.environ.setdefault(name, value)


def context() -> multiprocessing.context.BaseContext:
    """The fork-server context, with meshcore and its kernels preloaded."""
    _job_environment()
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


def die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent (the fork server) exits."""
    if _LIBC is not None:
        _LIBC.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def job_body(task: Task, memory_limit: int, send: Callable[[tuple], None]) -> None:
    """Body of a spawned job's process: run the task (:func:`run_task`), exit."""
    die_with_parent()
    run_task(task, memory_limit, send)
    os._exit(0)  # the answer is sent: skip interpreter teardown


def run_task(task: Task, memory_limit: int, send: Callable[[tuple], None]) -> None:
    """Run ``task`` in this job process under its limits and send its outcome.

    The address space is limited to ``memory_limit``; the CPU time to the
    task's time limit and 5 s beyond what the process has used so far (the
    kernel then kills it with SIGXCPU), so a process that ran earlier jobs
    gives each the same allowance. Both are soft limits (:func:`_soft_limit`):
    a lowered hard limit could not be raised again for a later job.
    """
    _soft_limit(resource.RLIMIT_AS, memory_limit)
    used = resource.getrusage(resource.RUSAGE_SELF)
    _soft_limit(resource.RLIMIT_CPU, int(used.ru_utime + used.ru_stime + task.time_limit) + 5)
    last = time.monotonic()

    def progress(fraction: float, message: str) -> None:
        nonlocal last
        now = time.monotonic()
        if now - last >= PROGRESS_INTERVAL:
            last = now
            send(("progress", min(max(float(fraction), 0.0), 1.0), str(message)[:200]))

    try:
        send(("ok", run_job(task.spec, task.params, progress, task.formats, task.arrays)))
    except JobFailed as exc:
        send(("error", exc.problem))


def _soft_limit(which: int, value: int) -> None:
    """Set the soft limit ``which`` to ``value`` (at most the hard limit, left as it is)."""
    hard = resource.getrlimit(which)[1]
    if hard != resource.RLIM_INFINITY:
        value = min(value, hard)
    resource.setrlimit(which, (value, hard))


def demotion(pid: int) -> Callable[[], bool]:
    """A function to call as job process ``pid`` runs: the first call :data:`NICE_AFTER`
    seconds from now or later adds :data:`JOB_NICE` to the niceness of each of its threads
    (Linux keeps one per thread) and answers True, the others do nothing (False)."""
    at = time.monotonic() + NICE_AFTER
    done = False

    def demote() -> bool:
        nonlocal done
        if done or time.monotonic() < at:
            return False
        done = True
        nice = os.getpriority(os.PRIO_PROCESS, 0) + JOB_NICE  # this thread's, the API's
        try:
            threads = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
        except OSError:  # it has ended
            return True
        for tid in threads:
            try:
                os.setpriority(os.PRIO_PROCESS, tid, nice)
            except OSError:  # that thread has ended
                pass
        return True

    return demote


class Spares:
    """Processes started ahead of their jobs: at most ``size`` wait, one thread refills.

    ``start()`` makes one (blocking), ``alive(p)`` says whether it still
    waits, ``discard(p)`` ends one. A caller that takes a process calls
    :meth:`fill` once it will not give it back (:meth:`give_back`). The
    refill thread lives as long as the process: a job's process asks Linux
    to die with the thread that started it (``PR_SET_PDEATHSIG``), so that
    thread must not end before it.
    """

    def __init__(
        self,
        start: Callable[[], Any],
        alive: Callable[[Any], bool],
        discard: Callable[[Any], None],
        size: int,
    ) -> None:
        self._start, self._alive, self._discard, self.size = start, alive, discard, size
        self._ready: deque = deque()
        self._lock = threading.Lock()
        self._wanted = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    def fill(self) -> None:
        """Start the refill thread (once) and have it top the spares up."""
        with self._lock:
            if self._closed:
                return
            if self._thread is None:
                self._thread = threading.Thread(target=self._refill, name="spares", daemon=True)
                self._thread.start()
        self._wanted.set()

    def take(self) -> Any | None:
        """A waiting process, or None when none is ready (the caller starts its own).
        One found dead meanwhile is ended and replaced."""
        spare = None
        dead = False
        with self._lock:
            while self._ready:
                candidate = self._ready.popleft()
                if self._alive(candidate):
                    spare = candidate
                    break
                self._discard(candidate)
                dead = True
        if dead:
            self.fill()
        return spare

    def give_back(self, spare: Any) -> None:
        """A process that ran a job and waits for another: first in line (its pages are
        warm), or ended when ``size`` already wait."""
        with self._lock:
            if not self._closed and len(self._ready) < self.size:
                self._ready.appendleft(spare)
                return
        self._discard(spare)

    def close(self) -> None:
        """End the waiting processes; no more are started."""
        with self._lock:
            self._closed = True
            waiting, self._ready = list(self._ready), deque()
        for spare in waiting:
            self._discard(spare)
        self._wanted.set()

    def _refill(self) -> None:
        while not self._closed:
            self._wanted.wait()
            self._wanted.clear()
            while True:
                with self._lock:
                    if self._closed or len(self._ready) >= self.size:
                        break
                try:
                    spare = self._start()
                except Exception:  # e.g. out of processes: jobs then start their own
                    log.exception("could not start a spare job process")
                    break
                with self._lock:
                    if not self._closed and len(self._ready) < self.size:
                        self._ready.append(spare)
                        continue
                self._discard(spare)
                break


@dataclass
class _Forked:
    """A forked job process waiting for its tasks on ``tasks``; it answers on ``answers``."""

    proc: multiprocessing.process.BaseProcess
    tasks: Connection
    answers: Connection
    jobs: int = 0  # tasks sent to it so far


def _waiting_child(tasks: Connection, answers: Connection) -> None:
    die_with_parent()
    while True:
        try:
            task, memory_limit = tasks.recv()
        except EOFError:  # no more jobs (the service stopped, or the process is done)
            os._exit(0)  # skip interpreter teardown
        run_task(task, memory_limit, answers.send)
        del task  # not held while waiting


def _fork(ctx: multiprocessing.context.BaseContext) -> _Forked:
    tasks_r, tasks_w = ctx.Pipe(duplex=False)
    answers_r, answers_w = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_waiting_child, args=(tasks_r, answers_w), name="job", daemon=True)
    proc.start()
    tasks_r.close()
    answers_w.close()
    return _Forked(proc, tasks_w, answers_r)


def _end_forked(spare: _Forked) -> None:
    spare.tasks.close()  # it exits on EOF
    spare.proc.join(1)
    if spare.proc.is_alive():
        spare.proc.kill()
        spare.proc.join(5)
    spare.answers.close()


def forked_spares(ctx: multiprocessing.context.BaseContext, size: int) -> Spares:
    """Spare job processes forked from ``ctx``'s fork server, for :func:`run_in_child`."""
    return Spares(lambda: _fork(ctx), lambda s: s.proc.is_alive(), _end_forked, size)


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


def _reap(proc: multiprocessing.process.BaseProcess) -> None:
    """Wait for a job's process to end, killing it after 5 s."""
    proc.join(5)
    if proc.is_alive():
        proc.kill()
        proc.join(5)


def run_in_child(
    ctx: multiprocessing.context.BaseContext,
    task: Task,
    memory_limit: int,
    progress: Callable[[float, str], None],
    should_stop: Callable[[], bool],
    poll: float = 0.1,
    spares: Spares | None = None,
) -> dict[str, bytes]:
    """Run ``task`` in a child process and return its result files.

    The child is a spare of ``spares`` when one waits (:func:`forked_spares`),
    else forked now; it goes back to ``spares`` when the job succeeded within
    :data:`NICE_AFTER` and it has run fewer than :data:`JOBS_PER_PROCESS`
    jobs, else it ends. Blocks until the child answers or dies; checks
    ``should_stop`` every ``poll`` seconds while waiting.

    Raises
    ------
    JobFailed
        the job failed (its problem document), or its process died.
    Stopped
        ``should_stop()`` turned true; the child has been killed.
    """
    child = (spares.take() if spares is not None else None) or _fork(ctx)
    child.jobs += 1
    proc, receiver = child.proc, child.answers
    answered = None  # the answer's kind: "ok" or "error"
    owed = spares is not None  # a spare in its place unless it goes back (one fill)

    def gone() -> None:
        """It will not come back: a spare in its place now (once)."""
        nonlocal owed
        if owed:
            owed = False
            spares.fill()

    if child.jobs >= JOBS_PER_PROCESS:  # its last job
        gone()
    try:
        child.tasks.send((task, memory_limit))
    except OSError:
        pass  # it died meanwhile: its exit code says why, below
    demote = demotion(proc.pid)
    try:
        # Sequential by nature: one blocking reader per job's pipe.
        while True:
            ready = receiver.poll(poll)
            if demote():  # not a small job: it will not come back
                gone()
            if not ready:
                if should_stop():
                    raise Stopped(task.job_id)
                continue
            try:
                kind, *payload = receiver.recv()
            except EOFError:
                break
            if kind == "progress":
                progress(*payload)
                continue
            answered = kind
            if kind == "ok":
                return payload[0]
            raise JobFailed(payload[0])
        proc.join(5)
        log.warning("job %s: process died with exit code %s", task.job_id, proc.exitcode)
        raise JobFailed(death_problem(proc.exitcode))
    finally:
        if answered == "ok" and owed:  # small and not its last job: it may take another
            spares.give_back(child)
        else:
            gone()
            child.tasks.close()  # a process that waits for another task exits
            receiver.close()
            if answered:  # it exits by itself: its teardown (about 10 ms) is not the job's time
                threading.Thread(target=_reap, args=(proc,), name="reap", daemon=True).start()
            else:  # stopped, died, or this side failed: it may be deep in a kernel, no waiting
                proc.kill()
                proc.join(5)


def _frames(
    proc: subprocess.Popen,
    poll: float,
    should_stop: Callable[[], bool],
    demote: Callable[[], None],
    job_id: str,
):
    """The messages of a spawned job's stdout, checking ``should_stop`` every ``poll`` s
    and calling ``demote`` (:func:`demotion`) at each wake-up."""
    fd = proc.stdout.fileno()
    buffer = bytearray()
    while True:
        ready, _, _ = select.select([fd], [], [], poll)
        demote()
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


def _spawn() -> subprocess.Popen:
    import service

    root = str(Path(service.__file__).resolve().parents[1])  # the same code as this process
    _job_environment()
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, "PYTHONPATH": root + (os.pathsep + path if path else "")}
    return subprocess.Popen(
        [sys.executable, "-m", "service.executors.spawned"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
    )


def _end_spawned(proc: subprocess.Popen) -> None:
    proc.stdin.close()  # it exits on EOF
    try:
        proc.wait(1)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
    proc.stdout.close()


_SPAWNED: Spares | None = None
_SPAWNED_LOCK = threading.Lock()


def spawned_spares() -> Spares:
    """This process's spare interpreters for :func:`run_in_subprocess` (one, made on first use)."""
    global _SPAWNED
    with _SPAWNED_LOCK:
        if _SPAWNED is None:
            _SPAWNED = Spares(_spawn, lambda p: p.poll() is None, _end_spawned, 1)
            atexit.register(_SPAWNED.close)
        return _SPAWNED


def run_in_subprocess(
    task: Task,
    memory_limit: int,
    progress: Callable[[float, str], None],
    should_stop: Callable[[], bool],
    poll: float = 0.1,
    spares: Spares | None = None,
) -> dict[str, bytes]:
    """:func:`run_in_child`, but the job's process is a new interpreter started by ``subprocess``.

    For hosts where ``multiprocessing`` may not start children (daemonic
    processes such as a stock Dask worker). A fresh interpreter pays its
    start and imports (1-2 s): the job takes a spare of ``spares``
    (:func:`spawned_spares`) that has done them while waiting, when one is
    ready. Limits, death with the parent and kill on ``should_stop`` are the
    same.

    Raises
    ------
    JobFailed
        the job failed (its problem document), or its process died.
    Stopped
        ``should_stop()`` turned true; the process has been killed.
    """
    proc = (spares.take() if spares is not None else None) or _spawn()
    if spares is not None:
        spares.fill()  # a spawned process runs one job: a spare in its place
    try:
        proc.stdin.write(pickle.dumps((task, memory_limit), protocol=pickle.HIGHEST_PROTOCOL))
        proc.stdin.close()
    except BrokenPipeError:
        pass  # it died at once: its exit code says why, below
    try:
        frames = _frames(proc, poll, should_stop, demotion(proc.pid), task.job_id)
        for kind, *payload in frames:
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
