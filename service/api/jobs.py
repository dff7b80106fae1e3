"""The jobs resource: submit, read, long-poll, stream, list, cancel, delete, results."""

import asyncio
import base64
import binascii
import functools
import gc
import hashlib
import logging
import operator
from collections.abc import AsyncIterator
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, Header, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.sse import EventSourceResponse, ServerSentEvent
from pydantic import ConfigDict, Field, TypeAdapter, ValidationError, create_model

from service import bodies, downloads
from service.deps import ClientDep, JobDep, ManagerDep, SettingsDep, StoreDep
from service.methods.domain_schema import ARRAYS, PACK, pack_arrays, write_npz
from service.methods.registry import FORMATS, InputError, Registry
from service.problems import (
    Damaged,
    Gone,
    InsufficientStorage,
    Invalid,
    NoResult,
    NotFound,
    NotReady,
    TooLarge,
    TooManyJobs,
    UnsupportedMediaType,
    from_input_error,
)
from service.schemas import JobOut, JobPage, ProblemOut, ResultOut
from service.store import DamagedFile, DiskFull, Job

log = logging.getLogger("meshservice.api")

MAX_WAIT = 30.0
MAX_SEQ = 2**62  # page tokens beyond it were not given out (and overflow SQLite's integers)
Format = Literal[tuple(FORMATS)]  # type: ignore[valid-type]


def _problems(*statuses: int) -> dict[int | str, dict[str, Any]]:
    return {s: {"model": ProblemOut, "content": {"application/problem+json": {}}} for s in statuses}


def request_model(registry: Registry) -> Any:
    """The POST body: a union of one model per method, discriminated on ``method``."""
    variants = []
    for spec in registry.values():
        example = {"method": spec.name, "params": spec.example}
        variants.append(
            create_model(
                f"{''.join(p.title() for p in spec.name.split('_'))}Job",
                __config__=ConfigDict(
                    extra="forbid", json_schema_extra={"examples": [example]}, title=spec.name
                ),
                method=(Literal[spec.name], Field(description=spec.summary)),
                params=(spec.params, ...),
            )
        )
    if len(variants) == 1:
        return variants[0]
    return Annotated[functools.reduce(operator.or_, variants), Field(discriminator="method")]


def _changed(before: Job, now: Job) -> bool:
    return now.version != before.version


def _page_token(seq: int) -> str:
    return base64.urlsafe_b64encode(f"seq:{seq}".encode()).decode().rstrip("=")


def _seq_of(token: str) -> int:
    try:
        raw = base64.urlsafe_b64decode(token + "=" * (-len(token) % 4)).decode()
        prefix, _, seq = raw.partition(":")
        if prefix != "seq" or not seq.isdigit() or int(seq) > MAX_SEQ:
            raise ValueError(raw)
        return int(seq)
    except (ValueError, binascii.Error, UnicodeDecodeError):
        raise Invalid(
            "page_token is not a token this service gave out",
            errors=[
                {"loc": ["query", "page_token"], "msg": "invalid token", "type": "value_error"}
            ],
        ) from None


async def _stream_slot(manager: ManagerDep, client: ClientDep) -> str:
    """The client, once it is known to have a free stream slot (a 429 before streaming)."""
    manager.check_stream(client)
    return client


def _etag_matches(if_none_match: str, etag: str) -> bool:
    """``If-None-Match`` holds ``etag`` or is ``*`` (weak comparison, RFC 9110 §13.1.2)."""
    tags = [t.strip() for t in if_none_match.split(",")]
    return "*" in tags or etag in (t.removeprefix("W/") for t in tags)


async def _read_body(request: Request) -> bytes | bytearray:
    """The request body, read into one buffer of its ``Content-Length``.

    Starlette's :meth:`~starlette.requests.Request.body` keeps the chunks and
    joins them (twice the body at once) and caches the result on the request
    for its whole life; this buffer is the only copy and is freed as soon as
    the body is parsed. A body without a length is read the ordinary way.
    """
    length = request.headers.get("content-length", "")
    if not length.isdigit():
        return await request.body()
    buf = bytearray(int(length))
    size = 0
    async for chunk in request.stream():
        buf[size : size + len(chunk)] = chunk
        size += len(chunk)
    del buf[size:]
    return buf


def _store_params(store: Any, params_json: bytes, packed: dict) -> str:
    """Write a new job's params and the arrays of its validated domains (blocking I/O);
    its id. The arrays go to ``params.npz`` straight from memory (:func:`write_npz`)."""
    arrays = pack_arrays(packed)
    return store.write_params(params_json, functools.partial(write_npz, arrays) if arrays else b"")


async def _json_body(request: Request) -> None:
    """Refuse a body that is not JSON (415); no ``Content-Type`` is taken as JSON."""
    kind = request.headers.get("content-type")
    if kind is None:
        return
    media = kind.split(";", 1)[0].strip().lower()
    if media != "application/json" and not media.endswith("+json"):
        raise UnsupportedMediaType(f"send the job as application/json, not {media or kind!r}")


def _job_response(job: Job, response: Response) -> JobOut:
    response.headers["ETag"] = job.etag
    response.headers["Location"] = f"/v1/jobs/{job.id}"
    if not job.finished:
        response.headers["Retry-After"] = "1"
    return JobOut.of(job)


def router(registry: Registry) -> APIRouter:
    """The ``/v1/jobs`` routes for the methods of ``registry``."""
    api = APIRouter(prefix="/v1/jobs", tags=["jobs"])
    JobRequest = request_model(registry)  # noqa: N806 (a type)
    adapter = TypeAdapter(JobRequest)
    body_schema = adapter.json_schema(ref_template="#/components/schemas/{model}")
    body_defs = body_schema.pop("$defs", {})

    def validate(raw: bytes) -> Any:
        # Building a million small lists runs the cyclic collector over and over (its full
        # passes walk every object made so far): 4 s instead of 21 s here with it paused.
        paused = gc.isenabled()
        gc.disable()
        try:
            body, arrays = bodies.extract_coordinates(raw)  # big rings straight to numpy
            try:
                return adapter.validate_json(body, context={ARRAYS: arrays} if arrays else None)
            except ValidationError as exc:
                if body is not raw and any(e["type"] == "json_invalid" for e in exc.errors()):
                    return adapter.validate_json(raw)  # raises, located in the body sent
                raise
        finally:
            if paused:
                gc.enable()

    def parsed_body(raw: bytes | bytearray) -> Any:
        """The body parsed and validated in one pass from its bytes (a 422 naming the
        place in the body otherwise).

        A million-vertex domain is 40 MB of JSON; parsing it to Python
        objects first and validating those after would hold both at once.
        """
        try:
            return validate(raw)
        except ValidationError as exc:
            errors = [{**e, "loc": ("body", *e["loc"])} for e in exc.errors()]
            loc = errors[0]["loc"] if errors else ()
            method = loc[1] if len(loc) > 1 and loc[1] in registry else None
            raise RequestValidationError(errors, body={"method": method}) from None

    def admit(
        held: list[bytes | bytearray],
        store: Any,
        settings: Any,
        client: str,
        idempotency_key: str | None,
    ) -> tuple[Job, str, bool]:
        """Parse, validate, check, store and commit a submitted job (blocking: one call off
        the event loop from the body's bytes to the committed row); the job, the body's
        hash and whether the job is new. A repeated ``Idempotency-Key`` gives the first
        job (not new) without the deep checks.

        ``held`` holds the body's only reference (tens of MB for a big domain): it is
        taken out, so the body is freed as soon as it is parsed.
        """
        body = parsed_body(held.pop())
        params = body.params
        packed: dict = {}  # domains, surfaces: arrays apart (pack), a marker in the JSON
        params_json = params.model_dump_json(context={PACK: packed}).encode()
        digest = hashlib.sha256(body.method.encode() + b"\0" + params_json)
        for model in packed.values():
            for arr in model.content_arrays():
                digest.update(len(arr).to_bytes(8, "little"))
                digest.update(np.ascontiguousarray(arr))
        body_hash = digest.hexdigest()
        job = store.by_idempotency_key(client, idempotency_key) if idempotency_key else None
        if job is not None:
            return job, body_hash, False
        try:  # deep checks (a million-vertex domain takes a while)
            params.check()
        except InputError as exc:
            raise from_input_error(exc, "body", "params") from None
        points = params.point_count()
        if points > settings.max_points:
            raise TooLarge(
                f"the job has {points} input points; this service takes at most "
                f"{settings.max_points} (MESHSERVICE_MAX_POINTS)"
            )
        too_many = TooManyJobs(
            f"you have {settings.max_queued} unfinished jobs (MESHSERVICE_MAX_QUEUED); "
            "wait for some to finish",
            headers={"Retry-After": "5"},
        )
        if store.unfinished_count(client) >= settings.max_queued:  # early, before writing
            raise too_many
        try:
            job_id = _store_params(store, params_json, packed)
        except DiskFull as exc:
            raise InsufficientStorage(
                f"the job could not be stored: {exc}; try again later"
            ) from None
        job = store.create(  # counts again and inserts in one statement
            job_id,
            client=client,
            method=body.method,
            idempotency_key=idempotency_key,
            body_hash=body_hash,
            max_unfinished=settings.max_queued,
        )
        if job is None:
            raise too_many
        return job, body_hash, job.id == job_id  # another request with this key committed first

    @api.post(
        "",
        status_code=202,
        operation_id="submitJob",
        summary="Submit a job",
        response_model=JobOut,
        responses={
            200: {"model": JobOut, "description": "Finished within ?wait=, or replayed."},
            **_problems(400, 401, 413, 415, 422, 429),
        },
        dependencies=[Depends(_json_body)],
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {"application/json": {"schema": body_schema}},
            },
            "x-schemas": body_defs,  # moved to components/schemas by the app's openapi()
        },
    )
    async def submit(
        client: ClientDep,  # first: a missing key is a 401 before the body is read
        request: Request,
        response: Response,
        manager: ManagerDep,
        store: StoreDep,
        settings: SettingsDep,
        wait: Annotated[float, Query(ge=0, le=MAX_WAIT, description="Seconds to wait.")] = 0,
        idempotency_key: Annotated[str | None, Header(max_length=255)] = None,
    ) -> JobOut:
        """Queue a job; with ``?wait=S`` answer 200 with the finished job if it ends by then.

        A repeated ``Idempotency-Key`` returns the first job (200) for the same
        body and answers 422 for a different one; an empty key is no key.
        """
        idempotency_key = idempotency_key or None
        held = [await _read_body(request)]  # before admission: a slow sender holds no slot
        async with manager.admission():  # a status read keeps its turn in a burst
            job, body_hash, new = await asyncio.to_thread(
                admit, held, store, settings, client, idempotency_key
            )
        if new:
            manager.wake()
        replayed = not new
        if replayed:
            response.headers["Idempotent-Replayed"] = "true"
        if job.body_hash != body_hash:
            raise Invalid(
                "this Idempotency-Key was used for a different request body",
                errors=[
                    {
                        "loc": ["header", "Idempotency-Key"],
                        "msg": "reused key",
                        "type": "idempotency_conflict",
                    }
                ],
            )
        if wait > 0 and not job.finished:
            with manager.stream(client):
                job = await manager.wait(job.id, lambda j: j.finished, wait) or job
        if job.finished or replayed:
            response.status_code = 200
        return _job_response(job, response)

    @api.get(
        "",
        operation_id="listJobs",
        summary="List your jobs, newest first",
        response_model=JobPage,
        responses=_problems(401, 422),
    )
    async def list_jobs(
        store: StoreDep,
        client: ClientDep,
        page_size: Annotated[int, Query(ge=1, le=100)] = 20,
        page_token: Annotated[str | None, Query(max_length=64)] = None,
    ) -> JobPage:
        before = _seq_of(page_token) if page_token else None
        jobs = store.page(client, page_size + 1, before)
        more = len(jobs) > page_size
        jobs = jobs[:page_size]
        return JobPage(
            jobs=[JobOut.of(j) for j in jobs],
            next_page_token=_page_token(jobs[-1].seq) if more else None,
        )

    @api.get(
        "/{job_id}",
        operation_id="getJob",
        summary="Get a job (long-poll with ?wait=)",
        response_model=JobOut,
        responses={304: {"description": "Not modified (If-None-Match)."}, **_problems(401, 404)},
    )
    async def get_job(
        job: JobDep,
        response: Response,
        manager: ManagerDep,
        client: ClientDep,
        wait: Annotated[float, Query(ge=0, le=MAX_WAIT, description="Seconds to wait.")] = 0,
        if_none_match: Annotated[str | None, Header()] = None,
    ) -> Any:
        """The job; ``?wait=S`` waits for a change (of the ETag given in
        ``If-None-Match``, else of the status); 304 when the ETag still matches."""
        if wait > 0:
            if if_none_match is not None:
                tag = if_none_match

                def changed(j: Job) -> bool:
                    return not _etag_matches(tag, j.etag)
            else:
                status = job.status

                def changed(j: Job) -> bool:
                    return j.status != status

            with manager.stream(client):
                job = await manager.wait(job.id, changed, wait)
            if job is None:
                raise NotFound("the job was deleted")
        if if_none_match is not None and _etag_matches(if_none_match, job.etag):
            return Response(status_code=304, headers={"ETag": job.etag})
        return _job_response(job, response)

    @api.get(
        "/{job_id}/events",
        operation_id="streamJobEvents",
        summary="Progress of a job as server-sent events",
        response_class=EventSourceResponse,
        responses=_problems(401, 404, 429),
    )
    async def events(
        job: JobDep, manager: ManagerDep, client: Annotated[str, Depends(_stream_slot)]
    ) -> AsyncIterator[ServerSentEvent]:
        """One ``progress`` event per change of the job, then an ``end`` event."""
        with manager.stream(client):
            version = -1
            current: Job | None = job
            while current is not None:
                if current.version != version:
                    version = current.version
                    data = JobOut.of(current).model_dump(mode="json")
                    yield ServerSentEvent(
                        event="end" if current.finished else "progress",
                        id=str(version),
                        data=data,
                    )
                if current.finished:
                    return
                current = await manager.wait(job.id, functools.partial(_changed, current), 15.0)

    @api.post(
        "/{job_id}/cancel",
        operation_id="cancelJob",
        summary="Cancel a job (idempotent)",
        response_model=JobOut,
        responses=_problems(401, 404),
    )
    async def cancel(job: JobDep, response: Response, manager: ManagerDep) -> JobOut:
        manager.cancel(job.id)
        return _job_response(manager.store.get(job.id) or job, response)

    @api.delete(
        "/{job_id}",
        status_code=204,
        operation_id="deleteJob",
        summary="Cancel if needed, then remove the job and its files",
        responses=_problems(401, 404),
    )
    async def delete(job: JobDep, manager: ManagerDep) -> Response:
        await manager.delete(job.id)
        return Response(status_code=204)

    def _removed(job: Job, store: Any) -> Exception:
        if store.get(job.id) is None:
            return NotFound("the job was deleted")
        return Gone(f"the result of job {job.id} has expired and was removed")

    async def _result_path(job: Job, store: Any) -> Any:
        """The job's checked result file (a damaged one is a 500 and a log line, never served)."""
        if job.expired:
            raise Gone(f"the result of job {job.id} has expired and was removed")
        if not job.finished:
            raise NotReady(f"job {job.id} is {job.status}", headers={"Retry-After": "1"})
        if job.status != "succeeded":
            raise NoResult(f"job {job.id} {job.status}; see its error")
        try:
            path = await asyncio.to_thread(store.verified_result, job.id)
        except DamagedFile as exc:
            log.error("job %s: damaged result file: %s", job.id, exc)
            raise Damaged(
                f"the stored result of job {job.id} is damaged ({exc}); it is not served: "
                "submit the job again"
            ) from None
        if path is None:  # deleted or expired between the row's read and now
            raise _removed(job, store)
        return path

    binary = {"type": "string", "format": "binary"}
    download_types = sorted({spec.media_type for spec in FORMATS.values()})
    format_table = "; ".join(f"`{name}`: {spec.media_type}" for name, spec in FORMATS.items())
    ranges = {
        206: {"description": "Part of the file (a `Range` request)."},
        304: {"description": "Not modified (`If-None-Match`)."},
        416: {"description": "The range is outside the file."},
    }

    @api.get(
        "/{job_id}/result",
        operation_id="getJobResult",
        summary="The result as JSON, or its mesh as a file (?format=)",
        description="Every answer is a file with `ETag`, `Content-Length`, "
        "`Content-Disposition` (`<job>-<format>.<suffix>`) and range requests. "
        f"Media types by format: {format_table}.",
        response_model=None,
        responses={
            200: {
                "description": "The result, or with ?format= the mesh file.",
                "content": {
                    "application/json": {"schema": ResultOut.model_json_schema()},
                    **{t: {"schema": binary} for t in download_types},
                },
            },
            **ranges,
            **_problems(401, 404, 409, 410, 422),
        },
    )
    async def result(
        job: JobDep,
        store: StoreDep,
        request: Request,
        format: Annotated[
            Format | None, Query(description=f"Download the mesh: {format_table}.")
        ] = None,
    ) -> Response:
        path = await _result_path(job, store)
        try:
            if format is None:
                return downloads.answer(
                    request,
                    path,
                    media_type="application/json",
                    filename=f"{job.id}-result.json",
                    etag=f'"{job.id}-json"',
                    attachment=False,
                )
            try:
                target = await asyncio.to_thread(downloads.mesh_download, store, job.id, format)
            except InputError as exc:
                raise from_input_error(exc) from None
            except DiskFull as exc:
                raise InsufficientStorage(f"the {format} file could not be stored: {exc}") from None
            spec = FORMATS[format]
            return downloads.answer(
                request,
                target,
                media_type=spec.media_type,
                filename=f"{job.id}-{format}{spec.suffix}",
                etag=f'"{job.id}-{format}"',
            )
        except FileNotFoundError:  # deleted or expired meanwhile
            raise _removed(job, store) from None

    def preview_route(kind: str, media_type: str, summary: str) -> None:
        @api.get(
            f"/{{job_id}}/preview.{kind}",
            operation_id="getJobPreview" if kind == "svg" else f"getJobPreview{kind.title()}",
            summary=summary,
            response_class=Response,
            responses={
                200: {"content": {media_type: {}}, "description": "The drawing."},
                **ranges,
                **_problems(401, 404, 409, 410, 422),
            },
        )
        async def preview(job: JobDep, store: StoreDep, request: Request) -> Response:
            await _result_path(job, store)  # 409 while running, 410 once expired
            try:
                target = await asyncio.to_thread(downloads.preview_file, store, job.id, kind)
                return downloads.answer(
                    request,
                    target,
                    media_type=media_type,
                    filename=f"{job.id}-preview.{kind}",
                    etag=f'"{job.id}-preview-{kind}"',
                    attachment=False,
                )
            except InputError as exc:
                raise from_input_error(exc) from None
            except DiskFull as exc:
                raise InsufficientStorage(f"the preview could not be stored: {exc}") from None
            except FileNotFoundError:  # deleted or expired meanwhile
                raise _removed(job, store) from None

    for kind, (media_type, _) in downloads.PREVIEWS.items():
        preview_route(
            kind,
            media_type,
            "A drawing of the result (2D; a 3D mesh as its boundary surface from a fixed view), "
            + ("at most about 2 MB" if kind == "svg" else "800 pixels wide or high"),
        )

    return api
