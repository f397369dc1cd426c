"""What ``srg fsck`` reads and writes in the database: the artifact rows, who references
a given artifact, and the database's own consistency check.

The checks themselves (hashes, recomputation) are :mod:`app.services.fsck`'s; these are
the queries it needs, kept beside the other stores' SQL.
"""

from __future__ import annotations

from collections.abc import Iterator

from sqlalchemy import delete, func, select, text, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.models import Artifact, Clip, ExpansionClip, GrowthEpoch, Vertex

#: artifact rows read per query while scanning
SCAN_BATCH = 2_000


def count_artifacts(session: Session) -> int:
    return session.scalar(select(func.count()).select_from(Artifact)) or 0


def artifact_rows(session: Session) -> Iterator[tuple[str, int]]:
    """Every registered artifact's (hash, size), in hash order, a batch per query."""
    after = ""
    while True:
        rows = session.execute(
            select(Artifact.hash, Artifact.size)
            .where(Artifact.hash > after)
            .order_by(Artifact.hash)
            .limit(SCAN_BATCH)
        ).all()
        if not rows:
            return
        yield from ((digest, size) for digest, size in rows)
        after = rows[-1][0]


def sqlite_integrity(session: Session) -> list[str]:
    """``PRAGMA integrity_check``'s lines: ``["ok"]`` for a sound file."""
    return [str(row[0]) for row in session.execute(text("PRAGMA integrity_check"))]


def clip_with_bundle(session: Session, digest: str) -> tuple[int, int] | None:
    """(graph, clip) of one stored clip whose bundle is ``digest`` (equal clips share one)."""
    row = session.execute(
        select(Clip.graph_id, Clip.idx).where(Clip.bundle == digest).limit(1)
    ).first()
    return None if row is None else (int(row[0]), int(row[1]))


def clip_start(session: Session, graph_id: int, clip: int) -> tuple[int | None, int]:
    """What a stored clip starts from, the clip whose end state its source vertex is
    (None: the start vertex), and the control it plays."""
    source, control = session.execute(
        select(Clip.source, Clip.control).where(Clip.graph_id == graph_id, Clip.idx == clip)
    ).one()
    before = session.scalar(
        select(Vertex.clip_idx).where(Vertex.graph_id == graph_id, Vertex.idx == source)
    )
    return (None if before is None else int(before)), int(control)


def expansion_clip_with(session: Session, digest: str) -> tuple[int, int, int] | None:
    """(epoch, position, control) of one recorded expansion clip stored as ``digest``."""
    row = session.execute(
        select(ExpansionClip.epoch_id, ExpansionClip.position, ExpansionClip.control)
        .where(ExpansionClip.clip == digest)
        .limit(1)
    ).first()
    return None if row is None else (int(row[0]), int(row[1]), int(row[2]))


def drop_warm_starts(session: Session, digest: str) -> bool:
    """Forget a STATERANK warm start (it only speeds the next ranking up), and its
    artifact row when nothing else holds it; whether some epoch had it."""
    result = session.execute(
        update(GrowthEpoch).where(GrowthEpoch.warm_start == digest).values(warm_start=None)
    )
    if not getattr(result, "rowcount", 0):
        return False
    try:
        with session.begin_nested():
            session.execute(delete(Artifact).where(Artifact.hash == digest))
    except IntegrityError:  # referenced elsewhere too: the row stays, the scan says so
        pass
    return True
