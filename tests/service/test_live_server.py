"""The live-server fixture itself (tests/service/conftest.py): a test talks to its own server."""

from __future__ import annotations

import signal
import threading
from http.server import BaseHTTPRequestHandler, HTTPServer

from tests.service.conftest import LiveServer


class _Ready(BaseHTTPRequestHandler):
    """Answers 200 to every GET, as another test's server answers ``/readyz``."""

    def do_GET(self) -> None:
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args) -> None:
        pass


def test_a_server_whose_port_was_taken_starts_again_on_another(tmp_path):
    """``_free_port`` lets the port go before the server binds it; another process that
    took it meanwhile and answered ``/readyz`` was taken for the server, which exited
    unable to bind (a CI run's Dask test sent its jobs to another test's server)."""
    other = HTTPServer(("127.0.0.1", 0), _Ready)
    threading.Thread(target=other.serve_forever, daemon=True).start()
    server = LiveServer(tmp_path / "data")
    server.port = other.server_address[1]
    try:
        server.start()
        assert server.port != other.server_address[1]
        with server.client() as c:
            assert c.get("/readyz").json()["executor"] == "local"
    finally:
        other.shutdown()
        server.stop(signal.SIGKILL)
