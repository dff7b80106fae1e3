"""Session set-up for the whole suite."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from service.executors.child import die_with_parent

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session", autouse=True)
def _numba_cache_warmed_in_the_background() -> Iterator[None]:
    """Compile the kernels on the idle core (:mod:`tests.warmup`); stopped at the end.

    Under pytest-xdist only the first worker starts it (one warm-up is enough)."""
    if os.environ.get("PYTEST_XDIST_WORKER", "gw0") != "gw0":
        yield
        return
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.warmup"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=die_with_parent,  # pytest killed (a timeout): no orphan compiling on
    )
    yield
    if proc.poll() is None:
        proc.kill()
    proc.wait()
