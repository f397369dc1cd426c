"""`srg demo`: the product's main job on the embedded default.

It builds (or continues) a graph and runs self-refining rounds on it: publish, let
goal-directed bots play the publication, learn the crowd model from every trace so far
and grow with sr-crowd. Each round is its own transaction, so an interrupted demo keeps
the rounds it finished and the next run goes on from there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from app.config import Settings
from app.models import Graph, PublicationEdge
from app.services.graphs import (
    PlayResult,
    PublishResult,
    artifact_store,
    grow_graph,
    init_graph,
    play_graph,
    publish_graph,
)


@dataclass(frozen=True)
class DemoPlan:
    name: str = "demo"
    dynamics: str = "liquid"
    preset: str | None = "small"
    rounds: int = 3
    budget: int = 3
    sessions: int = 20
    mean_steps: int = 60
    seed: int = 0

    def check(self) -> None:
        if self.rounds < 1 or self.budget < 1 or self.sessions < 1 or self.mean_steps < 2:
            raise ValueError("rounds, budget and sessions must be positive, mean steps >= 2")


@dataclass(frozen=True)
class DemoRound:
    round: int
    publication: int
    size_frames: int
    observed_mean_error: float
    high_error_fraction: float
    mean_score_per_step: float
    steps: int


#: stages reported to the caller's progress display: (stage name, round)
Stage = Callable[[str, int], None]


def run_demo(
    sessions: sessionmaker[Session],
    settings: Settings,
    plan: DemoPlan,
    stage: Stage,
    advance: Callable[[int], None],
) -> list[DemoRound]:
    """Rounds of publish, play, learn-and-grow; a final publish and play closes them."""
    plan.check()
    with sessions() as session:
        exists = session.scalar(select(Graph.id).where(Graph.name == plan.name)) is not None
    if not exists:
        stage("initial tree", 0)
        with sessions.begin() as session:
            init_graph(
                session,
                settings,
                name=plan.name,
                dynamics=plan.dynamics,
                preset=plan.preset,
                strategy="sr-crowd",
            )
    rounds = []
    for number in range(1, plan.rounds + 2):
        stage("publish", number)
        with sessions.begin() as session:
            published: PublishResult = publish_graph(
                session, settings, name=plan.name, progress=advance
            )
        stage("play", number)
        with sessions.begin() as session:
            played: PlayResult = play_graph(
                session,
                settings,
                name=plan.name,
                sessions=plan.sessions,
                mean_steps=plan.mean_steps,
                seed=plan.seed * 1000 + published.number,
            )
        rounds.append(
            DemoRound(
                round=number,
                publication=published.number,
                size_frames=published.size_frames,
                observed_mean_error=played.observed_mean_error,
                high_error_fraction=played.high_error_fraction,
                mean_score_per_step=played.mean_score_per_step,
                steps=played.steps,
            )
        )
        if number > plan.rounds:
            break
        stage("grow", number)
        grow_graph(
            sessions.begin,
            settings,
            name=plan.name,
            strategy="sr-crowd",
            expansions=plan.budget,
            progress=advance,
        )
    return rounds


def write_demo_report(
    session: Session, settings: Settings, plan: DemoPlan, rounds: list[DemoRound], out: Path
) -> Path:
    """report.md with the error per round plot and a contact sheet of rendered frames."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    x = [r.size_frames for r in rounds]
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.plot(x, [r.observed_mean_error for r in rounds], "o-", label="observed mean error")
    ax.plot(x, [r.high_error_fraction for r in rounds], "s--", label="high-error fraction")
    ax.set_xlabel("graph size (simulated frames)")
    ax.set_title(f"{plan.name}: what goal-directed bots saw")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "error-per-round.png", dpi=120)
    plt.close(fig)
    contact = contact_sheet(session, settings, plan.name)
    if contact is not None:
        from PIL import Image

        Image.fromarray(contact).save(out / "contact-sheet.png")
    lines = [
        f"# srg demo: {plan.name} ({plan.dynamics}"
        + (f", preset {plan.preset}" if plan.preset else "")
        + ")",
        "",
        "Each round publishes the graph, lets goal-directed bots play it, then learns the "
        "crowd player model from all traces so far and grows the graph with sr-crowd.",
        "",
        "| round | publication | frames | observed mean error | high-error fraction "
        "| score per step | steps played |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r.round} | {r.publication} | {r.size_frames} | {r.observed_mean_error:.4f} "
        f"| {r.high_error_fraction:.3f} | {r.mean_score_per_step:.4g} | {r.steps} |"
        for r in rounds
    ]
    lines += ["", "![error per round](error-per-round.png)", ""]
    if contact is not None:
        lines += ["Frames of the edges players visited most:", "", "![frames](contact-sheet.png)"]
    lines += ["", "Play it: `srg serve`, then open http://127.0.0.1:8000/", ""]
    report = out / "report.md"
    report.write_text("\n".join(lines))
    return report


def contact_sheet(
    session: Session, settings: Settings, name: str, edges: int = 12, columns: int = 4
) -> np.ndarray | None:
    """Middle frames of the latest publication's most visited animations, in a grid."""
    from app.render.animation import decode_strip
    from app.store.analytics import visit_counts
    from app.store.graphs import get_graph_row
    from app.store.publications import latest_publication

    row = get_graph_row(session, name)
    latest = latest_publication(session, row.id)
    if latest is None:
        return None
    visited = [int(v["vertex"]) for v in visit_counts(session, row.id)]
    animations = session.execute(
        select(PublicationEdge.vertex, PublicationEdge.animation).where(
            PublicationEdge.publication_id == latest.id, PublicationEdge.animation.is_not(None)
        )
    ).all()
    by_vertex: dict[int, str] = {}
    for vertex, animation in animations:
        if animation is not None:
            by_vertex.setdefault(vertex, animation)
    chosen = [by_vertex[v] for v in visited if v in by_vertex][:edges] or list(by_vertex.values())[
        :edges
    ]
    if not chosen:
        return None
    store = artifact_store(settings)
    k = row.frames_per_clip
    tiles = [decode_strip(store.get_bytes(digest), k)[k // 2] for digest in chosen]
    while len(tiles) % columns:
        tiles.append(np.full_like(tiles[0], 255))
    rows = [np.concatenate(tiles[i : i + columns], axis=1) for i in range(0, len(tiles), columns)]
    return np.concatenate(rows, axis=0)


def rounds_as_dicts(rounds: list[DemoRound]) -> list[dict[str, object]]:
    return [asdict(r) for r in rounds]
