"""Slow senders and clients that stop reading are cut off without holding the service."""

from __future__ import annotations

import socket
import time

import httpx

from tests.service.test_jobs import submit


def _connect(server) -> socket.socket:
    return socket.create_connection(("127.0.0.1", server.port), timeout=30)


def test_a_body_sent_a_byte_a_second_is_cut_off(start_server):
    server = start_server(MESHSERVICE_BODY_TIMEOUT="2")
    body = b'{"method": "sleep", "params": {"seconds": 0}}'
    with _connect(server) as s:
        s.sendall(
            b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Content-Length: %d\r\n\r\n" % len(body)
        )
        start = time.monotonic()
        answer = b""
        for byte in body:
            try:
                s.sendall(bytes([byte]))
            except OSError:
                break
            s.settimeout(1.0)
            try:
                answer += s.recv(65536)
            except TimeoutError:
                continue
            if answer:
                break
        s.settimeout(5.0)
        try:  # the rest of the answer, until the server closes (a reset: unread body bytes)
            while chunk := s.recv(65536):
                answer += chunk
        except ConnectionResetError:
            pass
        elapsed = time.monotonic() - start
    assert answer.startswith(b"HTTP/1.1 408"), answer[:200]
    assert b"MESHSERVICE_BODY_TIMEOUT" in answer
    assert elapsed < 10
    with server.client() as c:  # and the service still serves
        assert c.get("/healthz").status_code == 200


def test_a_client_that_never_reads_is_dropped(start_server):
    server = start_server(MESHSERVICE_SEND_TIMEOUT="1")
    with server.client() as c:
        job = submit(c, "blob", {"megabytes": 40}, wait=30).json()
        assert job["status"] == "succeeded"
    with _connect(server) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.sendall(f"GET /v1/jobs/{job['id']}/result HTTP/1.1\r\nHost: x\r\n\r\n".encode())
        # never read: meanwhile the service answers others at once
        with server.client() as c:
            start = time.monotonic()
            for _ in range(20):
                assert c.get(f"/v1/jobs/{job['id']}").status_code == 200
            assert time.monotonic() - start < 5
        deadline = time.monotonic() + 20
        while "did not read the response" not in server.log.read_text():
            assert time.monotonic() < deadline, server.log.read_text()[-2000:]
            time.sleep(0.2)


def test_streams_beyond_the_limit_answer_429(start_server):
    server = start_server(MESHSERVICE_MAX_STREAMS="2")
    with server.client() as c:
        job = submit(c, "sleep", {"seconds": 30}).json()["id"]
        url = f"{server.url}/v1/jobs/{job}/events"
        with (
            httpx.stream("GET", url, timeout=30) as one,
            httpx.stream("GET", url, timeout=30) as two,
        ):
            assert one.status_code == two.status_code == 200
            time.sleep(0.3)
            third = c.get(f"/v1/jobs/{job}/events")
            assert third.status_code == 429 and third.headers["retry-after"]
            assert "MESHSERVICE_MAX_STREAMS" in third.json()["detail"]
            poll = c.get(f"/v1/jobs/{job}", params={"wait": 1})
            assert poll.status_code == 429
        deadline = time.monotonic() + 20  # both closed: the slots come back
        while c.get(f"/v1/jobs/{job}", params={"wait": 0.2}).status_code == 429:
            assert time.monotonic() < deadline, "closed streams kept their slots"
            time.sleep(0.2)
        c.post(f"/v1/jobs/{job}/cancel")
