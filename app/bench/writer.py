"""``srg bench writer``: does one graph's single writer keep up to F frames at a given
clip rate?

A graph grows from its initial tree to ``frames`` frames on a scratch PostgreSQL
database, epoch by epoch, in one process that plays the writer's part for real: every
epoch is planned (rank, pick, relink) and every expansion integrated (lock, best-target
searches, diff persistence) by the very services the workers run, one transaction each,
on the process's cached graph as a worker that keeps it. Only the clips are synthetic:
the toy's, made here and not timed, standing in for clips that W workers deliver at a
measured cost of ``clip_seconds`` each. Their delivery runs on a virtual clock:

    epoch = plan + ceil(3 B / W) x clip_seconds + B x (t_int + liquid_seconds)

(the chord of docs/runtime.md: integrations start when the epoch's clips are all in,
the next epoch is planned after the last one), where plan and t_int are the measured
seconds of this run and ``liquid_seconds`` is what the liquid's best-target search and
bundle writes add to each integration at the preset (measured apart, docs/runtime.md).
The writer keeps up while its share of the virtual time stays small: that share is the
fraction of the workers' time lost waiting for it. One growth serves every worker count
(the writer's seconds do not depend on W); each is reported whole and per tenth of the
run. A run to 200,000 frames takes hours: interrupted (Ctrl-C), it reports the epochs it
grew, marked ``interrupted``, and drops its scratch database as a finished one does.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy.orm import Session, sessionmaker

from app.bench.scratch import scratch_database
from app.config import Settings
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.services.scope import Scope
from app.store.graph_catalogue import get_graph_row, size_frames


def _virtual_clock(
    records: list[tuple[int, float]],
    *,
    batch: int,
    n_controls: int,
    workers: int,
    clip_seconds: float,
    liquid_seconds: float,
    parts: int = 10,
) -> dict[str, Any]:
    """The run on the virtual clock of ``workers``: its hours and the writer's share,
    whole and per slice (the run cut into ``parts`` consecutive slices of epochs)."""
    clips = math.ceil(batch * n_controls / workers) * clip_seconds
    writer = np.array([seconds + batch * liquid_seconds for _, seconds in records])
    epoch = writer + clips
    slices = []
    for chunk in np.array_split(np.arange(len(records)), parts):
        if len(chunk):
            slices.append(
                {
                    "up_to_frames": records[chunk[-1]][0],
                    "writer_share": round(float(writer[chunk].sum() / epoch[chunk].sum()), 4),
                }
            )
    return {
        "workers": workers,
        "virtual_hours": round(float(epoch.sum()) / 3600, 2),
        "frames_per_hour": round(records[-1][0] / (float(epoch.sum()) / 3600)),
        "writer_share": round(float(writer.sum() / epoch.sum()), 4),
        "slices": slices,
    }


def bench_writer(
    *,
    settings: Settings,
    frames: int,
    batch: int,
    workers: list[int],
    clip_seconds: float,
    liquid_seconds: float,
    progress: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Grow a toy graph to ``frames`` with the real writer; the virtual-clock figures."""
    from app.services.creation import init_graph

    with (
        tempfile.TemporaryDirectory() as tmp,
        scratch_database(settings.scratch_postgres_url) as url,
    ):
        settings = settings.replace(
            database_url=url, var_dir=Path(tmp), batch_size=batch, growth_renders=False
        )
        sessions = session_factory(make_engine(url))
        with sessions() as session:
            init_graph(session, settings, name="writer", dynamics="toy")
            session.commit()
        with sessions() as session:
            row = get_graph_row(session, "writer")
            graph_id, n_controls = row.id, row.n_controls
            size = size_frames(session, graph_id)
        #: (size after the epoch, the writer's measured seconds: plan + integrations)
        records: list[tuple[int, float]] = []
        integration_seconds: list[float] = []
        started = time.perf_counter()
        interrupted = False
        try:
            _grow(sessions, settings, graph_id, n_controls, size, frames, records,
                  integration_seconds, progress)  # fmt: skip
        except KeyboardInterrupt:
            if not records:
                raise
            interrupted = True
        size = records[-1][0] if records else size
    t_int = np.asarray(integration_seconds)
    return {
        "frames": size,
        "target_frames": frames,
        "interrupted": interrupted,
        "epochs": len(records),
        "batch": batch,
        "bench_wall_seconds": round(time.perf_counter() - started, 1),
        "integration_median_ms_last_tenth": round(
            1000 * float(np.median(t_int[-max(len(t_int) // 10, 1) :])), 1
        ),
        "clip_seconds": clip_seconds,
        "liquid_seconds_per_integration": liquid_seconds,
        "by_workers": [
            _virtual_clock(
                records,
                batch=batch,
                n_controls=n_controls,
                workers=w,
                clip_seconds=clip_seconds,
                liquid_seconds=liquid_seconds,
            )
            for w in workers
        ],
    }


def _grow(
    sessions: sessionmaker[Session],
    settings: Settings,
    graph_id: int,
    n_controls: int,
    size: int,
    frames: int,
    records: list[tuple[int, float]],
    integration_seconds: list[float],
    progress: Callable[[int], None] | None,
) -> None:
    """Epochs until the graph holds ``frames``: the writer's part timed into ``records``
    (size after the epoch, plan + integration seconds) as each epoch ends."""
    from app.services import clips, epochs

    while size < frames:
        t0 = time.perf_counter()
        with sessions() as session:
            plan = epochs.plan_epoch(Scope.of(session, settings), graph_id, renders=False)
            session.commit()
        plan_s = time.perf_counter() - t0
        if plan is None or not plan.expansions:
            break
        with sessions() as session:  # the workers' part: not on the writer's clock
            for position in range(len(plan.expansions)):
                for control in range(n_controls):
                    stage = clips.simulate_step(
                        Scope.of(session, settings), plan.epoch_id, position, control
                    )
                    clips.sdf_step(
                        Scope.of(session, settings), stage, plan.epoch_id, position, control
                    )
            session.commit()
        integrations = []
        for position in range(len(plan.expansions)):
            t0 = time.perf_counter()
            with sessions() as session:
                epochs.integrate_step(Scope.of(session, settings), plan.epoch_id, position)
                session.commit()
            integrations.append(time.perf_counter() - t0)
        with sessions() as session:
            grown = size_frames(session, graph_id) - size
        size += grown
        records.append((size, plan_s + sum(integrations)))
        integration_seconds.extend(integrations)
        if progress is not None:
            progress(grown)
