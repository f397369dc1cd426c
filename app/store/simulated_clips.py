"""The simulated clips of a database by what determines them (``simulated_clips``).

Keys come from :func:`app.services.clips.simulation_key`; the values are finished clip
artifacts that may have been collected since (docs/runtime.md, "Each simulation once").
"""

from __future__ import annotations

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.models import ExpansionClip, SimulatedClip
from app.store._sql import insert_ignoring_duplicates


def simulated_clip(session: Session, key: str) -> str | None:
    """The clip artifact recorded for ``key``, if any."""
    return session.scalar(select(SimulatedClip.clip).where(SimulatedClip.key == key))


def record_simulated_clip(session: Session, key: str, clip: str) -> None:
    """Remember ``clip`` as the simulation of ``key``; the first writer of a key wins
    (two writers of one key computed the same bytes)."""
    insert_ignoring_duplicates(session, SimulatedClip, [{"key": key, "clip": clip}])


def reuse_counts(session: Session) -> tuple[int, int]:
    """(clips grown by epochs, simulations remembered): their difference was reused."""
    grown = session.scalar(select(func.count()).select_from(ExpansionClip)) or 0
    simulated = session.scalar(select(func.count()).select_from(SimulatedClip)) or 0
    return grown, simulated
