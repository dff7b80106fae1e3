"""The durable job store: SQLite in WAL mode plus one folder of files per job.

Layout under the data directory::

    jobs.sqlite3            one row per job (status, progress, timestamps, error)
    jobs/<id>/params.json   the submitted params, written before the row commits
    jobs/<id>/result.json   the result, written atomically (temporary file + rename)
    jobs/<id>/result.<fmt>  downloads, the mesh's arrays (npz), previews: service.downloads

Durability: a crash or SIGKILL of the service loses nothing acknowledged
(files are renamed into place whole; SQLite commits before an answer). A
power loss may lose the last jobs and results, as SQLite's
``synchronous=NORMAL`` does, unless the store is ``durable``: then every
file is ``fsync``-ed before it is renamed into place and SQLite runs with
``synchronous=FULL`` (about 15 ms more per file on this machine's disk).

The store is used from the event-loop thread, and for result files from
worker threads (SQLite runs in serialized mode); every statement is short.
Each change of a row bumps its ``version``, which is the job's ``ETag``.

Every result file's size and SHA-256 are recorded in the ``files`` table
when it is written, and checked before it is served (a file truncated or
changed on disk is never served as a result: :class:`DamagedFile`). A
database that SQLite cannot read refuses to open (:class:`StoreDamaged`):
the service never starts empty over it. A full disk while writing a result
leaves no partial file (:class:`DiskFull`). Removing a job's files waits
for the writes in flight, and a write into a removed job's folder leaves
nothing behind (DELETE or expiry racing a result or a conversion).
"""

from __future__ import annotations

import errno
import hashlib
import json
import logging
import os
import shutil
import sqlite3
import threading
import time
import uuid
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from service.problems import problem_document

TERMINAL = frozenset({"succeeded", "failed", "cancelled"})
STATUSES = ("queued", "running", "succeeded", "failed", "cancelled")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT UNIQUE NOT NULL,
    client TEXT NOT NULL,
    method TEXT NOT NULL,
    status TEXT NOT NULL,
    attempt INTEGER NOT NULL DEFAULT 0,
    progress_fraction REAL NOT NULL DEFAULT 0,
    progress_message TEXT NOT NULL DEFAULT '',
    created_at REAL NOT NULL,
    started_at REAL,
    finished_at REAL,
    error TEXT,
    idempotency_key TEXT,
    body_hash TEXT,
    expired INTEGER NOT NULL DEFAULT 0,
    version INTEGER NOT NULL DEFAULT 1,
    UNIQUE (client, idempotency_key)
);
CREATE INDEX IF NOT EXISTS jobs_by_status ON jobs (status, seq);
CREATE INDEX IF NOT EXISTS jobs_by_client ON jobs (client, seq);
CREATE TABLE IF NOT EXISTS files (
    job_id TEXT NOT NULL,
    name TEXT NOT NULL,
    size INTEGER NOT NULL,
    sha256 TEXT NOT NULL,
    PRIMARY KEY (job_id, name)
);
"""

log = logging.getLogger("meshservice.store")

#: Seconds :meth:`Store.close` waits for the result writes and removals in flight.
CLOSE_WAIT = 30.0
_NO_SPACE = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


class StoreDamaged(RuntimeError):
    """The SQLite file cannot be read: the service refuses to start over it."""


class DamagedFile(RuntimeError):
    """A result file on disk no longer matches the size and checksum recorded for it."""


class DiskFull(RuntimeError):
    """A file did not fit on the data directory's disk; nothing partial was left."""


@dataclass(frozen=True)
class Job:
    """One row of the store."""

    seq: int
    id: str
    client: str
    method: str
    status: str
    attempt: int
    progress_fraction: float
    progress_message: str
    created_at: float
    started_at: float | None
    finished_at: float | None
    error: dict | None
    idempotency_key: str | None
    body_hash: str | None
    expired: bool
    version: int

    @property
    def finished(self) -> bool:
        return self.status in TERMINAL

    @property
    def etag(self) -> str:
        return f'"{self.id[:8]}-{self.version}"'


def write_atomically(path: Path, data: bytes | Callable[[BinaryIO], None], sync: bool) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one.

    ``data`` is the bytes, or a function writing them to the open file (big
    arrays go to disk without being assembled in memory first). ``sync``: on
    the disk (``fsync``) before it replaces ``path``, so that it survives a
    power loss too, not only a crash of the service. Raises
    :class:`DiskFull` (and removes the partial temporary file) when the disk
    or a quota is full.
    """
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    size = len(data) if isinstance(data, bytes | bytearray) else 0
    try:
        with open(tmp, "wb") as f:
            if callable(data):
                data(f)
                size = f.tell()
            else:
                f.write(data)
            f.flush()
            if sync:
                os.fsync(f.fileno())
        os.replace(tmp, path)
        if sync:  # the rename itself
            folder = os.open(path.parent, os.O_RDONLY)
            try:
                os.fsync(folder)
            finally:
                os.close(folder)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if exc.errno in _NO_SPACE:
            what = f"{size} bytes" if size else "the data"
            raise DiskFull(
                f"{what} did not fit in {path.parent} ({os.strerror(exc.errno)})"
            ) from exc
        raise


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


class Store:
    """Jobs in SQLite (WAL) and their files under ``data_dir``."""

    def __init__(self, data_dir: Path, durable: bool = False) -> None:
        self.data_dir = Path(data_dir)
        self.durable = durable
        self.jobs_dir = self.data_dir / "jobs"
        self.jobs_dir.mkdir(parents=True, exist_ok=True)
        path = self.data_dir / "jobs.sqlite3"
        self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        #: Held by every write from its statement to its row count: the count is the
        #: connection's last change, which another thread's write can replace in between
        #: (submits are admitted in threads: a committed job was taken for refused and its
        #: files removed, test_max_queued_holds_under_concurrent_submits).
        self._writing = threading.Lock()
        try:
            self._db.row_factory = sqlite3.Row
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(f"PRAGMA synchronous={'FULL' if durable else 'NORMAL'}")
            check = self._db.execute("PRAGMA quick_check").fetchone()[0]
            if check != "ok":
                raise sqlite3.DatabaseError(check)
            self._db.executescript(_SCHEMA)
        except sqlite3.DatabaseError as exc:
            self._db.close()
            raise StoreDamaged(
                f"the job store {path.resolve()} is damaged ({exc}); it was left untouched: "
                "restore it from a backup, or move it aside to start with an empty store"
            ) from exc
        self._verified: set[tuple] = set()
        self._files = threading.Condition()  # guards the two below
        self._writers: Counter[str] = Counter()  # result writes in flight, by job
        self._removing: set[str] = set()  # jobs whose folder is being removed
        self._closing = False  # set by close(): no new result write starts

    def close(self) -> None:
        """Close the database once the result writes and folder removals in flight
        have ended (they run in threads that a cancelled job or request does not
        stop: closing under one crashes SQLite); later ones write nothing."""
        with self._files:
            self._closing = True
            self._files.wait_for(lambda: not self._writers and not self._removing, CLOSE_WAIT)
        self._db.close()

    def ping(self) -> bool:
        """True when the database answers a query."""
        try:
            return self._db.execute("SELECT 1").fetchone()[0] == 1
        except sqlite3.Error:
            return False

    # -- files ------------------------------------------------------------------

    def job_dir(self, job_id: str) -> Path:
        return self.jobs_dir / job_id

    def params_path(self, job_id: str) -> Path:
        return self.job_dir(job_id) / "params.json"

    def result_path(self, job_id: str, fmt: str = "json") -> Path:
        return self.job_dir(job_id) / f"result.{fmt}"

    def arrays_path(self, job_id: str) -> Path:
        return self.job_dir(job_id) / "params.npz"

    def read_params(self, job_id: str) -> bytes:
        return self.params_path(job_id).read_bytes()

    def read_arrays(self, job_id: str) -> bytes:
        """The params' arrays (``domain_schema.pack``; blocking I/O); empty if it has none."""
        try:
            return self.arrays_path(job_id).read_bytes()
        except FileNotFoundError:
            return b""

    def write_result(self, job_id: str, data: bytes, fmt: str = "json") -> bool:
        """Write a result file atomically and record its size and SHA-256 (blocking I/O).

        False, writing nothing, when the job's folder is gone or being removed or
        the store is closing;
        :class:`DiskFull` when it does not fit.
        """
        with self._files:
            if self._closing or job_id in self._removing or not self.job_dir(job_id).is_dir():
                return False
            self._writers[job_id] += 1
        try:
            path = self.result_path(job_id, fmt)
            write_atomically(path, data, self.durable)
            self._changed(
                "INSERT OR REPLACE INTO files (job_id, name, size, sha256) VALUES (?, ?, ?, ?)",
                (job_id, path.name, len(data), hashlib.sha256(data).hexdigest()),
            )
            return True
        except FileNotFoundError:  # the folder was removed under the write
            return False
        finally:
            with self._files:
                self._writers[job_id] -= 1
                if not self._writers[job_id]:
                    del self._writers[job_id]
                self._files.notify_all()

    def verified_result(self, job_id: str, fmt: str = "json") -> Path | None:
        """The result file, checked against its record (blocking I/O); None if absent.

        Raises :class:`DamagedFile` when its size or SHA-256 differs from what
        was written. A file is hashed once per state (inode, size, mtime).
        """
        path = self.result_path(job_id, fmt)
        row = self._db.execute(
            "SELECT size, sha256 FROM files WHERE job_id = ? AND name = ?", (job_id, path.name)
        ).fetchone()
        try:
            st = path.stat()
        except FileNotFoundError:
            return None
        if row is None:  # written before checksums were kept
            return path
        state = (str(path), st.st_ino, st.st_size, st.st_mtime_ns)
        if state in self._verified:
            return path
        if st.st_size != row["size"]:
            raise DamagedFile(f"{path} has {st.st_size} bytes on disk, {row['size']} were written")
        if _sha256(path) != row["sha256"]:
            raise DamagedFile(f"{path} was changed on disk: its SHA-256 differs from the record")
        self._verified.add(state)
        return path

    def forget_file(self, job_id: str, fmt: str) -> None:
        """Remove a derived file (a damaged download cache) and its record."""
        path = self.result_path(job_id, fmt)
        path.unlink(missing_ok=True)
        self._changed("DELETE FROM files WHERE job_id = ? AND name = ?", (job_id, path.name))

    def remove_files(self, job_id: str) -> None:
        """Remove the job's folder once the result writes in flight have ended
        (blocking: run it off the event loop when a write may be running); nothing
        once the store is closing."""
        with self._files:
            if self._closing:
                return
            self._removing.add(job_id)
            self._files.wait_for(lambda: not self._writers[job_id])
            self._writers.pop(job_id, None)
        try:
            shutil.rmtree(self.job_dir(job_id), ignore_errors=True)
            self._changed("DELETE FROM files WHERE job_id = ?", (job_id,))
        finally:
            with self._files:
                self._removing.discard(job_id)
                self._files.notify_all()  # close() may be waiting

    def write_results(self, job_id: str, files: dict[str, bytes]) -> bool:
        """Write a finished job's files by name, ``result.json`` last (it marks them complete).

        False when the job's folder is gone or being removed; on
        :class:`DiskFull` the files already written are removed again.
        """
        written: list[str] = []
        try:
            for name in [*(n for n in files if n != "json"), "json"]:
                if not self.write_result(job_id, files[name], name):
                    return False
                written.append(name)
        except DiskFull:
            for name in written:
                self.forget_file(job_id, name)
            raise
        return True

    # -- rows -------------------------------------------------------------------

    def _row(self, row: sqlite3.Row | None) -> Job | None:
        if row is None:
            return None
        values: dict[str, Any] = dict(row)
        values["error"] = json.loads(values["error"]) if values["error"] else None
        values["expired"] = bool(values["expired"])
        return Job(**values)

    def write_params(self, params: bytes, arrays: bytes | Callable[[BinaryIO], None] = b"") -> str:
        """Write a new job's params file and its arrays if any (bytes, or a function
        writing them to a file; blocking I/O, run it off the event loop); its id."""
        job_id = uuid.uuid4().hex
        try:
            self.job_dir(job_id).mkdir(parents=True)
            if arrays:
                write_atomically(self.arrays_path(job_id), arrays, self.durable)
            write_atomically(self.params_path(job_id), params, self.durable)
        except (DiskFull, OSError) as exc:
            shutil.rmtree(self.job_dir(job_id), ignore_errors=True)
            if isinstance(exc, DiskFull) or exc.errno in _NO_SPACE:
                if isinstance(arrays, bytes):
                    size = f"{len(params) + len(arrays)} bytes"
                else:
                    size = f"{len(params)} bytes and the arrays"
                raise DiskFull(f"the job's params ({size}) did not fit") from exc
            raise
        return job_id

    def create(
        self,
        job_id: str,
        *,
        client: str,
        method: str,
        idempotency_key: str | None,
        body_hash: str,
        max_unfinished: int,
    ) -> Job | None:
        """Commit a queued row for params written by :meth:`write_params`, unless the
        client has ``max_unfinished`` queued or running jobs (None).

        The count and the insert are one statement, so concurrent submits
        cannot pass the limit together. When another request committed the
        same ``(client, idempotency_key)`` first, that job is returned instead.
        Either way, this job's files are removed when no row was inserted.
        """
        inserted = self._changed(
            "INSERT INTO jobs (id, client, method, status, created_at, idempotency_key,"
            " body_hash) SELECT ?, ?, ?, 'queued', ?, ?, ?"
            " WHERE (SELECT COUNT(*) FROM jobs WHERE client = ?"
            " AND status IN ('queued', 'running')) < ?"
            " ON CONFLICT (client, idempotency_key) DO NOTHING",
            (
                job_id,
                client,
                method,
                time.time(),
                idempotency_key,
                body_hash,
                client,
                max_unfinished,
            ),
        )
        if not inserted:
            shutil.rmtree(self.job_dir(job_id), ignore_errors=True)
            return self.by_idempotency_key(client, idempotency_key) if idempotency_key else None
        return self.get(job_id)

    def get(self, job_id: str, client: str | None = None) -> Job | None:
        """The job, or None when it does not exist or belongs to another client."""
        if client is None:
            row = self._db.execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone()
        else:
            row = self._db.execute(
                "SELECT * FROM jobs WHERE id = ? AND client = ?", (job_id, client)
            ).fetchone()
        return self._row(row)

    def by_idempotency_key(self, client: str, key: str) -> Job | None:
        row = self._db.execute(
            "SELECT * FROM jobs WHERE client = ? AND idempotency_key = ?", (client, key)
        ).fetchone()
        return self._row(row)

    def page(self, client: str, limit: int, before_seq: int | None) -> list[Job]:
        """A client's jobs, newest first, with ``seq`` below ``before_seq``."""
        rows = self._db.execute(
            "SELECT * FROM jobs WHERE client = ? AND seq < ? ORDER BY seq DESC LIMIT ?",
            (client, before_seq if before_seq is not None else 2**62, limit),
        ).fetchall()
        return [self._row(r) for r in rows]

    def unfinished_count(self, client: str) -> int:
        return self._db.execute(
            "SELECT COUNT(*) FROM jobs WHERE client = ? AND status IN ('queued', 'running')",
            (client,),
        ).fetchone()[0]

    def counts_by_status(self) -> dict[str, int]:
        rows = self._db.execute("SELECT status, COUNT(*) FROM jobs GROUP BY status").fetchall()
        counts = dict.fromkeys(STATUSES, 0)
        counts.update({status: n for status, n in rows})
        return counts

    def queued(self, limit: int, exclude: set[str]) -> list[Job]:
        """The oldest queued jobs not in ``exclude``."""
        rows = self._db.execute(
            "SELECT * FROM jobs WHERE status = 'queued' ORDER BY seq LIMIT ?",
            (limit + len(exclude),),
        ).fetchall()
        jobs = [self._row(r) for r in rows]
        return [j for j in jobs if j.id not in exclude][:limit]

    def _update(self, job_id: str, where_status: tuple[str, ...], **fields: Any) -> bool:
        """Set ``fields`` when the job's status is one of ``where_status``; True if it was."""
        if "error" in fields and fields["error"] is not None:
            fields["error"] = json.dumps(fields["error"])
        assignments = ", ".join(f"{k} = ?" for k in fields)
        marks = ", ".join("?" * len(where_status))
        return (
            self._changed(
                f"UPDATE jobs SET {assignments}, version = version + 1"
                f" WHERE id = ? AND status IN ({marks})",
                (*fields.values(), job_id, *where_status),
            )
            == 1
        )

    def _changed(self, sql: str, args: tuple) -> int:
        """Run a write (every write of the store goes through here); the rows it changed."""
        with self._writing:
            return self._db.execute(sql, args).rowcount

    def mark_running(self, job_id: str) -> bool:
        return (
            self._changed(
                "UPDATE jobs SET status = 'running', attempt = attempt + 1, started_at = ?,"
                " progress_fraction = 0, progress_message = '', version = version + 1"
                " WHERE id = ? AND status = 'queued'",
                (time.time(), job_id),
            )
            == 1
        )

    def set_progress(self, job_id: str, fraction: float, message: str) -> bool:
        return self._update(
            job_id, ("running",), progress_fraction=fraction, progress_message=message
        )

    def finish(self, job_id: str, status: str, error: dict | None = None) -> bool:
        """Record the end of a running job (a cancelled job stays cancelled)."""
        fields: dict[str, Any] = {"status": status, "finished_at": time.time(), "error": error}
        if status == "succeeded":
            fields["progress_fraction"] = 1.0
        return self._update(job_id, ("running",), **fields)

    def cancel(self, job_id: str) -> bool:
        """Cancel a queued or running job; False when it had already ended."""
        return self._update(
            job_id, ("queued", "running"), status="cancelled", finished_at=time.time()
        )

    def requeue(self, job_id: str) -> bool:
        """Put a running job back in the queue (shutdown or restart)."""
        return self._update(job_id, ("running",), status="queued", progress_message="requeued")

    def running(self) -> list[Job]:
        rows = self._db.execute("SELECT * FROM jobs WHERE status = 'running'").fetchall()
        return [self._row(r) for r in rows]

    def bump_attempt(self, job_id: str) -> bool:
        """Count one more run of a running job (the engine re-ran it)."""
        return (
            self._changed(
                "UPDATE jobs SET attempt = attempt + 1, version = version + 1"
                " WHERE id = ? AND status = 'running'",
                (job_id,),
            )
            == 1
        )

    def recover(self, interrupted: list[Job], max_attempts: int) -> tuple[int, int]:
        """After a restart: re-queue interrupted jobs, fail those out of attempts.

        Returns (requeued, failed).
        """
        requeued = failed = 0
        for job in interrupted:
            if job.attempt < max_attempts:
                requeued += self.requeue(job.id)
            else:
                error = problem_document(
                    500,
                    "interrupted",
                    "The job was interrupted too often",
                    f"the service stopped during each of its {job.attempt} attempts",
                )
                failed += self.finish(job.id, "failed", error)
        return requeued, failed

    def delete_row(self, job_id: str) -> None:
        """Remove the job's row (its files stay: see :meth:`remove_files`)."""
        self._changed("DELETE FROM jobs WHERE id = ?", (job_id,))

    def delete(self, job_id: str) -> None:
        """Remove the job's row, then its files."""
        self.delete_row(job_id)
        self.remove_files(job_id)

    def expire(self, now: float, retention: float) -> tuple[list[str], list[str]]:
        """Drop results older than ``retention`` and rows older than twice that.

        Returns the ids of (results expired, jobs removed).
        """
        old = self._db.execute(
            "SELECT id FROM jobs WHERE finished_at IS NOT NULL AND finished_at < ? AND expired = 0",
            (now - retention,),
        ).fetchall()
        for (job_id,) in old:
            self.remove_files(job_id)
            self._changed(
                "UPDATE jobs SET expired = 1, version = version + 1 WHERE id = ?", (job_id,)
            )
        ancient = self._db.execute(
            "SELECT id FROM jobs WHERE finished_at IS NOT NULL AND finished_at < ?",
            (now - 2 * retention,),
        ).fetchall()
        for (job_id,) in ancient:
            self.delete(job_id)
        return [j for (j,) in old], [j for (j,) in ancient]
