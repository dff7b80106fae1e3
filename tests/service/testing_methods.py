"""Methods registered only by the test server, never shipped in the product.

``echo_mesh`` returns its input mesh (to test downloads); ``sleep`` runs for a
while reporting progress (cancel, time limits, restarts); ``crash`` kills its
own process in a chosen way; ``boom`` raises an unexpected exception.
"""

from __future__ import annotations

import ctypes
import os
import signal
import time
from typing import Literal

from pydantic import Field

from service.methods.registry import MethodSpec, Progress, Registry, default_registry
from service.schemas import MeshIn, MethodParams

SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}


class EchoParams(MethodParams):
    mesh: MeshIn


def run_echo(params: EchoParams, progress: Progress) -> dict:
    return {"mesh": params.mesh.to_mesh(), "stats": {"points": len(params.mesh.points)}}


class SleepParams(MethodParams):
    seconds: float = Field(ge=0, le=3600)
    marker: str | None = Field(None, description="A file to create when the job starts.")


def run_sleep(params: SleepParams, progress: Progress) -> dict:
    if params.marker:
        with open(params.marker, "a") as f:
            f.write(f"{os.getpid()}\n")
    end = time.monotonic() + params.seconds
    while (left := end - time.monotonic()) > 0:
        progress(1 - left / max(params.seconds, 1e-9), f"{left:.1f} s left")
        time.sleep(min(left, 0.05))
    return {"stats": {"slept": params.seconds, "pid": os.getpid()}}


class CrashParams(MethodParams):
    how: Literal["exit", "segfault", "memory"]


def run_crash(params: CrashParams, progress: Progress) -> dict:
    if params.how == "exit":
        os._exit(3)
    if params.how == "segfault":
        os.kill(os.getpid(), signal.SIGSEGV)
        ctypes.string_at(0)
    blocks = []
    while True:  # grows until the address-space limit stops it
        blocks.append(bytearray(256 << 20))


class BlobParams(MethodParams):
    megabytes: float = Field(ge=0, le=256)


def run_blob(params: BlobParams, progress: Progress) -> dict:
    return {"stats": {"blob": "x" * int(params.megabytes * 1e6)}}


class BoomParams(MethodParams):
    pass


def run_boom(params: BoomParams, progress: Progress) -> dict:
    raise RuntimeError("boom")


def testing_registry() -> Registry:
    registry = default_registry()
    for spec in [
        MethodSpec(
            "echo_mesh", "Return the input mesh.", "tests", EchoParams, run_echo, {"mesh": SQUARE}
        ),
        MethodSpec(
            "sleep", "Sleep, reporting progress.", "tests", SleepParams, run_sleep, {"seconds": 0.1}
        ),
        MethodSpec(
            "crash", "Kill the job's own process.", "tests", CrashParams, run_crash, {"how": "exit"}
        ),
        MethodSpec("boom", "Raise an unexpected exception.", "tests", BoomParams, run_boom, {}),
        MethodSpec(
            "blob", "A result of the given size.", "tests", BlobParams, run_blob, {"megabytes": 1}
        ),
    ]:
        registry[spec.name] = spec
    return registry
