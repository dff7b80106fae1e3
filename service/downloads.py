"""A finished job's files and how they are answered: the fast download path.

A job's process hands back, besides its result JSON (``result.json``), the
mesh of the result as raw arrays (``result.npz``), the result without its
mesh (``result.meta.json``: domain, axis, regions, stats, for previews) and
the downloads listed in ``MESHSERVICE_JOB_FORMATS`` (default ``vtu``), so the
most asked download is ready when the job is. Any other format is written
on its first request from ``result.npz`` (milliseconds to load, where the
JSON takes seconds to parse) by meshcore's fast writers, then cached beside
it; results of older jobs without ``result.npz`` fall back to the JSON.
Previews are made and cached the same way.

Every answer is a file: ``ETag`` (strong: a job's files never change once
written), ``Content-Length``, ``Content-Disposition`` naming the job and the
format, ``Accept-Ranges: bytes`` and range requests (``206``, ``If-Range``),
and ``304`` on ``If-None-Match``. A derived file (``result.npz``, a
download, a preview) that no longer matches its recorded checksum is made
again; the file is opened before the answer starts, so a DELETE or an
expiry meanwhile is a :class:`FileNotFoundError` (404 or 410), not a 500.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable
from pathlib import Path

from fastapi import Request, Response

from meshcore.errors import InputError
from meshcore.mesh import Mesh, io
from service import preview
from service.files import OpenedFileResponse
from service.store import DamagedFile, Store

log = logging.getLogger("meshservice.downloads")

#: Previews by route suffix: (media type, renderer).
PREVIEWS: dict[str, tuple[str, Callable[[dict, Mesh | None], bytes]]] = {
    "svg": ("image/svg+xml", preview.render_svg),
    "png": ("image/png", preview.render_png),
}

_locks: dict[tuple[str, str], threading.Lock] = {}
_locks_guard = threading.Lock()


def _lock(job_id: str, name: str) -> threading.Lock:
    """One lock per job file: concurrent first requests convert once."""
    with _locks_guard:
        if len(_locks) > 1024:  # forget idle locks
            for key in [k for k, v in _locks.items() if not v.locked()]:
                del _locks[key]
        return _locks.setdefault((job_id, name), threading.Lock())


def _no_mesh() -> InputError:
    return InputError(
        "this result holds no mesh to download", loc=("query", "format"), code="no_mesh"
    )


def _verified(store: Store, job_id: str, name: str) -> Path | None:
    """A derived file if it exists and is intact; a damaged one is removed (made again)."""
    try:
        return store.verified_result(job_id, name)
    except DamagedFile as exc:
        log.warning("job %s: damaged %s, made again: %s", job_id, name, exc)
        store.forget_file(job_id, name)
        return None


def _mesh(store: Store, job_id: str) -> Mesh | None:
    """The result's mesh (None when it has none), from ``result.npz`` or else the JSON."""
    npz = _verified(store, job_id, "npz")
    if npz is not None:
        return io.from_npz(npz)
    result = json.loads(store.result_path(job_id).read_bytes())
    return io.from_json(result["mesh"]) if result.get("mesh") else None


def _meta(store: Store, job_id: str) -> dict:
    """The result without its mesh."""
    path = store.result_path(job_id, "meta.json")
    source = path if path.exists() else store.result_path(job_id)
    result = json.loads(source.read_bytes())
    result.pop("mesh", None)
    return result


def _cached(store: Store, job_id: str, name: str, make: Callable[[], bytes]) -> Path:
    """The file ``name``, written by ``make`` unless an intact copy exists.

    Raises :class:`FileNotFoundError` when the job's files were removed meanwhile.
    """
    path = _verified(store, job_id, name)
    if path is not None:
        return path
    with _lock(job_id, name):
        path = store.result_path(job_id, name)
        if not path.exists() and not store.write_result(job_id, make(), name):
            raise FileNotFoundError(path)
    return path


def mesh_download(store: Store, job_id: str, fmt: str) -> Path:
    """The file of the result's mesh in ``fmt``, written on first request (blocking).

    Raises
    ------
    InputError
        ``no_mesh``, or the format's ``format_mismatch`` (a 422).
    """

    def make() -> bytes:
        mesh = _mesh(store, job_id)
        if mesh is None:
            raise _no_mesh()
        if fmt == "glb":  # the web page reads the report and stats from the file, not the JSON
            meta = _meta(store, job_id)
            return io.to_glb(mesh, {k: meta[k] for k in ("quality", "stats") if k in meta})
        return io.to_bytes(mesh, fmt)

    return _cached(store, job_id, fmt, make)


def preview_file(store: Store, job_id: str, kind: str) -> Path:
    """The preview of the result (``svg`` or ``png``), drawn on first request (blocking).

    Raises
    ------
    InputError
        ``nothing_to_draw`` (a 422).
    """
    render = PREVIEWS[kind][1]
    return _cached(
        store, job_id, f"preview.{kind}", lambda: render(_meta(store, job_id), _mesh(store, job_id))
    )


def answer(
    request: Request,
    path: Path,
    *,
    media_type: str,
    filename: str,
    etag: str,
    attachment: bool = True,
) -> Response:
    """``path`` as the response: ETag (304 on a match), length, disposition, ranges."""
    headers = {"ETag": etag, "Cache-Control": "private, max-age=3600"}
    tags = request.headers.get("if-none-match")
    if tags is not None and (
        tags.strip() == "*" or etag in {t.strip().removeprefix("W/") for t in tags.split(",")}
    ):
        return Response(status_code=304, headers=headers)
    return OpenedFileResponse(
        path,
        media_type=media_type,
        filename=filename,
        headers=headers,
        content_disposition_type="attachment" if attachment else "inline",
    )
