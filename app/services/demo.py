"""`srg demo`: the product's main job on the embedded default.

The demo is a small experiment (:mod:`app.services.experiment`): three graphs grow side
by side from the same initial tree, with BASELINE, SR-HEURISTIC and SR-CROWD, and at each
checkpoint goal-directed bots play all three. A newcomer sees the error players meet fall
faster on the graph that learns from play: SR-CROWD against SR-HEURISTIC is what the
traces add to the same STATERANK growth, SR-CROWD against BASELINE what both add (the
sizes are chosen from measurements: docs/experiment.md). The SR-CROWD graph is then
published with its animations, ready to play in the browser. Its checkpoints are
stored, so an interrupted demo goes on from the last one when run again.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.state_graph import EdgeKind
from app.core.growth.kinds import Strategy
from app.core.liquid.defaults import QUICK_LIQUID_PRESET
from app.core.players.kinds import PlayerModelKind
from app.db.sessions import transaction
from app.reports.contact_sheet import Tile, contact_sheet
from app.reports.experiment import write_report
from app.reports.figures import ArraysLoader
from app.services.catalogue import missing_animations
from app.services.experiment.plan import (
    ExperimentExists,
    ExperimentPlan,
    NothingToResume,
    create_experiment,
    run_graph_name,
    stored_plan,
)
from app.services.experiment.runs import Grower, run_experiment
from app.services.loading import artifact_store
from app.services.progress import Advance
from app.services.publishing import PublishResult, publish_graph
from app.store.animations import (
    PublishedStrip,
    publication_animations,
)
from app.store.graph_catalogue import graph_entry, graph_exists

#: graph sizes (frames) where bots play: on `tiny` sr-crowd and baseline part by 1,500
DEMO_CHECKPOINTS = (300, 600, 1_000, 1_500)
PLAYABLE = Strategy.SR_CROWD
#: what the demo grows, in the order of its table: sr-heuristic is sr-crowd's control
DEMO_STRATEGIES = (Strategy.BASELINE, Strategy.SR_HEURISTIC, PLAYABLE)


@dataclass(frozen=True)
class DemoRow:
    """The graphs at one checkpoint, as the demo's table shows them: per strategy the
    mean error per step and the visibly-wrong share, and sr-crowd's error ratios (the
    experiment's comparison, of the demo's one seed; None where undefined)."""

    frames: int
    error: dict[str, float]
    high_error: dict[str, float]
    crowd_vs_heuristic: float | None
    crowd_vs_baseline: float | None


def demo_plan(
    dynamics: str = "liquid",
    preset: str | None = QUICK_LIQUID_PRESET,
    fluid: str | None = None,
    checkpoints: tuple[int, ...] = DEMO_CHECKPOINTS,
    sessions: int = 30,
    seed: int = 0,
    player_model: PlayerModelKind = PlayerModelKind.EQ2,
) -> ExperimentPlan:
    return ExperimentPlan(
        dynamics=dynamics,
        preset=preset if dynamics == "liquid" else None,
        fluid=fluid,
        strategies=DEMO_STRATEGIES,
        seeds=(seed,),
        checkpoints=checkpoints,
        sessions=sessions,
        player_model=player_model,
    )


def run_demo(
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    grower: Grower,
    *,
    jobs: int,
    progress: Advance | None = None,
) -> dict[str, Any]:
    """Grow, play and measure the graphs (resuming a stored demo): the result."""
    try:
        stored = stored_plan(settings, name)
    except NothingToResume:
        stored = create_experiment(settings, name, plan)
    else:
        if replace(stored, high_error_threshold=None) != plan:
            raise ExperimentExists(
                f"a demo named {name!r} was run with other settings: choose another --name"
            )
    return run_experiment(settings, name, stored, grower, jobs=jobs, progress=progress)


def publish_playable(
    settings: Settings, name: str, plan: ExperimentPlan, progress: Advance | None = None
) -> tuple[str, PublishResult]:
    """Publish the demo's SR-CROWD graph with every animation rendered; its name too."""
    graph = run_graph_name(name, PLAYABLE, plan.seeds[0])
    with transaction(settings) as session:
        return graph, publish_graph(session, settings, name=graph, progress=progress)


def unrendered_edges(settings: Settings, name: str, plan: ExperimentPlan) -> int:
    """Edges of the playable graph without an animation yet (what publishing renders)."""
    graph = run_graph_name(name, PLAYABLE, plan.seeds[0])
    with transaction(settings) as session:
        if not graph_exists(session, graph):
            return 0
        return missing_animations(session, graph)


def demo_rows(result: dict[str, Any]) -> list[DemoRow]:
    """One row per checkpoint of a complete demo's result."""
    ((bot, played),) = result["crowds"].items()  # the demo's one crowd and seed
    checkpoints = {
        strategy: next(iter(by_seed.values())) for strategy, by_seed in played["results"].items()
    }
    return [
        DemoRow(
            frames=int(compared["checkpoint_frames"]),
            error={s: float(rows[i]["observed_mean_error"]) for s, rows in checkpoints.items()},
            high_error={
                s: float(rows[i]["high_error_fraction"]) for s, rows in checkpoints.items()
            },
            crowd_vs_heuristic=compared["crowd_vs_heuristic"]["mean"],
            crowd_vs_baseline=compared["crowd_vs_baseline"]["mean"],
        )
        for i, compared in enumerate(result["comparison"][bot])
    ]


def write_demo_report(
    settings: Settings, result: dict[str, Any], graph: str, out: Path, load_arrays: ArraysLoader
) -> Path:
    """The experiment's report, with a contact sheet of the playable graph and how to play."""
    report = write_report(result, out, load_arrays)
    with transaction(settings) as session:
        frames = visited_frames(session, settings, graph)
    lines = ["", "## Play it", ""]
    if frames is not None:
        from PIL import Image

        Image.fromarray(contact_sheet(*frames)).save(out / "contact-sheet.png")
        lines += [f"Frames of the edges bots visited most on `{graph}`:", ""]
        lines += ["![frames](contact-sheet.png)", ""]
    lines += [f"`srg serve`, then open http://127.0.0.1:8000/?graph={graph}", ""]
    report.write_text(report.read_text() + "\n".join(lines))
    return report


def visited_frames(
    session: Session, settings: Settings, name: str, edges: int = 12
) -> tuple[str, list[Tile]] | None:
    """The title and captioned middle frames of the latest publication's most visited
    animations (one edge per vertex, its first control with a strip); None without any."""
    from app.render.animation import decode_strip
    from app.store.analytics import visit_counts
    from app.store.publications import latest_publication

    entry = graph_entry(session, name)
    latest = latest_publication(session, entry.id)
    if latest is None:
        return None
    visits = {int(v["vertex"]): int(v["visits"]) for v in visit_counts(session, entry.id)}
    by_vertex: dict[int, PublishedStrip] = {}
    for strip in publication_animations(session, latest.id):
        by_vertex.setdefault(strip.vertex, strip)
    chosen = [by_vertex[v] for v in visits if v in by_vertex][:edges] or list(by_vertex.values())[
        :edges
    ]
    if not chosen:
        return None
    store = artifact_store(settings)
    k = entry.frames_per_clip
    tiles = [
        Tile(
            decode_strip(store.get_bytes(strip.animation), k)[k // 2],
            _caption(strip, k // 2, k, visits.get(strip.vertex, 0)),
        )
        for strip in chosen
    ]
    order = "most visited first" if visits else "none visited yet: the first edges"
    title = f"{name}, publication {latest.number}: middle frames of edges, {order}"
    return title, tiles


def _caption(strip: PublishedStrip, frame: int, frames: int, visits: int) -> tuple[str, ...]:
    kind = "simulated" if strip.kind == EdgeKind.SIM else f"blend, error {strip.err:.3g}"
    return (
        f"vertex {strip.vertex}, control {strip.control}",
        kind,
        f"frame {frame + 1} of {frames}, {visits} visits",
    )
