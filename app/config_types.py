"""The kinds of value a setting holds beyond a bounded number: URLs of the services srg
can use, rate limits, web origins, directories (:mod:`app.config` declares its fields
with them).

Each is a ``str`` checked as it is read, so a bad value is one line naming its variable
(``SRG_DATABASE_URL: ...``) before a command or a server starts work, not a traceback or
a limit silently taken. A URL's message never repeats it: it may hold a password.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Annotated
from urllib.parse import urlsplit

from pydantic import AfterValidator

DAY = 24 * 3600
#: bodies and per-process caches: far above any sane value, far below a machine's memory
GIB, MIB_PER_TIB = 1 << 30, 1 << 20
#: the databases srg runs on, each as SQLAlchemy names it with its driver (psycopg 3 is
#: SQLAlchemy's default driver of ``postgresql://``); ``mysql://`` names a dialect
#: SQLAlchemy knows but no driver srg installs
POSTGRESQL_SCHEMES = frozenset(["postgresql", "postgresql+psycopg"])
DATABASE_SCHEMES = POSTGRESQL_SCHEMES | {"sqlite", "sqlite+pysqlite"}
REDIS_SCHEMES = frozenset(["redis", "rediss", "unix"])
#: the brokers Celery can use here: kombu's transports whose client library srg installs,
#: Redis (``redis+socket``: on a Unix socket; ``sentinel``: through Redis Sentinel) and
#: RabbitMQ's AMQP. Any other URL is refused: kombu reads ``notaurl`` as the name of an
#: AMQP host, ``http://`` fails at the first task sent, and ``memory://`` (Celery's own
#: broker of eager runs) is one process's queue, which no worker reads
BROKER_SCHEMES = frozenset(
    ["redis", "rediss", "redis+socket", "sentinel", "amqp", "amqps", "pyamqp"]
)
#: one limit of the ``limits`` notation (its parser's grammar) with a count of at least 1
#: and the optional multiple of the period at least 1: ``limits`` itself takes "0/minute",
#: a limit that refuses every request
_RATE = re.compile(
    r"\s*0*[1-9][0-9]*\s*(?:/|\s*per\s*)\s*(?:0*[1-9][0-9]*\s*)?"
    r"(?:second|minute|hour|day|month|year)s?\s*",
    re.IGNORECASE,
)


def _url_of(schemes: frozenset[str], *, optional: bool) -> Callable[[str], str]:
    def check(value: str) -> str:
        scheme, separator, _ = value.partition("://")
        if (value or not optional) and not (separator and scheme.lower() in schemes):
            listed = ", ".join(f"{scheme}://" for scheme in sorted(schemes))
            raise ValueError(f"must start with one of {listed} (the value is not shown)")
        return value

    return check


_broker_scheme = _url_of(BROKER_SCHEMES, optional=True)


def _broker_url(value: str) -> str:
    """A broker of :data:`BROKER_SCHEMES`; a ``rediss://`` one says how the server's
    certificate is checked, or Celery refuses it as its result backend (the broker's URL
    unless ``SRG_RESULT_BACKEND`` names another), once a worker has started."""
    _broker_scheme(value)
    if value.lower().startswith("rediss://") and "ssl_cert_reqs=" not in urlsplit(value).query:
        raise ValueError(
            "a rediss:// URL must set ssl_cert_reqs (?ssl_cert_reqs=required, optional or "
            "none) (the value is not shown)"
        )
    return value


def _directory_or_absent(value: Path) -> Path:
    """A directory srg may make: refused when a file already sits at the path (or on the
    way to it), which would otherwise fail later in ``mkdir`` without the setting's name."""
    existing = next((p for p in (value, *value.parents) if p.exists()), None)
    if existing is not None and not existing.is_dir():
        raise ValueError(f"{value} is not a directory: {existing} is a file")
    return value


def _rates(value: str) -> str:
    if not all(_RATE.fullmatch(part) for part in re.split(r"[,;|]", value)):
        raise ValueError(
            "each limit must be COUNT/PERIOD with a count of at least 1 and a period of "
            "second, minute, hour, day, month or year ('600/minute', '10/second;600/minute')"
        )
    return value


def _web_origins(value: str) -> str:
    """A browser's ``Origin`` is scheme://host[:port] and is matched as a string: an entry
    with a path, a user or another scheme (``javascript:``) would never match one."""
    origins = [origin.strip() for origin in value.split(",") if origin.strip()]
    for origin in origins:
        if origin != "*" and not _is_web_origin(origin):
            raise ValueError(
                "each origin must be http(s)://host[:port] with nothing after it, or '*'"
            )
    return ",".join(origins)


def _is_web_origin(origin: str) -> bool:
    try:
        parts = urlsplit(origin)
        parts.port  # noqa: B018 -- raises ValueError for a port that is not one
    except ValueError:
        return False
    return (
        parts.scheme in ("http", "https")
        and bool(parts.hostname)
        and "@" not in parts.netloc
        and origin == f"{parts.scheme}://{parts.netloc}"
    )


#: a database URL, or '' for the embedded SQLite file
DatabaseURL = Annotated[str, AfterValidator(_url_of(DATABASE_SCHEMES, optional=True))]
PostgresURL = Annotated[str, AfterValidator(_url_of(POSTGRESQL_SCHEMES, optional=False))]
#: a Celery broker URL, or '' for none (tasks then run eagerly)
BrokerURL = Annotated[str, AfterValidator(_broker_url)]
#: a Redis URL, or '' for none
RedisURL = Annotated[str, AfterValidator(_url_of(REDIS_SCHEMES, optional=True))]
#: a directory, made on first use (refused where a file is in the way)
DirectoryPath = Annotated[Path, AfterValidator(_directory_or_absent)]
#: limits in the ``limits`` notation, each of at least one request per period
RateLimits = Annotated[str, AfterValidator(_rates)]
#: comma-separated http(s) origins, or '*'; '' for none
WebOrigins = Annotated[str, AfterValidator(_web_origins)]
