"""Throwaway services for the benchmarks: a migrated PostgreSQL database, a Redis server.

Each lives for one ``with`` block and leaves nothing behind, so a benchmark never touches
the user's own database or broker. A benchmark stopped with SIGTERM (``kill``) unwinds as
on Ctrl-C while one is open, so a long run killed by hand drops its database too.
"""

from __future__ import annotations

import signal
import subprocess
import threading
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType

from sqlalchemy import text
from sqlalchemy.engine import make_url
from tenacity import Retrying, retry_if_exception_type, stop_after_delay, wait_fixed

from app.db.engines import make_engine
from app.db.migrations import alembic_config


@contextmanager
def scratch_database(server_url: str) -> Iterator[str]:
    """A fresh, migrated database on the PostgreSQL server of ``server_url``, then dropped."""
    from alembic import command

    url = make_url(server_url)
    name = f"srg_bench_{uuid.uuid4().hex[:8]}"
    admin = make_engine(
        url.set(database="postgres").render_as_string(False), isolation_level="AUTOCOMMIT"
    )
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    created = url.set(database=name).render_as_string(hide_password=False)
    engine = make_engine(created)
    with engine.begin() as connection:
        command.upgrade(alembic_config(connection), "head")
    engine.dispose()
    try:
        with _terminate_as_interrupt():
            yield created
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


@contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM raises KeyboardInterrupt in the main thread for the block (a signal handler
    can only be set there; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def scratch_redis(directory: Path) -> Iterator[str]:
    """A private ``redis-server`` on a free port (no persistence), stopped afterwards."""
    import socket

    import redis

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    process = subprocess.Popen(
        ["redis-server", "--port", str(port), "--save", "", "--dir", str(directory)],
        stdout=subprocess.DEVNULL,
    )
    try:
        Retrying(
            stop=stop_after_delay(5),
            wait=wait_fixed(0.1),
            retry=retry_if_exception_type(redis.RedisError),
            reraise=True,
        )(redis.Redis(port=port).ping)
        yield f"redis://127.0.0.1:{port}/0"
    finally:
        process.terminate()
        process.wait()
