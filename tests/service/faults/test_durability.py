"""What the ``durable`` setting changes: fsync of every file and SQLite's FULL sync.

A crash of the service loses nothing acknowledged either way (the crash
tests); ``durable`` adds survival of a power loss, which no test here can
cause, so these tests check the mechanism: the fsyncs and the pragma.
"""

from __future__ import annotations

import os

import pytest

from service.store import Store


@pytest.mark.parametrize("durable", [False, True])
def test_durable_store_fsyncs_each_file_and_runs_sqlite_full(tmp_path, monkeypatch, durable):
    synced: list[int] = []
    fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (synced.append(fd), fsync(fd)))
    store = Store(tmp_path / "data", durable=durable)
    try:
        assert store._db.execute("PRAGMA synchronous").fetchone()[0] == (2 if durable else 1)
        job_id = store.write_params(b"{}", b"arrays")
        assert store.write_result(job_id, b'{"ok": true}')
        # params.npz, params.json, result.json: each file, then its folder (the rename)
        assert len(synced) == (6 if durable else 0)
        assert store.result_path(job_id).read_bytes() == b'{"ok": true}'
    finally:
        store.close()
