"""The job's own process started by ``subprocess``: ``python -m service.executors.spawned``.

:func:`service.executors.child.run_in_subprocess` starts it where
``multiprocessing`` may not start children (a stock Dask worker is a
daemonic process): it imports every method's code first (it may wait as a spare
meanwhile), then reads one pickled ``(task, memory_limit)`` from stdin
(none, at end of file: it exits), sets the same limits as a forked job
(address space, CPU time, death with its parent), runs :func:`service.runner.run_job` and writes its
messages to stdout as length-prefixed pickles: ``("progress", fraction,
message)`` any number of times, then ``("ok", files)`` or ``("error",
problem)``. The job's own prints go to stderr, so they cannot corrupt the
stream.
"""

from __future__ import annotations

import importlib
import os
import pickle
import struct
import sys


def main() -> None:
    out = os.fdopen(os.dup(sys.stdout.fileno()), "wb", buffering=0)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # stray prints go to stderr
    from service.executors.child import die_with_parent, job_body
    from service.methods.registry import METHOD_CODE

    for name in METHOD_CODE:  # every method's code, before the job comes
        importlib.import_module(name)

    die_with_parent()
    data = sys.stdin.buffer.read()
    if not data:
        os._exit(0)
    task, memory_limit = pickle.loads(data)

    def send(message: tuple) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        out.write(struct.pack("<Q", len(data)) + data)

    job_body(task, memory_limit, send)


if __name__ == "__main__":
    main()
