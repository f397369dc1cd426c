"""A player's trace stored against the publication it was played on.

The checks that need the HTTP request (size, token, rates, schema) stay in the route;
every step is checked once, by the store (:func:`app.store.traces.record_trace`),
against the publication's edges, before anything is written.
"""

from __future__ import annotations

import numpy as np
from sqlalchemy.orm import Session

from app.core.graph.publication import Publication
from app.store.publications import load_publication
from app.store.traces import record_trace
from app.store.transactions import in_transaction

__all__ = ["load_publication", "store_trace"]


def store_trace(
    session: Session,
    publication: Publication,
    publication_id: int,
    player_id: int,
    idempotency_key: str,
    steps: np.ndarray,
) -> tuple[int, bool]:
    """``(trace id, created)`` in one write transaction; a replay of the key returns the
    trace stored first with ``created`` False. A step off the publication's edges or a
    key reused for other steps raises the store's error and writes nothing."""
    return in_transaction(
        session,
        lambda: record_trace(
            session,
            publication_id,
            player_id,
            idempotency_key,
            steps,
            publication=publication,
        ),
    )
