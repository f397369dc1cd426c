"""Run the API on a free loopback port in a background thread, for benches and tests.

The socket is bound here (port 0, so the OS picks a free port) and handed to uvicorn,
so there is no window in which another process can take the port.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import uvicorn
from fastapi import FastAPI

from app.api.serving import UVICORN_OPTIONS

LOOPBACK = "127.0.0.1"


@contextmanager
def serve_in_thread(app: FastAPI, *, startup_timeout: float = 15.0) -> Iterator[str]:
    """Yield the base URL of ``app`` served on loopback; stop the server on exit."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.bind((LOOPBACK, 0))
    port = sock.getsockname()[1]
    config = uvicorn.Config(app, log_level="warning", access_log=False, **UVICORN_OPTIONS)
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + startup_timeout
        while not server.started:
            if not thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("the API server did not start")
            time.sleep(0.01)
        yield f"http://{LOOPBACK}:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=startup_timeout)
        sock.close()
