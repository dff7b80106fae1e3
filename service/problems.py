"""Errors as classes, mapped once to RFC 9457 problem documents.

Routes raise :class:`Problem` subclasses, never free-text ``HTTPException``\\ s.
:func:`install_handlers` turns them, meshcore's input errors, FastAPI's
validation errors and Starlette's own 404/405 into
``application/problem+json`` bodies with ``type``, ``title``, ``status``,
``detail`` and, for validation errors, an ``errors`` list of
``{"loc": [...], "msg": ..., "type": ...}``. An unexpected exception gives a
500 problem and a logged traceback, never a bare stack trace to the client.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from meshcore.errors import InputError, MeshcoreError

if TYPE_CHECKING:  # imported where used: a job's process needs problem_document only
    from fastapi import FastAPI, Request
    from fastapi.responses import JSONResponse

log = logging.getLogger("meshservice")

PROBLEM_MEDIA_TYPE = "application/problem+json"


def problem_type(code: str) -> str:
    """The ``type`` URI of a problem code (a relative reference, RFC 9457 §3.1.1)."""
    return f"/problems/{code.replace('_', '-')}"


def problem_document(
    status: int, code: str, title: str, detail: str, errors: list[dict] | None = None
) -> dict[str, Any]:
    """A problem document as a plain dict (also stored in a failed job's ``error``)."""
    doc: dict[str, Any] = {
        "type": problem_type(code),
        "title": title,
        "status": status,
        "detail": detail,
    }
    if errors:
        doc["errors"] = errors
    return doc


class Problem(Exception):
    """An HTTP error the API answers on purpose."""

    status = 500
    code = "internal_error"
    title = "Internal server error"

    def __init__(
        self,
        detail: str,
        *,
        errors: list[dict] | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
        super().__init__(detail)
        self.detail = detail
        self.errors = errors
        self.headers = headers or {}

    def document(self) -> dict[str, Any]:
        return problem_document(self.status, self.code, self.title, self.detail, self.errors)


class BadRequest(Problem):
    status, code, title = 400, "bad_request", "Bad request"


class Unauthorized(Problem):
    status, code, title = 401, "unauthorized", "Missing or invalid API key"

    def __init__(self, detail: str) -> None:
        super().__init__(detail, headers={"WWW-Authenticate": 'Bearer realm="meshservice"'})


class NotFound(Problem):
    status, code, title = 404, "not_found", "Not found"


class MethodNotAllowed(Problem):
    status, code, title = 405, "method_not_allowed", "Method not allowed"


class NotReady(Problem):
    """The job has not finished (its result does not exist yet)."""

    status, code, title = 409, "not_finished", "The job has not finished"


class NoResult(Problem):
    """The job ended without a result (failed or cancelled)."""

    status, code, title = 409, "no_result", "The job has no result"


class Gone(Problem):
    status, code, title = 410, "expired", "The result has expired"


class TooLarge(Problem):
    status, code, title = 413, "too_large", "Request too large"


class UnsupportedMediaType(Problem):
    status, code, title = 415, "unsupported_media_type", "Unsupported media type"


class Invalid(Problem):
    status, code, title = 422, "validation_error", "Invalid request"


class TooManyJobs(Problem):
    status, code, title = 429, "too_many_jobs", "Too many unfinished jobs"


class TooManyStreams(Problem):
    status, code, title = 429, "too_many_streams", "Too many open streams"


class RequestTimeout(Problem):
    status, code, title = 408, "request_timeout", "The request body came too slowly"


class Damaged(Problem):
    """A stored file no longer matches its checksum: it is never served."""

    status, code, title = 500, "result_damaged", "The stored result is damaged"


class InsufficientStorage(Problem):
    status, code, title = 507, "disk_full", "Not enough space to store it"


class Unavailable(Problem):
    status, code, title = 503, "unavailable", "Service not ready"


def from_input_error(exc: InputError, *prefix: str | int) -> Invalid:
    """A meshcore input error as a 422, its locations under ``prefix``."""
    errors = [{**e, "loc": [*prefix, *e["loc"]]} for e in exc.errors]
    problem = Invalid(exc.message, errors=errors)
    problem.code = exc.code
    return problem


def _response(status: int, doc: dict, headers: dict[str, str] | None = None) -> JSONResponse:
    from fastapi.responses import JSONResponse

    return JSONResponse(doc, status_code=status, headers=headers, media_type=PROBLEM_MEDIA_TYPE)


def _jsonable_errors(errors: list[dict], body: Any) -> list[dict]:
    """Pydantic error entries without the parts that are not JSON (ctx objects, inputs).

    Locations are paths into the request as sent: pydantic's union member
    name (the method) is dropped from ``["body", METHOD, "params", ...]``,
    and a discriminated union's tag error is located at the tag field itself
    (``["body", "method"]``), not at the whole body.
    """
    method = body.get("method") if isinstance(body, dict) else None
    out = []
    for e in errors:
        loc, msg = list(e.get("loc", ())), str(e.get("msg", ""))
        if len(loc) > 1 and loc[0] == "body" and method is not None and loc[1] == method:
            del loc[1]
        if e.get("type") in ("union_tag_invalid", "union_tag_not_found"):
            tag = str(e.get("ctx", {}).get("discriminator", "")).strip("'\"")
            loc.append(tag)
            if e["type"] == "union_tag_invalid":
                ctx = e["ctx"]
                msg = (
                    f"unknown {tag} {ctx.get('tag')!r}; expected one of {ctx.get('expected_tags')}"
                )
        out.append({"loc": loc, "msg": msg, "type": e.get("type")})
    return out


def install_handlers(app: FastAPI) -> None:
    """Map every error the app can meet to a problem document."""
    from fastapi.exceptions import RequestValidationError
    from starlette.exceptions import HTTPException as StarletteHTTPException

    @app.exception_handler(Problem)
    async def _problem(_: Request, exc: Problem) -> JSONResponse:
        return _response(exc.status, exc.document(), exc.headers)

    @app.exception_handler(InputError)
    async def _input(_: Request, exc: InputError) -> JSONResponse:
        problem = from_input_error(exc)
        return _response(problem.status, problem.document())

    @app.exception_handler(MeshcoreError)
    async def _meshcore(_: Request, exc: MeshcoreError) -> JSONResponse:
        doc = problem_document(422, exc.code, "The input could not be processed", exc.message)
        return _response(422, doc)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        errors = _jsonable_errors(exc.errors(), exc.body)
        if any(e["type"] == "json_invalid" for e in errors):
            bad = BadRequest(
                "the request body is not valid JSON: " + errors[0]["msg"], errors=errors
            )
            return _response(400, bad.document())
        first = errors[0] if errors else {"loc": [], "msg": "invalid request"}
        where = ".".join(str(p) for p in first["loc"])
        detail = f"{where}: {first['msg']}" if where else first["msg"]
        if len(errors) > 1:
            detail += f" (and {len(errors) - 1} more)"
        return _response(422, Invalid(detail, errors=errors).document())

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        titles = {404: NotFound, 405: MethodNotAllowed}
        cls = titles.get(exc.status_code)
        if cls is not None:
            doc = cls(str(exc.detail)).document()
        else:
            doc = problem_document(exc.status_code, "http_error", str(exc.detail), str(exc.detail))
        return _response(exc.status_code, doc, dict(exc.headers or {}))

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unexpected error on %s %s", request.method, request.url.path)
        doc = Problem("An unexpected error occurred; it has been logged.").document()
        return _response(500, doc)
