"""ASGI middleware guarding the API against large bodies and slow or stalled clients.

:class:`BodySizeLimit` refuses request bodies over ``MESHSERVICE_MAX_BODY_BYTES``
(413): it checks ``Content-Length`` up front; a body without one (chunked) is
read up to the limit before the app sees it, so it cannot slip past.
:class:`ClientTimeouts` cuts off a client that sends its body too slowly
(408) or stops reading its response.
"""

from __future__ import annotations

import asyncio
import json
import logging

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.problems import PROBLEM_MEDIA_TYPE, RequestTimeout, TooLarge

log = logging.getLogger("meshservice.limits")


async def _send_problem(send: Send, status: int, doc: dict) -> None:
    """Answer a problem document and close the connection."""
    body = json.dumps(doc).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", PROBLEM_MEDIA_TYPE.encode()),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


class BodySizeLimit:
    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def _refuse(self, send: Send) -> None:
        doc = TooLarge(
            f"the request body is larger than {self.max_bytes} bytes (MESHSERVICE_MAX_BODY_BYTES)"
        ).document()
        await _send_problem(send, 413, doc)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope["headers"])
        length = headers.get(b"content-length")
        if length is not None and length.isdigit() and int(length) > self.max_bytes:
            await self._refuse(send)
            return
        if length is not None:
            await self.app(scope, receive, send)
            return
        # No length given (chunked): read the body up to the limit, then replay it.
        chunks, size, more = [], 0, True
        while more:
            message = await receive()
            if message["type"] != "http.request":
                await self.app(scope, receive, send)
                return
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > self.max_bytes:
                await self._refuse(send)
                return
            more = message.get("more_body", False)
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if replayed:
                return await receive()
            replayed = True
            return {"type": "http.request", "body": b"".join(chunks), "more_body": False}

        await self.app(scope, replay, send)


class _SlowBody(BaseException):
    """The request body did not arrive within the body timeout (not an app error)."""


class _StalledClient(BaseException):
    """The client stopped reading the response for longer than the send timeout."""


class ClientTimeouts:
    """ASGI middleware cutting off slow and stalled clients.

    A request body must arrive whole within ``body_timeout`` seconds
    (``MESHSERVICE_BODY_TIMEOUT``; 408 otherwise, connection closed), and a
    client that stops reading a response for ``send_timeout`` seconds
    (``MESHSERVICE_SEND_TIMEOUT``) is dropped. Both wait on the event loop
    without blocking it, and neither holds a worker. The two exceptions
    derive from ``BaseException`` so that no handler of the app turns them
    into a response of its own.
    """

    def __init__(self, app: ASGIApp, body_timeout: float, send_timeout: float) -> None:
        self.app = app
        self.body_timeout = body_timeout
        self.send_timeout = send_timeout

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.body_timeout
        body_done = scope["method"] in ("GET", "HEAD", "DELETE", "OPTIONS")
        started = False

        async def timed_receive() -> Message:
            nonlocal body_done
            if body_done:  # later calls wait for a disconnect: no deadline
                return await receive()
            try:
                message = await asyncio.wait_for(receive(), max(deadline - loop.time(), 0.0))
            except TimeoutError:
                raise _SlowBody from None
            if message["type"] != "http.request" or not message.get("more_body", False):
                body_done = True
            return message

        async def timed_send(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            try:
                await asyncio.wait_for(send(message), self.send_timeout)
            except TimeoutError:
                raise _StalledClient from None

        client = scope.get("client")
        try:
            await self.app(scope, timed_receive, timed_send)
        except _SlowBody:
            log.warning(
                "%s: request body not received within %g s (MESHSERVICE_BODY_TIMEOUT): cut off",
                client,
                self.body_timeout,
            )
            if not started:
                doc = RequestTimeout(
                    f"the request body did not arrive within {self.body_timeout:g} s "
                    "(MESHSERVICE_BODY_TIMEOUT)"
                ).document()
                await _send_problem(send, 408, doc)
        except _StalledClient:
            log.warning(
                "%s: did not read the response for %g s (MESHSERVICE_SEND_TIMEOUT): dropped",
                client,
                self.send_timeout,
            )
