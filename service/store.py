"""The durable job store: SQLite in WAL mode plus one folder of files per job.

Layout under the data directory::

    jobs.sqlite3            one row per job (status, progress, timestamps, error)
    jobs/<id>/params.json   the submitted params, written before the row commits
    jobs/<id>/result.json   the result, written atomically (temporary file + rename)
    jobs/<id>/result.<fmt>  downloads, the mesh's arrays (npz), previews: service.downloads

The store is used from the event-loop thread only; every statement is short.
Each change of a row bumps its ``version``, which is the job's ``ETag``.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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
"""


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


def write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one."""
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class Store:
    """Jobs in SQLite (WAL) and their files under ``data_dir``."""

    def __init__(self, data_dir: Path) -> None:
        self.data_dir = Path(data_dir)
        self.jobs_dir = self.data_dir / "jobs"
        self.jobs_dir.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(
            self.data_dir / "jobs.sqlite3", isolation_level=None, check_same_thread=False
        )
        self._db.row_factory = sqlite3.Row
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_SCHEMA)

    def close(self) -> None:
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

    def read_params(self, job_id: str) -> bytes:
        return self.params_path(job_id).read_bytes()

    def write_result(self, job_id: str, data: bytes, fmt: str = "json") -> None:
        write_atomically(self.result_path(job_id, fmt), data)

    def write_results(self, job_id: str, files: dict[str, bytes]) -> None:
        """Write a finished job's files by name, ``result.json`` last (it marks them complete)."""
        for name, data in files.items():
            if name != "json":
                self.write_result(job_id, data, name)
        self.write_result(job_id, files["json"])

    # -- rows -------------------------------------------------------------------

    def _row(self, row: sqlite3.Row | None) -> Job | None:
        if row is None:
            return None
        values: dict[str, Any] = dict(row)
        values["error"] = json.loads(values["error"]) if values["error"] else None
        values["expired"] = bool(values["expired"])
        return Job(**values)

    def write_params(self, params: bytes) -> str:
        """Write a new job's params file (blocking I/O, run it off the event loop); its id."""
        job_id = uuid.uuid4().hex
        self.job_dir(job_id).mkdir(parents=True)
        write_atomically(self.params_path(job_id), params)
        return job_id

    def create(
        self,
        job_id: str,
        *,
        client: str,
        method: str,
        idempotency_key: str | None,
        body_hash: str,
    ) -> Job:
        """Commit a queued row for params written by :meth:`write_params`.

        When another request committed the same ``(client, idempotency_key)``
        first, this job's files are removed and that job is returned instead.
        """
        inserted = self._db.execute(
            "INSERT INTO jobs (id, client, method, status, created_at, idempotency_key,"
            " body_hash) VALUES (?, ?, ?, 'queued', ?, ?, ?)"
            " ON CONFLICT (client, idempotency_key) DO NOTHING",
            (job_id, client, method, time.time(), idempotency_key, body_hash),
        ).rowcount
        if not inserted:
            shutil.rmtree(self.job_dir(job_id), ignore_errors=True)
            return self.by_idempotency_key(client, idempotency_key)
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
        cur = self._db.execute(
            f"UPDATE jobs SET {assignments}, version = version + 1"
            f" WHERE id = ? AND status IN ({marks})",
            (*fields.values(), job_id, *where_status),
        )
        return cur.rowcount == 1

    def mark_running(self, job_id: str) -> bool:
        return (
            self._db.execute(
                "UPDATE jobs SET status = 'running', attempt = attempt + 1, started_at = ?,"
                " progress_fraction = 0, progress_message = '', version = version + 1"
                " WHERE id = ? AND status = 'queued'",
                (time.time(), job_id),
            ).rowcount
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
            self._db.execute(
                "UPDATE jobs SET attempt = attempt + 1, version = version + 1"
                " WHERE id = ? AND status = 'running'",
                (job_id,),
            ).rowcount
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

    def delete(self, job_id: str) -> None:
        """Remove the job's row and its files."""
        self._db.execute("DELETE FROM jobs WHERE id = ?", (job_id,))
        shutil.rmtree(self.job_dir(job_id), ignore_errors=True)

    def expire(self, now: float, retention: float) -> tuple[int, int]:
        """Drop results older than ``retention`` and rows older than twice that.

        Returns (results expired, jobs removed).
        """
        old = self._db.execute(
            "SELECT id FROM jobs WHERE finished_at IS NOT NULL AND finished_at < ? AND expired = 0",
            (now - retention,),
        ).fetchall()
        for (job_id,) in old:
            shutil.rmtree(self.job_dir(job_id), ignore_errors=True)
            self._db.execute(
                "UPDATE jobs SET expired = 1, version = version + 1 WHERE id = ?", (job_id,)
            )
        ancient = self._db.execute(
            "SELECT id FROM jobs WHERE finished_at IS NOT NULL AND finished_at < ?",
            (now - 2 * retention,),
        ).fetchall()
        for (job_id,) in ancient:
            self.delete(job_id)
        return len(old), len(ancient)
