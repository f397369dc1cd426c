"""``SRG_BROKER_URL`` names a broker Celery can use here, or every command says so in one line.

The finding: any string was taken. ``srg worker`` then ended in kombu's traceback
(``http://``: no such transport), and ``notaurl`` was quietly read as the name of an AMQP
host that a worker waited for.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from cli_helpers import SRG, one_line_error, srg

from app.config import Settings
from app.tasks.celery_app import make_celery

NO_SCHEME = "must start with one of amqp://"
#: each refused URL, and what its line says
REFUSED = [
    ("notaurl", NO_SCHEME),
    ("http://127.0.0.1:1/", NO_SCHEME),
    ("bogus://nowhere", NO_SCHEME),
    ("memory://", NO_SCHEME),
    # Celery takes no rediss:// result backend without it (the broker's URL is that backend)
    ("rediss://127.0.0.1:1/0", "a rediss:// URL must set ssl_cert_reqs"),
]


@pytest.mark.parametrize(("url", "says"), [REFUSED[0], REFUSED[1], REFUSED[4]])
def test_the_worker_says_a_bad_broker_url_in_one_line(tmp_path: Path, url: str, says: str) -> None:
    """The console script, as an operator starts it: the broker is read as Celery starts."""
    environment = {
        **{k: v for k, v in os.environ.items() if not k.startswith("SRG_")},
        "SRG_VAR_DIR": str(tmp_path),
        "SRG_BROKER_URL": url,
    }
    done = subprocess.run(
        [str(SRG), "worker"], capture_output=True, text=True, env=environment, timeout=120
    )
    one_line_error(done, "SRG_BROKER_URL: ")
    assert says in done.stderr and url not in done.stderr  # a URL may hold a password


@pytest.mark.parametrize(("url", "says"), REFUSED)
@pytest.mark.parametrize("command", [["grow-epoch", "g"], ["status"]])
def test_every_command_says_a_bad_broker_url_in_one_line(
    tmp_path: Path, command: list[str], url: str, says: str
) -> None:
    """Read with the settings, so a command that never sends work refuses it too."""
    done = srg(tmp_path, *command, SRG_BROKER_URL=url)
    one_line_error(done, "SRG_BROKER_URL: ")
    assert says in done.stderr and url not in done.stderr


@pytest.mark.parametrize(
    "url",
    [
        "",
        "redis://127.0.0.1:6379/0",
        "rediss://:secret@cache.example:6380/0?ssl_cert_reqs=required",
        "redis+socket:///run/redis.sock",
        "sentinel://127.0.0.1:26379;sentinel://127.0.0.1:26380",
        "amqp://guest:guest@127.0.0.1:5672//",
        "pyamqp://127.0.0.1//",
    ],
)
def test_the_brokers_celery_can_use_here_are_taken(url: str) -> None:
    """Taken, and usable: Celery finds the transport and a result backend for each (an
    AMQP broker's results come back over it, Celery 5 having no ``amqp`` backend)."""
    settings = Settings().replace(broker_url=url)
    assert settings.broker_url == url
    workers = make_celery(settings)
    assert workers.backend is not None
    with workers.connection_for_write() as connection:
        assert connection.transport is not None
