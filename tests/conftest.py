"""Session set-up for the whole suite."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from service.executors.child import die_with_parent

ROOT = Path(__file__).resolve().parents[1]
WARMUP_PARTS = 2  # processes filling numba's cache at once (the machine's cores)


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist, fill numba's cache (:mod:`tests.warmup`) before the workers start.

    Only the controller does it, and only when workers will run: a single-process
    run compiles what it reaches, once, as it goes.
    """
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    started = time.monotonic()
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "tests.warmup", str(part), str(WARMUP_PARTS)],
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=die_with_parent,  # pytest killed (a timeout): no orphan compiling on
        )
        for part in range(WARMUP_PARTS)
    ]
    for proc in procs:
        proc.wait()
    print(f"numba cache filled in {time.monotonic() - started:.0f} s", file=sys.stderr)
