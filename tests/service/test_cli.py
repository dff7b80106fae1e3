"""The batch client, ``meshservice submit/jobs/cancel``, against a live server."""

from __future__ import annotations

import json
import subprocess
import sys

from service.client import MeshClient
from tests.service.conftest import ROOT
from tests.service.testing_methods import SQUARE


def cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "service", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def write_batch(folder, n_files: int, n_lines: int, method: str = "echo_mesh") -> list[str]:
    folder.mkdir()
    job = {"method": method, "params": {"mesh": SQUARE} if method == "echo_mesh" else {}}
    paths = []
    for i in range(n_files):
        path = folder / f"job{i}.json"
        path.write_text(json.dumps(job))
        paths.append(str(path))
    lines = folder / "more.jsonl"
    lines.write_text(
        "\n".join(
            json.dumps(
                {
                    **job,
                    "params": {
                        **job["params"],
                        "mesh": {**SQUARE, "points": [[x + i, y] for x, y in SQUARE["points"]]},
                    },
                }
            )
            for i in range(n_lines)
        )
    )
    return [*paths, str(lines)]


class TestSubmit:
    def test_batch_of_20_downloads_20_files_and_a_rerun_submits_nothing(
        self, start_server, tmp_path
    ):
        server = start_server()
        files = write_batch(tmp_path / "in", 10, 10)
        out = tmp_path / "out"
        first = cli("submit", *files, "--url", server.url, "--out", str(out), "--format", "vtu")
        assert first.returncode == 0, first.stderr
        assert "submitted 20 jobs (20 new, 0 refused)" in first.stderr
        assert "overall" in first.stderr and "#" in first.stderr
        assert sorted(p.name for p in out.iterdir()) == sorted(
            [f"job{i}.vtu" for i in range(10)] + [f"more-{i}.vtu" for i in range(1, 11)]
        )
        again = cli("submit", *files, "--url", server.url, "--wait")
        assert again.returncode == 0, again.stderr
        assert "submitted 20 jobs (0 new, 0 refused)" in again.stderr
        with MeshClient(server.url) as api:
            assert len(list(api.jobs())) == 20

    def test_a_failing_job_gives_nonzero_exit_and_names_it(self, client, live, tmp_path):
        good = tmp_path / "good.json"
        good.write_text(json.dumps({"method": "quality", "params": {"mesh": SQUARE}}))
        bad = tmp_path / "explodes.json"
        bad.write_text(json.dumps({"method": "boom", "params": {}}))
        run = cli("submit", str(good), str(bad), "--url", live.url, "--wait")
        assert run.returncode == 1
        summary = run.stderr.splitlines()
        assert any(line.startswith("explodes.json") and "failed" in line for line in summary)
        assert any(line.startswith("good.json") and "succeeded" in line for line in summary)

    def test_refused_job_is_reported(self, live, tmp_path):
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps({"method": "quality", "params": {"mesh": {"points": []}}}))
        run = cli("submit", str(bad), "--url", live.url)
        assert run.returncode == 1
        assert "422" in run.stderr and "bad.json" in run.stderr

    def test_stopped_server_is_a_clear_message(self, tmp_path):
        job = tmp_path / "j.json"
        job.write_text(json.dumps({"method": "quality", "params": {"mesh": SQUARE}}))
        run = cli("submit", str(job), "--url", "http://127.0.0.1:9")
        assert run.returncode == 2
        assert "cannot reach http://127.0.0.1:9" in run.stderr
        assert "Traceback" not in run.stderr

    def test_bad_file_is_a_clear_message(self, tmp_path):
        job = tmp_path / "j.jsonl"
        job.write_text('{"method": "quality", "params": {}}\n{not json\n')
        run = cli("submit", str(job))
        assert run.returncode == 2
        assert "j.jsonl:2: not JSON" in run.stderr


class TestJobsAndCancel:
    def test_list_and_cancel(self, start_server):
        server = start_server(MESHSERVICE_WORKERS="1")
        with MeshClient(server.url) as api:
            running = api.submit("sleep", {"seconds": 30})
            listed = cli("jobs", "--url", server.url)
            assert listed.returncode == 0 and running["id"] in listed.stdout
            cancelled = cli("cancel", running["id"], "--url", server.url)
            assert cancelled.returncode == 0
            assert f"{running['id']} cancelled" in cancelled.stdout
            assert api.job(running["id"])["status"] == "cancelled"
            missing = cli("cancel", "nope", "--url", server.url)
            assert missing.returncode == 1 and "404" in missing.stderr
