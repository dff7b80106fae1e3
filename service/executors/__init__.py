"""Executors run jobs; the API layer knows only this protocol.

An executor runs :func:`service.runner.run_job` for a :class:`Task` somewhere
it can stop: cancelling the coroutine returned by :meth:`Executor.run` must
stop the job's process (that is how cancellation and time limits work). It
returns the result bytes or raises :class:`~service.runner.JobFailed`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from service.methods import MethodSpec


@dataclass(frozen=True)
class Task:
    """One run of one job."""

    job_id: str
    spec: MethodSpec
    params: bytes
    time_limit: float


class Executor(Protocol):
    """Where jobs run: ``local`` processes here, or a distributed engine."""

    name: str
    capacity: int  # jobs it runs at once

    async def start(self) -> None: ...

    async def close(self) -> None: ...

    def ready(self) -> bool: ...

    async def run(self, task: Task, progress: Callable[[float, str], None]) -> bytes: ...
