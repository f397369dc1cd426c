"""``srg db upgrade|downgrade``: the database schema, by Alembic's migrations.

A migration that would lose stored rows or values changes nothing and says what it would
lose (:mod:`app.db.data_loss`), unless ``--drop-data`` says to lose them.
"""

from __future__ import annotations

import logging

import typer

from app.core.errors import InvalidInput

app = typer.Typer(help="The database schema (Alembic migrations).", no_args_is_help=True)

DROP_DATA_HELP = "migrate even where that loses stored rows or column values (named when refused)"


class RevisionError(InvalidInput):
    """Alembic refused the revision asked for (unknown, or not reachable that way)."""


def migrate(direction: str, revision: str, *, drop_data: bool) -> None:
    """``alembic upgrade|downgrade revision`` on the configured database, errors in one line.

    Alembic says each revision it runs on stderr, as the ``alembic`` command does with the
    logging of ``alembic.ini`` (which an installed srg has not).
    """
    from alembic.util import CommandError

    from alembic import command
    from app.config import get_settings
    from app.db.data_loss import DataLoss
    from app.db.engines import parse_database_url
    from app.db.migrations import alembic_config

    parse_database_url(get_settings().resolved_database_url)  # one line, before Alembic
    logging.basicConfig(format="%(levelname)-5.5s [%(name)s] %(message)s")
    logging.getLogger("alembic").setLevel(logging.INFO)
    for handler in logging.getLogger().handlers:
        handler.addFilter(_revisions_run)
    try:
        getattr(command, direction)(alembic_config(drop_data=drop_data), revision)
    except CommandError as exc:
        raise RevisionError(f"cannot {direction} to {revision!r}: {exc}".splitlines()[0]) from None
    except DataLoss as exc:
        raise DataLoss(
            f"cannot {direction} to {revision!r}: {exc} (--drop-data loses them)"
        ) from None


def _revisions_run(record: logging.LogRecord) -> bool:
    """Of Alembic's lines, only the revisions it runs: its set-up lines would come before
    an unknown revision's one-line error."""
    return not record.name.startswith("alembic") or record.getMessage().startswith("Running ")


@app.command("upgrade")
def upgrade(
    revision: str = typer.Argument("head", help="target revision"),
    drop_data: bool = typer.Option(False, "--drop-data", help=DROP_DATA_HELP),
) -> None:
    """Migrate the configured database up to REVISION (default: the latest)."""
    from app.config import get_settings
    from app.db.engines import parse_database_url

    migrate("upgrade", revision, drop_data=drop_data)
    url = parse_database_url(get_settings().resolved_database_url)
    typer.echo(f"database at {revision}: {url.render_as_string(hide_password=True)}", err=True)


@app.command("downgrade")
def downgrade(
    revision: str = typer.Argument(..., help="target revision ('base': empty)"),
    drop_data: bool = typer.Option(False, "--drop-data", help=DROP_DATA_HELP),
) -> None:
    """Migrate the configured database down to REVISION; one that would lose stored data
    is refused unless --drop-data."""
    migrate("downgrade", revision, drop_data=drop_data)
