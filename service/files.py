"""File downloads that survive the file's removal once the answer has begun.

:class:`~starlette.responses.FileResponse` opens its path only while it
sends: a DELETE or an expiry in between turns the download into a 500. Here
the file is opened when the response is made (a missing file raises
:class:`FileNotFoundError`, which the route turns into a 404 or a 410); an
open file stays readable after its name is removed.
"""

from __future__ import annotations

import os
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
from starlette.responses import FileResponse


class OpenedFileResponse(FileResponse):
    """A :class:`FileResponse` of a file opened up front (FileNotFoundError when it is gone)."""

    def __init__(self, path: Path, **kwargs) -> None:
        self._file = open(path, "rb")  # noqa: SIM115 (closed when sent, or by the collector)
        super().__init__(path, stat_result=os.fstat(self._file.fileno()), **kwargs)

    @asynccontextmanager
    async def _open_file(self) -> AsyncIterator[anyio.AsyncFile[bytes]]:
        file = anyio.wrap_file(self._file)
        try:
            yield file
        finally:
            with anyio.CancelScope(shield=True):
                await file.aclose()
