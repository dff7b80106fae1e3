"""The job process's CPU priority: the caller's at first, then lower (:func:`demotion`)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from service.executors.child import JOB_NICE, NICE_AFTER, demotion

#: A process with two threads, saying when both run.
TWO_THREADS = (
    "import threading, time\n"
    "threading.Thread(target=time.sleep, args=(30,), daemon=True).start()\n"
    "print('ready', flush=True)\n"
    "time.sleep(30)\n"
)


def _nices(pid: int) -> list[int]:
    return [os.getpriority(os.PRIO_PROCESS, int(t)) for t in os.listdir(f"/proc/{pid}/task")]


def test_a_job_runs_at_the_callers_priority_first_then_every_thread_lower():
    own = os.getpriority(os.PRIO_PROCESS, 0)
    proc = subprocess.Popen([sys.executable, "-c", TWO_THREADS], stdout=subprocess.PIPE)
    try:
        assert proc.stdout.readline() == b"ready\n"
        t0 = time.monotonic()
        demote = demotion(proc.pid)
        demote()
        if time.monotonic() - t0 < NICE_AFTER:  # (not on a machine too busy to tell)
            assert _nices(proc.pid) == [own, own]
        time.sleep(NICE_AFTER)
        demote()
        assert _nices(proc.pid) == [min(own + JOB_NICE, 19)] * 2
    finally:
        proc.kill()
        proc.wait()
