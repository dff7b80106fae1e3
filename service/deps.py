"""``Annotated`` dependencies shared by the routers.

They are coroutines: FastAPI runs a plain ``def`` dependency in its thread
pool, a hop per dependency per request that costs more than the dependency
itself under load.
"""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from service.jobs import JobManager
from service.problems import NotFound, Unauthorized
from service.settings import Settings
from service.store import Job, Store

_bearer = HTTPBearer(auto_error=False, description="An API key from MESHSERVICE_API_KEYS.")
_metrics_bearer = HTTPBearer(
    auto_error=False, scheme_name="MetricsToken", description="MESHSERVICE_METRICS_TOKEN."
)


async def _settings(request: Request) -> Settings:
    return request.app.state.settings


async def _manager(request: Request) -> JobManager:
    return request.app.state.manager


async def _store(request: Request) -> Store:
    return request.app.state.manager.store


async def _client(
    settings: Annotated[Settings, Depends(_settings)],
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
) -> str:
    """The calling client: from its API key, or ``anonymous`` when keys are off."""
    clients = settings.clients_by_key
    if not clients:
        return "anonymous"
    if credentials is None:
        raise Unauthorized("send an API key as 'Authorization: Bearer KEY'")
    client = clients.get(credentials.credentials)
    if client is None:
        raise Unauthorized("the API key is not valid")
    return client


async def authenticated(client: Annotated[str, Depends(_client)]) -> None:
    """A route dependency: the caller must send a valid API key when keys are set."""


async def metrics_access(
    settings: Annotated[Settings, Depends(_settings)],
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_metrics_bearer)],
) -> None:
    """``/metrics`` is open without API keys; with keys, it needs ``MESHSERVICE_METRICS_TOKEN``."""
    if not settings.clients_by_key and not settings.metrics_token:
        return
    if not settings.metrics_token:
        raise Unauthorized("with API keys set, /metrics needs MESHSERVICE_METRICS_TOKEN to be set")
    if credentials is None or not hmac.compare_digest(
        credentials.credentials, settings.metrics_token
    ):
        raise Unauthorized("send the metrics token as 'Authorization: Bearer TOKEN'")


SettingsDep = Annotated[Settings, Depends(_settings)]
ManagerDep = Annotated[JobManager, Depends(_manager)]
StoreDep = Annotated[Store, Depends(_store)]
ClientDep = Annotated[str, Depends(_client)]


async def _job(job_id: str, store: StoreDep, client: ClientDep) -> Job:
    """The caller's job; another client's job is as absent as a missing one."""
    job = store.get(job_id, client)
    if job is None:
        raise NotFound(f"no job {job_id!r}")
    return job


JobDep = Annotated[Job, Depends(_job)]
