"""A small Python client of the meshservice API, on httpx.

    from service.client import MeshClient
    with MeshClient("http://127.0.0.1:8000", key="...") as api:
        job = api.submit("quality", {"mesh": mesh}, wait=10)
        for event, state in api.events(job["id"]):
            print(event, state["progress"])
        api.download(job["id"], "vtu", "out.vtu")

Transient failures are retried with exponential backoff: connection
errors, and 429 / 503 answers (honouring ``Retry-After``). Every other
error answer raises :class:`ServiceError` carrying the problem document.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx

RETRY_STATUSES = (429, 502, 503, 504)


class ServiceError(Exception):
    """The service answered with a problem document, or could not be reached."""

    def __init__(self, message: str, problem: dict | None = None) -> None:
        super().__init__(message)
        self.problem = problem or {}


class SubmittedJob(dict):
    """A job as the submission answered it; ``replayed`` when its key was seen before."""

    replayed: bool = False


class MeshClient:
    """The jobs API of one service, for one API key."""

    def __init__(
        self,
        url: str = "http://127.0.0.1:8000",
        key: str | None = None,
        *,
        timeout: float = 60.0,
        retries: int = 5,
        backoff: float = 0.25,
    ) -> None:
        headers = {"Authorization": f"Bearer {key}"} if key else {}
        self.url = url.rstrip("/")
        self.retries = retries
        self.backoff = backoff
        self._http = httpx.Client(base_url=self.url, headers=headers, timeout=timeout)

    def __enter__(self) -> MeshClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def _request(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        """One call, retried on transient failures; raises ServiceError on a problem."""
        for attempt in range(self.retries + 1):
            delay = self.backoff * 2**attempt
            try:
                response = self._http.request(method, path, **kwargs)
            except httpx.TransportError as exc:
                if attempt == self.retries:
                    raise ServiceError(f"cannot reach {self.url}: {exc}") from None
            else:
                if response.status_code not in RETRY_STATUSES or attempt == self.retries:
                    break
                retry_after = response.headers.get("retry-after", "")
                delay = float(retry_after) if retry_after.isdigit() else delay
            time.sleep(min(delay, 30.0))
        if response.status_code >= 400:
            try:
                problem = response.json()
            except ValueError:
                problem = {"status": response.status_code, "detail": response.text}
            detail = problem.get("detail") or problem.get("title") or response.reason_phrase
            raise ServiceError(f"{response.status_code}: {detail}", problem)
        return response

    def health(self) -> dict:
        """The service's liveness answer (raises ServiceError when it cannot be reached)."""
        return self._request("GET", "/healthz").json()

    def submit(
        self,
        method: str,
        params: dict,
        *,
        idempotency_key: str | None = None,
        wait: float = 0,
    ) -> SubmittedJob:
        """Submit a job; the same ``idempotency_key`` again returns the first job."""
        headers = {"Idempotency-Key": idempotency_key} if idempotency_key else {}
        query = {"wait": wait} if wait else {}
        body = {"method": method, "params": params}
        response = self._request("POST", "/v1/jobs", json=body, headers=headers, params=query)
        job = SubmittedJob(response.json())
        job.replayed = response.headers.get("idempotent-replayed") == "true"
        return job

    def job(self, job_id: str, *, wait: float = 0) -> dict:
        query = {"wait": wait} if wait else {}
        return self._request("GET", f"/v1/jobs/{job_id}", params=query).json()

    def jobs(self, page_size: int = 50) -> Iterator[dict]:
        """Every job of this client, newest first, page by page."""
        token = None
        while True:
            query = {"page_size": page_size, **({"page_token": token} if token else {})}
            page = self._request("GET", "/v1/jobs", params=query).json()
            yield from page["jobs"]
            token = page["next_page_token"]
            if token is None:
                return

    def cancel(self, job_id: str) -> dict:
        return self._request("POST", f"/v1/jobs/{job_id}/cancel").json()

    def events(self, job_id: str) -> Iterator[tuple[str, dict]]:
        """``(event, job)`` pairs from the job's event stream, until its ``end`` event."""
        with self._http.stream("GET", f"/v1/jobs/{job_id}/events", timeout=None) as response:
            if response.status_code >= 400:
                response.read()
                problem = response.json()
                raise ServiceError(f"{response.status_code}: {problem.get('detail')}", problem)
            event = "message"
            for line in response.iter_lines():
                if line.startswith("event:"):
                    event = line.partition(":")[2].strip()
                elif line.startswith("data:"):
                    yield event, json.loads(line.partition(":")[2])
                    if event == "end":
                        return

    def result(self, job_id: str) -> dict:
        return self._request("GET", f"/v1/jobs/{job_id}/result").json()

    def download(self, job_id: str, fmt: str, path: str | Path) -> Path:
        """Write the job's mesh in format ``fmt`` to ``path``."""
        response = self._request("GET", f"/v1/jobs/{job_id}/result", params={"format": fmt})
        path = Path(path)
        path.write_bytes(response.content)
        return path
