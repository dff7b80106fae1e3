"""``Annotated`` dependencies shared by the routers."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from service.jobs import JobManager
from service.problems import NotFound, Unauthorized
from service.settings import Settings
from service.store import Job, Store

_bearer = HTTPBearer(auto_error=False, description="An API key from MESHSERVICE_API_KEYS.")


def _settings(request: Request) -> Settings:
    return request.app.state.settings


def _manager(request: Request) -> JobManager:
    return request.app.state.manager


def _store(request: Request) -> Store:
    return request.app.state.manager.store


def _client(
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


SettingsDep = Annotated[Settings, Depends(_settings)]
ManagerDep = Annotated[JobManager, Depends(_manager)]
StoreDep = Annotated[Store, Depends(_store)]
ClientDep = Annotated[str, Depends(_client)]


def _job(job_id: str, store: StoreDep, client: ClientDep) -> Job:
    """The caller's job; another client's job is as absent as a missing one."""
    job = store.get(job_id, client)
    if job is None:
        raise NotFound(f"no job {job_id!r}")
    return job


JobDep = Annotated[Job, Depends(_job)]
