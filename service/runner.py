"""The job function: a method name plus JSON params in, the result's files out.

It is the same function for every executor: it runs inside the job's own
process (locally, or on a distributed worker), knows nothing of the store,
and turns every failure into :class:`JobFailed` carrying a problem document.
"""

from __future__ import annotations

import json
import logging
import traceback
from typing import Any

import numpy as np
from pydantic import ValidationError

from meshcore.errors import AlgorithmError, InputError, MeshcoreError
from meshcore.mesh import Mesh, io
from service.methods.domain_schema import DomainIn, unpack
from service.methods.registry import MethodSpec, Progress
from service.problems import problem_document

log = logging.getLogger("meshservice.job")


class JobFailed(Exception):
    """A job ended without a result; ``problem`` says why (RFC 9457 document)."""

    def __init__(self, problem: dict) -> None:
        super().__init__(problem)  # args carry the problem, so the error pickles whole
        self.problem = problem

    def __str__(self) -> str:
        return str(self.problem.get("detail", ""))


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mesh):
        return io.to_json(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def encode_result(result: dict) -> bytes:
    """Result JSON bytes; meshes in the DESIGN.md mesh shape, arrays as lists."""
    return json.dumps(result, default=_jsonable, allow_nan=False, separators=(",", ":")).encode()


def failure(exc: BaseException, method: str) -> dict:
    """The problem document for an exception raised by a job."""
    if isinstance(exc, InputError):
        errors = [{**e, "loc": ["params", *e["loc"]]} for e in exc.errors]
        return problem_document(422, exc.code, "Invalid input", exc.message, errors)
    if isinstance(exc, ValidationError):
        errors = [
            {"loc": ["params", *e["loc"]], "msg": e["msg"], "type": e["type"]} for e in exc.errors()
        ]
        return problem_document(422, "validation_error", "Invalid input", str(exc), errors)
    if isinstance(exc, AlgorithmError):
        return problem_document(422, exc.code, "The method could not finish", exc.message)
    if isinstance(exc, MeshcoreError):
        return problem_document(422, exc.code, "The method stopped", exc.message)
    if isinstance(exc, MemoryError):
        return problem_document(
            507, "out_of_memory", "Out of memory", "the job ran out of its memory limit"
        )
    return problem_document(
        500,
        "internal_error",
        "Internal error",
        f"method {method!r} failed unexpectedly ({type(exc).__name__}); it has been logged",
    )


def result_files(result: dict, formats: tuple[str, ...] = ()) -> dict[str, bytes]:
    """A finished job's files, by store name (see :mod:`service.downloads`).

    ``json``: the result; for a result holding a mesh, also ``npz`` (its
    arrays), ``meta.json`` (the result without the mesh) and the mesh in each
    of ``formats`` that can hold it.
    """
    files = {"json": encode_result(result)}
    mesh = result.get("mesh")
    if isinstance(mesh, Mesh):
        files["npz"] = io.to_npz(mesh)
        files["meta.json"] = encode_result({k: v for k, v in result.items() if k != "mesh"})
        for fmt in formats:
            try:
                files[fmt] = io.to_bytes(mesh, fmt)
            except InputError:  # the format cannot hold this mesh: its request answers 422
                pass
    return files


def _under_domain(exc: InputError, params) -> InputError:
    """A meshcore error located on a domain's geometry (``["coordinates", ring, vertex]``,
    ``["segments", i]``) placed under the params' domain field, when they have one."""
    if params is None or exc.errors[0]["loc"][:1] not in (["coordinates"], ["segments"]):
        return exc
    fields = [name for name, value in params if isinstance(value, DomainIn)]
    return exc.prefixed(fields[0]) if len(fields) == 1 else exc


def run_job(
    spec: MethodSpec,
    params_json: bytes,
    progress: Progress,
    formats: tuple[str, ...] = (),
    arrays: bytes = b"",
) -> dict[str, bytes]:
    """Validate the params, run the method, and encode its result as :func:`result_files`.

    ``arrays`` (:func:`service.methods.domain_schema.pack`) holds the
    coordinates the params refer to and the domains the submit validated:
    the job uses them as they are, without parsing or checking them again.

    Raises
    ------
    JobFailed
        for any failure, with the problem document of :func:`failure`; an
        unexpected exception is also logged with its traceback.
    """
    params = None
    try:
        params = spec.params.model_validate_json(params_json, context=unpack(arrays) or None)
        return result_files(spec.run(params, progress), formats)
    except InputError as exc:
        raise JobFailed(failure(_under_domain(exc, params), spec.name)) from None
    except (MeshcoreError, ValidationError, MemoryError) as exc:
        raise JobFailed(failure(exc, spec.name)) from None
    except Exception as exc:
        log.error("job of method %r failed:\n%s", spec.name, traceback.format_exc())
        raise JobFailed(failure(exc, spec.name)) from None
