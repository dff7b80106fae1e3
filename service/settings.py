"""Service settings, read from ``MESHSERVICE_*`` environment variables.

Every field has an embedded default, so ``meshservice serve`` runs with no
configuration at all on 127.0.0.1:8000 with data in ``./var``. The class
refuses unsafe combinations at start-up: a bind address beyond loopback
without API keys.
"""

from __future__ import annotations

import ipaddress
import os
from functools import cached_property
from pathlib import Path

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from meshcore.mesh.formats import FORMATS


def _default_memory_limit() -> int:
    """Half the machine's memory: one job must not take the whole machine down."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError):
        total = 8 << 30
    return max(total // 2, 2 << 30)


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Settings(BaseSettings):
    """The service's settings; see the README's settings table."""

    model_config = SettingsConfigDict(env_prefix="MESHSERVICE_", frozen=True, extra="ignore")

    host: str = Field("127.0.0.1", description="Address to bind.")
    port: int = Field(8000, ge=0, le=65535, description="Port to bind (0: any free port).")
    data_dir: Path = Field(
        Path("var"), description="Job store, result files and the warm-up's status (warmup/)."
    )
    workers: int = Field(
        default_factory=lambda: os.cpu_count() or 1, ge=1, description="Jobs run at once."
    )
    job_time_limit: float = Field(600.0, gt=0, description="Wall-clock seconds per job.")
    job_memory_limit: int = Field(
        default_factory=_default_memory_limit,
        ge=256 << 20,
        description="Address-space limit of a job's process, in bytes.",
    )
    max_body_bytes: int = Field(64 << 20, ge=1024, description="Largest request body.")
    max_points: int = Field(5_000_000, ge=1, description="Most input points per job.")
    max_queued: int = Field(100, ge=1, description="Most unfinished jobs per client.")
    max_attempts: int = Field(3, ge=1, description="Runs of a job interrupted by restarts.")
    max_streams: int = Field(
        256, ge=1, description="Most open event streams and long-polls per client."
    )
    body_timeout: float = Field(
        60.0, gt=0, description="Seconds a client may take to send its whole request body."
    )
    keep_alive: float = Field(
        30.0,
        gt=0,
        description="Seconds an idle connection is kept open; above the usual client pool "
        "expiry (httpx: 5 s), so a client never reuses a connection the service is closing.",
    )
    send_timeout: float = Field(
        60.0, gt=0, description="Seconds a response may wait for a client that does not read."
    )
    retention: float = Field(
        7 * 24 * 3600.0,
        gt=0,
        description="Seconds a finished job's result is kept; the job record is kept "
        "as long again (its result then answers 410).",
    )
    dask_scheduler: str | None = Field(
        None, description="A dask.distributed scheduler address: run jobs on its workers."
    )
    durable: bool = Field(
        False,
        description="fsync every file and SQLite commit: jobs and results survive a power "
        "loss, not only a crash of the service (about 15 ms more per file written).",
    )
    warmup: bool = Field(
        True,
        description="Load every numba kernel into the job fork server before the first job "
        "runs; false: the port is ready at once and each job loads the kernels it uses.",
    )
    job_formats: str = Field(
        "vtu",
        description="Comma-separated download formats a job writes itself when it finishes "
        "(others are written on their first request).",
    )
    api_keys: str = Field("", description="Comma-separated key:client pairs.")
    metrics_token: str = Field(
        "", description="Bearer token of /metrics; with API keys set, /metrics needs it."
    )
    cors_origins: str = Field("", description="Comma-separated web origins allowed.")

    @field_validator("api_keys")
    @classmethod
    def _keys_are_pairs(cls, value: str) -> str:
        for pair in filter(None, (p.strip() for p in value.split(","))):
            key, sep, client = pair.partition(":")
            if not sep or not key or not client:
                raise ValueError(f"API key entry {pair!r} is not of the form key:client")
        return value

    @field_validator("job_formats")
    @classmethod
    def _known_formats(cls, value: str) -> str:
        unknown = [f for f in _split(value) if f not in FORMATS]
        if unknown:
            raise ValueError(
                f"unknown job format(s) {', '.join(unknown)}; choose among {', '.join(FORMATS)}"
            )
        return value

    @model_validator(mode="after")
    def _no_public_bind_without_keys(self) -> Settings:
        if not self.api_keys and not _is_loopback(self.host):
            raise ValueError(
                f"refusing to listen on {self.host} without API keys: "
                "set MESHSERVICE_API_KEYS or bind a loopback address"
            )
        return self

    @cached_property
    def clients_by_key(self) -> dict[str, str]:
        """API key -> client name (empty: no authentication)."""
        pairs = (p.strip().partition(":") for p in self.api_keys.split(",") if p.strip())
        return {key: client for key, _, client in pairs}

    @cached_property
    def cors_origin_list(self) -> list[str]:
        return _split(self.cors_origins)

    @cached_property
    def formats(self) -> tuple[str, ...]:
        """The downloads a job writes itself."""
        return tuple(_split(self.job_formats))


def _split(value: str) -> list[str]:
    return [v.strip() for v in value.split(",") if v.strip()]
