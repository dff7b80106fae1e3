"""Executors run jobs; the API layer knows only this protocol.

An executor runs :func:`service.runner.run_job` for a :class:`Task` somewhere
it can stop: cancelling the coroutine returned by :meth:`Executor.run` must
stop the job's process (that is how cancellation and time limits work). It
returns the result's files (:func:`service.runner.result_files`) or raises
:class:`~service.runner.JobFailed`; it
calls ``progress(fraction, message)`` as the job reports, and
``restarted()`` when the engine runs the job again on its own (a
distributed worker died under it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from service.methods.registry import MethodSpec

#: The file where the fork server records its warm-up (see service.executors.preload).
WARMUP_STATUS_ENV = "MESHSERVICE_WARMUP_STATUS"
#: "0" when the fork server skips the warm-up steps (the ``warmup`` setting).
WARMUP_ENV = "MESHSERVICE_WARMUP"


@dataclass(frozen=True)
class Task:
    """One run of one job."""

    job_id: str
    attempt: int
    spec: MethodSpec
    params: bytes
    time_limit: float
    formats: tuple[str, ...] = ()  # downloads the job writes itself (MESHSERVICE_JOB_FORMATS)
    arrays: bytes = b""  # the params' arrays and validated domains (domain_schema.pack_arrays)


class Executor(Protocol):
    """Where jobs run: ``local`` processes here, or a distributed engine."""

    name: str
    capacity: int  # jobs it runs at once

    async def start(self) -> None: ...

    async def close(self) -> None: ...

    def ready(self) -> bool: ...

    def describe(self) -> dict: ...  # for /readyz: the backend and its workers

    async def forget(self, job_id: str, attempt: int) -> None:
        """Stop a run left over from before a restart, if the engine still has it."""

    async def run(
        self,
        task: Task,
        progress: Callable[[float, str], None],
        restarted: Callable[[], None],
    ) -> dict[str, bytes]: ...
