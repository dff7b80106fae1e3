"""A result file damaged on disk is never served; a damaged SQLite file stops the start."""

from __future__ import annotations

import subprocess
import sys

import meshio

from tests.service.conftest import ROOT
from tests.service.test_jobs import assert_problem, submit
from tests.service.testing_methods import SQUARE


def _finished(c, method="echo_mesh", params=None) -> str:
    r = submit(c, method, params or {"mesh": SQUARE}, wait=20)
    assert r.status_code == 200 and r.json()["status"] == "succeeded", r.text
    return r.json()["id"]


def test_a_truncated_result_is_refused_and_logged(live, client):
    job = _finished(client)
    path = live.data_dir / "jobs" / job / "result.json"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    doc = assert_problem(client.get(f"/v1/jobs/{job}/result"), 500)
    assert doc["type"] == "/problems/result-damaged" and job in doc["detail"]
    assert "damaged result file" in live.log.read_text()


def test_a_result_changed_in_place_is_refused(live, client):
    job = _finished(client)
    path = live.data_dir / "jobs" / job / "result.json"
    data = bytearray(path.read_bytes())
    data[data.index(b"0")] = ord("1")  # same size, other content
    path.write_bytes(bytes(data))
    assert_problem(client.get(f"/v1/jobs/{job}/result"), 500)
    assert_problem(client.get(f"/v1/jobs/{job}/result", params={"format": "vtu"}), 500)


def test_an_intact_result_is_served(client):
    job = _finished(client)
    assert client.get(f"/v1/jobs/{job}/result").json()["mesh"]["points"] == SQUARE["points"]


def test_a_damaged_download_is_converted_again(live, client, tmp_path):
    job = _finished(client)
    first = client.get(f"/v1/jobs/{job}/result", params={"format": "vtu"})
    assert first.status_code == 200
    cached = live.data_dir / "jobs" / job / "result.vtu"
    cached.write_bytes(cached.read_bytes()[:100])
    again = client.get(f"/v1/jobs/{job}/result", params={"format": "vtu"})
    assert again.status_code == 200 and again.content == first.content
    (tmp_path / "m.vtu").write_bytes(again.content)
    assert len(meshio.read(tmp_path / "m.vtu").points) == 4


def test_a_damaged_store_refuses_to_start(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    db = data / "jobs.sqlite3"
    db.write_bytes(b"this is not an SQLite database" * 100)
    before = db.read_bytes()
    proc = subprocess.run(
        [sys.executable, "-m", "service", "serve", "--port", "0", "--data-dir", str(data)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode != 0
    assert "refusing to start" in proc.stderr and str(db.resolve()) in proc.stderr
    assert db.read_bytes() == before  # never started empty over it
