"""Batch submission for ``meshservice submit``: files of jobs in, result files out.

Each JSON file holds one job (``{"method": ..., "params": ...}``); each line
of a ``.jsonl`` file holds one. Every job is submitted with an
``Idempotency-Key`` derived from its file name, line and body, so running
the same batch again returns the jobs already submitted instead of new ones.
While waiting, a progress bar per job and one overall are drawn from the
jobs' event streams (redrawn in place on a terminal, one line per change
otherwise). Results are written to ``--out`` in the chosen format, or as
JSON when a result holds no mesh.
"""

from __future__ import annotations

import hashlib
import json
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from meshcore.mesh.formats import FORMATS
from service.client import MeshClient, ServiceError


@dataclass
class Item:
    """One job of the batch."""

    source: str  # "file" or "file:line"
    stem: str  # output file name without suffix
    body: dict
    job: dict = field(default_factory=dict)
    error: str = ""
    output: str = ""

    @property
    def key(self) -> str:
        canonical = json.dumps(self.body, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(f"{self.source}\0{canonical}".encode()).hexdigest()[:40]

    @property
    def status(self) -> str:
        return "error" if self.error else self.job.get("status", "unsubmitted")


def read_items(paths: list[str]) -> list[Item]:
    """The jobs of the given files (ValueError naming the file and line when one is bad)."""
    items = []
    for name in paths:
        path = Path(name)
        try:
            text = path.read_text()
        except OSError as exc:
            raise ValueError(f"{name}: {exc.strerror}") from None
        lines = (
            [(i + 1, line) for i, line in enumerate(text.splitlines()) if line.strip()]
            if path.suffix == ".jsonl"
            else [(0, text)]
        )
        for number, line in lines:
            where = f"{path.name}:{number}" if number else path.name
            try:
                body = json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{where}: not JSON ({exc.msg} at column {exc.colno})") from None
            if not isinstance(body, dict) or "method" not in body:
                raise ValueError(f"{where}: a job is an object with 'method' and 'params'")
            stem = f"{path.stem}-{number}" if number else path.stem
            items.append(Item(where, stem, body))
    return items


def _bar(fraction: float, width: int = 20) -> str:
    done = int(round(fraction * width))
    return "#" * done + "." * (width - done)


class Progress:
    """Draws one bar per job and an overall bar."""

    def __init__(self, items: list[Item], out: TextIO) -> None:
        self.items = items
        self.out = out
        self.tty = out.isatty()
        self._last: dict[str, str] = {}
        self._drawn = 0
        self._lock = threading.Lock()

    def _line(self, item: Item) -> str:
        fraction = item.job.get("progress", {}).get("fraction", 0.0)
        if item.status == "succeeded":
            fraction = 1.0
        return f"{item.source:<28.28} [{_bar(fraction)}] {fraction:4.0%} {item.status}"

    def draw(self) -> None:
        with self._lock:
            finished = sum(
                i.status in ("succeeded", "failed", "cancelled", "error") for i in self.items
            )
            total = (
                f"{'overall':<28} [{_bar(finished / len(self.items))}] "
                f"{finished}/{len(self.items)} done"
            )
            if self.tty:
                lines = [self._line(i) for i in self.items] + [total]
                if self._drawn:
                    self.out.write(f"\x1b[{self._drawn}F")
                self.out.write("".join(f"\x1b[2K{line}\n" for line in lines))
                self._drawn = len(lines)
            else:
                for item in self.items:
                    line = self._line(item)
                    if self._last.get(item.source) != item.status:
                        self._last[item.source] = item.status
                        self.out.write(line + "\n")
                if self._last.get("") != total:
                    self._last[""] = total
                    self.out.write(total + "\n")
            self.out.flush()


def _follow(api: MeshClient, item: Item, progress: Progress) -> None:
    try:
        for _, state in api.events(item.job["id"]):
            item.job = state
            progress.draw()
    except (ServiceError, OSError) as exc:
        try:
            item.job = api.job(item.job["id"])
        except ServiceError:
            item.error = str(exc)
    progress.draw()


def _save(api: MeshClient, item: Item, out: Path, fmt: str) -> None:
    result = api.result(item.job["id"])
    out.mkdir(parents=True, exist_ok=True)
    if result.get("mesh"):
        path = api.download(item.job["id"], fmt, out / f"{item.stem}{FORMATS[fmt].suffix}")
    else:
        path = out / f"{item.stem}.json"
        path.write_text(json.dumps(result))
    item.output = str(path)


def run_batch(
    api: MeshClient,
    items: list[Item],
    *,
    wait: bool,
    out: Path | None,
    fmt: str,
    stream: TextIO = sys.stderr,
) -> int:
    """Submit, follow, download; print a summary table. Returns the exit status."""
    try:
        api.health()
    except ServiceError as exc:
        stream.write(f"meshservice: {exc}\n")
        return 2
    new = 0
    for item in items:
        try:
            item.job = api.submit(
                item.body["method"], item.body.get("params", {}), idempotency_key=item.key
            )
            new += not item.job.replayed
        except ServiceError as exc:
            item.error = str(exc)
    refused = sum(bool(i.error) for i in items)
    stream.write(
        f"submitted {len(items) - refused} jobs ({new} new, {refused} refused) to {api.url}\n"
    )
    if wait or out is not None:
        progress = Progress(items, stream)
        threads = [
            threading.Thread(target=_follow, args=(api, item, progress), daemon=True)
            for item in items
            if item.job and not item.error
        ]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        if out is not None:
            for item in items:
                if item.status == "succeeded":
                    try:
                        _save(api, item, out, fmt)
                    except (ServiceError, OSError) as exc:
                        item.error = f"download failed: {exc}"
    _summary(items, stream)
    bad = [i for i in items if i.error or i.status in ("failed", "cancelled")]
    return 1 if bad else 0


def _summary(items: list[Item], stream: TextIO) -> None:
    stream.write(f"{'job':<28} {'id':<32} {'status':<10} detail\n")
    for item in items:
        detail = item.error or (item.job.get("error") or {}).get("detail", "") or item.output
        stream.write(
            f"{item.source:<28.28} {item.job.get('id', '-'):<32} {item.status:<10} {detail}\n"
        )
