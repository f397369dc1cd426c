"""The scope one step of a use case works in: its transaction's session, the settings it
runs in and the one artifact store it reads and writes, made once by whoever runs the
step (a Celery task, the in-process epoch, a command) and handed to the service, which
opens none of them itself (docs/runtime.md, "One scope a step")."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.config import Settings
from app.db.sessions import Transactions, transaction
from app.services.loading import artifact_store
from app.store.artifacts import ArtifactStore


@dataclass(frozen=True)
class Scope:
    """One step's session, settings and artifact store."""

    session: Session
    settings: Settings
    artifacts: ArtifactStore

    @classmethod
    def of(cls, session: Session, settings: Settings) -> Scope:
        """The scope of work in ``session`` (a transaction its caller owns)."""
        return cls(session, settings, artifact_store(settings))


@contextmanager
def step_scope(
    settings: Settings,
    artifacts: ArtifactStore | None = None,
    transactions: Transactions | None = None,
) -> Iterator[Scope]:
    """A scope in a transaction of its own (one of ``transactions``, else a fresh one on
    the settings' database), committed when the step ends well."""
    opened = transactions or (lambda: transaction(settings))
    with opened() as session:
        yield Scope(session, settings, artifacts or artifact_store(settings))
