"""Session set-up for the whole suite."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session", autouse=True)
def _numba_cache_warmed_in_the_background() -> Iterator[None]:
    """Compile the kernels on the idle core (:mod:`tests.warmup`); stopped at the end."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.warmup"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    yield
    if proc.poll() is None:
        proc.kill()
    proc.wait()
