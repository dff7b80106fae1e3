"""Session set-up for the whole suite: numba's cache is filled while the service tests run.

On a fresh clone numba's disk cache is empty, and filling it takes about 400 CPU
seconds. Under pytest-xdist the controller starts filling it at once, in
:data:`WARMUP_PROCESSES` processes (:mod:`tests.warmup`), and the workers do not
wait for it: the tests that need no kernel run first, meanwhile. Those are the
service tests under ``tests/service`` that neither use the shared ``live``
server (it warms every method up) nor carry the ``kernels`` mark: they start
their own servers without warm-up and run the testing methods, and they spend
most of their time waiting on servers, jobs and clients, which leaves the cores
to the compiler. They wait only for the kernels an API process runs on a
request (the domain checks, the body parser: the warm-up's first task, a few
seconds; every worker compiled them at once before). Every other test waits
until the cache is filled, so that no
kernel is compiled twice at once (four workers compiling the same kernels made
a cold run's compile work about four times larger). ``--dist loadgroup
--no-loadscope-reorder`` (``pyproject.toml``) hands the tests out in the order set
here, a group where its first test falls.

A single-process run (``-n 0``), or a run of chosen files or tests, fills
nothing ahead: each test compiles what it reaches as it goes.

With ``CI`` set (``.ci/run`` sets it), hypothesis draws the same examples on
every run (``derandomize``): CI answers for the change, not for the draw; the
random exploration goes on in every other run.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest
from hypothesis import settings

# One BLAS thread per process, as the service's job processes have (service.executors.child.
# JOB_THREADS): four workers on two cores, each with a multithreaded OpenBLAS, oversubscribe.
# Set before the workers start (they inherit it), and before this process loads numpy.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

from service.executors.child import die_with_parent  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
WARMUP_PROCESSES = 2  # processes filling numba's cache at once (the machine's cores)
#: Names the file that exists once numba's cache is filled (set by the controller).
READY_ENV = "MESHSERVICE_TESTS_KERNELS_READY"
#: Names the file that exists once the API process's kernels are in the cache.
API_READY_ENV = "MESHSERVICE_TESTS_API_KERNELS_READY"
#: A worker waits at most this long for the cache, then compiles what it reaches.
READY_TIMEOUT = 1200.0

settings.register_profile("derandomized", derandomize=True, database=None)
if os.environ.get("CI"):
    settings.load_profile("derandomized")


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist, for the whole suite, start filling numba's cache
    (:mod:`tests.warmup`) in the controller; a thread touches the file named by
    :data:`READY_ENV` when it is done."""
    config.addinivalue_line(
        "markers", "kernels: runs numba kernels, so waits for numba's cache to be filled"
    )
    if (
        hasattr(config, "workerinput")
        or not config.getoption("numprocesses", None)
        or config.args_source != pytest.Config.ArgsSource.TESTPATHS  # chosen files or tests
    ):
        return
    ready = Path(tempfile.mkdtemp(prefix="meshservice-tests-")) / "kernels-ready"
    api_ready = ready.with_name("api-kernels-ready")
    os.environ[READY_ENV] = str(ready)  # the workers, started after this, inherit them
    os.environ[API_READY_ENV] = str(api_ready)
    started = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.warmup", str(WARMUP_PROCESSES), str(api_ready)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=die_with_parent,  # pytest killed (a timeout): no orphan compiling on
    )

    def wait() -> None:
        proc.wait()
        with contextlib.suppress(OSError):  # pytest may have ended first
            api_ready.touch()  # (a warm-up that failed early: nobody waits for ever)
            ready.touch()
        print(f"\nnumba cache filled in {time.monotonic() - started:.0f} s", file=sys.stderr)

    threading.Thread(target=wait, name="numba-cache", daemon=True).start()


def pytest_unconfigure(config: pytest.Config) -> None:
    ready = os.environ.get(READY_ENV)
    if ready and not hasattr(config, "workerinput"):
        Path(ready).unlink(missing_ok=True)
        Path(os.environ[API_READY_ENV]).unlink(missing_ok=True)
        Path(ready).parent.rmdir()


def _needs_kernels(item: pytest.Item) -> bool:
    in_service = Path(item.path).is_relative_to(ROOT / "tests" / "service")
    return (
        not in_service
        or "live" in getattr(item, "fixturenames", ())
        or item.get_closest_marker("kernels") is not None
    )


def _shared_group(item: pytest.Item) -> str | None:
    """The test's module (with the parameters of its shared fixtures) when it uses a
    module- or class-scoped fixture, else None."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return None
    callspec = getattr(item, "callspec", None)
    shared = []
    for name in item.fixturenames:
        defs = info.name2fixturedefs.get(name)
        if defs and defs[-1].scope in ("module", "class"):
            param = callspec.params.get(name) if callspec else None
            shared.append("" if param is None else f"[{param}]")
    return f"{item.module.__name__}{''.join(sorted(shared))}" if shared else None


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The tests that need no kernel first (a stable sort: the same order in every worker).

    The tests that share a module-scoped fixture (a server with its own settings, the Dask
    cluster, the browser) form one group, which ``--dist loadgroup`` (``pyproject.toml``)
    hands to one worker: before, each worker that ran one of them started its own copy.
    """
    items.sort(key=_needs_kernels)
    for item in items:
        group = _shared_group(item)
        if group:
            item.add_marker(pytest.mark.xdist_group(group))


def kernels_ready(env: str = READY_ENV) -> None:
    """Return once numba's cache is filled (under pytest-xdist), or at once (``-n 0``);
    with ``env`` :data:`API_READY_ENV`, once the API process's kernels are."""
    ready = os.environ.get(env)
    if not ready:
        return
    deadline = time.monotonic() + READY_TIMEOUT
    while not os.path.exists(ready) and time.monotonic() < deadline:
        time.sleep(0.2)


@pytest.fixture(autouse=True)
def _kernels_compiled(request: pytest.FixtureRequest) -> None:
    kernels_ready(READY_ENV if _needs_kernels(request.node) else API_READY_ENV)
