"""Wire models: what clients send and what the API answers.

Input models reject NaN and infinities at parse time and carry the JSON
location of every fault; their numbers must be JSON numbers (:class:`InputModel`:
``true``/``false`` and strings are refused, not read as 1/0). The checks that need
numpy (indices in range, degenerate cells) run in :meth:`MethodParams.check`, which maps meshcore's
:class:`~meshcore.errors.InputError` locations under the params field.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, GetCoreSchemaHandler
from pydantic_core import PydanticCustomError, core_schema

from meshcore.errors import InputError
from meshcore.mesh import CELL_TYPES, Mesh, io

#: A method's progress callback: ``progress(fraction, message)``.
Progress = Callable[[float, str], None]

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Index = Annotated[int, Field(ge=0)]
Coordinates = Annotated[list[FiniteFloat], Field(min_length=2, max_length=3)]
CellType = Literal["vertex", "line", "triangle", "quad", "tetra", "pyramid", "wedge", "hexahedron"]
assert set(CellType.__args__) == set(CELL_TYPES)


def _json_integer(value: Any) -> Any:
    if type(value) is not int and type(value) is not float:  # bool is a subclass of int
        raise PydanticCustomError("int_type", "Input should be a valid integer (a JSON number)")
    return value


def _numbers_only(schema: Any) -> None:
    """Make every number of a core schema a JSON number, in place: a float strict (it still
    takes an integer), an integer refusing ``true``, ``false`` and strings (it still takes
    ``2.0``, as before)."""
    items = schema.items() if isinstance(schema, dict) else enumerate(schema)
    for key, value in list(items):
        if not isinstance(value, dict | list):
            continue
        kind = value.get("type") if isinstance(value, dict) else None
        if kind == "float":
            value["strict"] = True
        elif kind == "int":
            schema[key] = core_schema.no_info_before_validator_function(_json_integer, value)
        elif kind != "function-before" or value["function"]["function"] is not _json_integer:
            _numbers_only(value)


class InputModel(BaseModel):
    """Base of the input models: unknown fields refused, and every number a JSON number.

    pydantic's lax mode reads ``true`` as 1 in a number field; here ``true`` answers a 422
    naming the field, in this model and in any model or list nested in it.
    """

    model_config = ConfigDict(extra="forbid")

    @classmethod
    def __get_pydantic_core_schema__(
        cls, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        schema = handler(source)
        _numbers_only(schema)
        return schema


class CellBlockIn(InputModel):
    """One block of cells of one type (meshio's names and node order)."""

    type: CellType
    data: list[list[Index]] = Field(description="Point indices, one row per cell.")


class MeshIn(InputModel):
    """A mesh: points and typed cell blocks, with optional data and cell sets (meshio layout)."""

    points: list[Coordinates] = Field(min_length=1, description="[x, y] or [x, y, z] rows.")
    cells: list[CellBlockIn] = Field(min_length=1)
    point_data: dict[str, list[FiniteFloat | list[FiniteFloat]]] = Field(default_factory=dict)
    cell_data: dict[str, list[list[FiniteFloat | list[FiniteFloat]]]] = Field(
        default_factory=dict, description="Per name, one list of values per block."
    )
    cell_sets: dict[str, list[list[Index]]] = Field(
        default_factory=dict, description="Per name, the cell ids in each block."
    )

    def to_mesh(self) -> Mesh:
        """The checked meshcore mesh (raises InputError located inside this object)."""
        return io.from_json(self.model_dump())

    def point_count(self) -> int:
        return len(self.points)


class MethodParams(InputModel):
    """Base of every method's params: unknown fields are refused, numbers are JSON numbers."""

    def meshes(self) -> dict[str, MeshIn]:
        """The mesh-valued fields, by name."""
        return {k: v for k, v in self if isinstance(v, MeshIn)}

    def point_count(self) -> int:
        """Input points of the job, counted against ``MESHSERVICE_MAX_POINTS``.

        Sums ``point_count()`` over the fields (and items of list fields) that have one.
        """
        total = 0
        for _, value in self:
            for item in value if isinstance(value, list) else [value]:
                if hasattr(item, "point_count"):
                    total += item.point_count()
        return total

    def check(self) -> None:
        """Deep checks before the job is queued; InputError locations start at the field."""
        for name, mesh in self.meshes().items():
            try:
                mesh.to_mesh()
            except InputError as exc:
                raise exc.prefixed(name) from None


class ProgressOut(BaseModel):
    fraction: float = Field(ge=0, le=1)
    message: str


class ErrorItem(BaseModel):
    loc: list[str | int]
    msg: str
    type: str | None = None


class ProblemOut(BaseModel):
    """An RFC 9457 problem document."""

    type: str
    title: str
    status: int
    detail: str
    errors: list[ErrorItem] | None = None


class JobLinks(BaseModel):
    self: str
    result: str
    events: str
    cancel: str
    preview: str


JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobOut(BaseModel):
    """A job as the API shows it."""

    id: str
    method: str
    status: JobStatus
    attempt: int = Field(description="Runs started so far (restarts re-run a job).")
    progress: ProgressOut
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    error: ProblemOut | None
    links: JobLinks

    @classmethod
    def of(cls, job: Any) -> JobOut:
        base = f"/v1/jobs/{job.id}"

        def when(t: float | None) -> datetime | None:
            return None if t is None else datetime.fromtimestamp(t, UTC)

        return cls(
            id=job.id,
            method=job.method,
            status=job.status,
            attempt=job.attempt,
            progress=ProgressOut(fraction=job.progress_fraction, message=job.progress_message),
            created_at=when(job.created_at),
            started_at=when(job.started_at),
            finished_at=when(job.finished_at),
            error=job.error,
            links=JobLinks(
                self=base,
                result=f"{base}/result",
                events=f"{base}/events",
                cancel=f"{base}/cancel",
                preview=f"{base}/preview.svg",
            ),
        )


class JobPage(BaseModel):
    jobs: list[JobOut]
    next_page_token: str | None = Field(description="Pass as page_token for the next page.")


class MethodOut(BaseModel):
    name: str
    summary: str
    section: str = Field(description="Where the methods text describes it.")
    params_schema: dict[str, Any]
    example: dict[str, Any] = Field(description="A valid params object.")


class ResultOut(BaseModel):
    """A method's result: one object with fixed keys, those that apply present."""

    model_config = ConfigDict(extra="allow")

    mesh: dict[str, Any] | None = None
    quality: dict[str, Any] | None = None
    axis: dict[str, Any] | None = None
    domain: dict[str, Any] | None = None
    regions: list[Any] | None = None
    stats: dict[str, Any] | None = None
