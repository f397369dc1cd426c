"""Use cases on persisted graphs: create, grow, render, publish, play, report.

The CLI, the HTTP admin routes and the Celery tasks call these. Each takes the caller's
session and never commits (the caller owns the transaction), so a failure anywhere
leaves the database as it was. Growth itself is :class:`~app.core.refinement.Refiner`:
here it is only fed from and written back to the store.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from sqlalchemy import String, func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.bots import parse_bot, play_sessions
from app.core.clipbank import ClipBank, MemoryClipBank
from app.core.dynamics import Dynamics
from app.core.graph import EdgeKind, StateGraph
from app.core.growth import initial_tree
from app.core.metrics import high_error_fraction, observed_mean_error
from app.core.names import check_name
from app.core.player_models import PlayerModelKind, parse_player_model
from app.core.publication import Publication
from app.core.refinement import Refiner, RefinerConfig
from app.core.strategies import Strategy, parse_strategy
from app.db import Scope
from app.models import Clip, Edge, Graph, GrowthEpoch
from app.models import Publication as PublicationRow
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.services.dynamics import make_dynamics
from app.store.artifacts import ArtifactStore
from app.store.graphs import (
    create_graph,
    get_graph_row,
    save_graph,
    set_animations,
    size_frames,
)
from app.store.publications import latest_publication, load_publication, publish
from app.store.traces import (
    bot_player,
    load_traces,
    play_summary,
    played_publications,
    record_trace,
)

Progress = Callable[[int], None]


#: the most simulated clips ``srg init --depth`` may ask of the initial tree; past it the
#: tree grows as N^depth and a typo would run for ever (growth refines from there)
MAX_INITIAL_CLIPS = 1_000


class GraphExists(ValueError):
    """A graph of that name is already stored."""


class NothingPublished(LookupError):
    """The graph has no publication to play yet."""


class ArtifactDirectoryError(ValueError):
    """The artifact directory (SRG_ARTIFACT_DIR, else SRG_VAR_DIR/data) cannot be one."""


@dataclass
class LoadedGraph:
    """A stored graph in memory with what growing it needs."""

    row: Graph
    graph: StateGraph
    bank: ClipBank
    dynamics: Dynamics
    artifacts: ArtifactStore


def artifact_store(settings: Settings) -> ArtifactStore:
    """The artifact store of ``settings``; :class:`ArtifactDirectoryError` if a file is in
    the way of its directory (checked before anything is written, not at the first file)."""
    root = settings.resolved_artifact_dir
    existing = next((path for path in (root, *root.parents) if path.exists()), None)
    if existing is not None and not existing.is_dir():
        raise ArtifactDirectoryError(
            f"the artifact directory {root} is not a directory: {existing} is a file "
            "(set SRG_ARTIFACT_DIR or SRG_VAR_DIR)"
        )
    return ArtifactStore(root)


def graph_name_length() -> int:
    """The length of the graphs' name column: the longest name every backend stores."""
    column = Graph.__table__.c.name.type
    assert isinstance(column, String) and column.length is not None
    return column.length


def check_initial_depth(depth: int, n_controls: int) -> None:
    """Refuse an initial tree too shallow to blend (depth < 2) or past MAX_INITIAL_CLIPS."""
    if depth < 2:
        raise ValueError("the initial tree needs depth >= 2 so that leaves have SIM targets")
    clips, level, deepest = 0, 1, 1
    for _ in range(1, depth):
        level *= n_controls
        clips += level
        if clips > MAX_INITIAL_CLIPS:
            raise ValueError(
                f"depth {depth} makes an initial tree of more than {MAX_INITIAL_CLIPS} "
                f"simulated clips for {n_controls} controls: at most depth {deepest}"
            )
        deepest += 1


def refiner_config(
    settings: Settings, dynamics: Dynamics, player_model: PlayerModelKind = PlayerModelKind.EQ2
) -> RefinerConfig:
    return RefinerConfig(
        alpha=settings.alpha,
        crowd_radius=settings.crowd_radius or dynamics.crowd_radius,
        crowd_eps=settings.crowd_eps,
        default_session_steps=settings.restart_steps,
        max_session_steps=settings.max_session_steps,
        prefilter_k=settings.prefilter_k,
        batch_size=settings.batch_size,
        player_model=player_model,
    )


def open_graph(session: Session, settings: Settings, name: str | int) -> LoadedGraph:
    """The graph by name or id, loaded the one way growth loads it (cache, Redis shapes)."""
    from app.services.growth import loaded_graph  # growth builds on this module

    return loaded_graph(session, settings, get_graph_row(session, name))


def graph_play(session: Session, graph_id: int) -> list[tuple[Publication, list[np.ndarray]]]:
    """Every publication of the graph that was played, with its traces, oldest first.

    Vertex ids are stable across publications (vertices are only appended), so traces of
    any of them read on the graph as it is now; the publication says what players saw.
    """
    return [
        (load_publication(session, publication_id), load_traces(session, [publication_id]))
        for publication_id in played_publications(session, graph_id)
    ]


def refiner_for(
    session: Session, settings: Settings, loaded: LoadedGraph, strategy: Strategy | None = None
) -> Refiner:
    """The graph's refiner, with the crowd's traces when its strategy learns from them."""
    strategy = strategy or parse_strategy(loaded.row.strategy)
    refiner = Refiner(
        loaded.graph,
        loaded.bank,
        loaded.dynamics,
        strategy,
        refiner_config(settings, loaded.dynamics, parse_player_model(loaded.row.player_model)),
    )
    if strategy.learns_from_traces and refiner.config.player_model is PlayerModelKind.LOGIT:
        for publication, traces in graph_play(session, loaded.row.id):
            refiner.learn(traces, publication)
    elif strategy.learns_from_traces:  # eq. 2 reads no publication: one query for all traces
        refiner.learn(load_traces(session, played_publications(session, loaded.row.id)))
    return refiner


# ---- create ---------------------------------------------------------------------------
def init_graph(
    session: Session,
    settings: Settings,
    *,
    name: str,
    dynamics: str = "toy",
    preset: str | None = None,
    fluid: str | None = None,
    strategy: str = "sr-crowd",
    depth: int = 2,
    seed: int = 0,
    player_model: str | None = None,
) -> dict[str, object]:
    """Store the initial tree (paper Fig. 3) of a new graph; return its summary.

    ``player_model`` is the crowd model sr-crowd learns (default ``SRG_PLAYER_MODEL``).

    Everything is checked before anything is written: the name (:func:`check_name`, the
    same on every backend), the strategy, the dynamics with its preset and fluid (the
    toy has neither), the depth and the artifact directory.
    """
    check_name(name, what="graph", max_length=graph_name_length())
    chosen = parse_strategy(strategy)
    crowd_model = parse_player_model(player_model or settings.player_model)
    if dynamics == "toy" and preset is not None:
        raise ValueError(f"the toy has no preset (got {preset!r}); presets are the liquid's")
    if session.scalar(select(Graph.id).where(Graph.name == name)) is not None:
        raise GraphExists(f"a graph named {name!r} already exists")
    model = make_dynamics(dynamics, preset, fluid)
    check_initial_depth(depth, model.n_controls)
    artifacts = artifact_store(settings)
    bank = MemoryClipBank()
    graph = initial_tree(model, bank, depth=depth, prefilter_k=settings.prefilter_k)
    scene: dict[str, object] = {"fps": model.fps}
    if preset is not None:
        scene["preset"] = preset
    if fluid is not None:
        scene["fluid"] = fluid
    try:
        graph_id = create_graph(
            session,
            name=name,
            dynamics=dynamics,
            n_controls=model.n_controls,
            frames_per_clip=model.frames_per_clip,
            scene=scene,
            seed=seed,
            strategy=chosen.value,
            player_model=crowd_model.value,
        )
    except IntegrityError:
        raise GraphExists(f"a graph named {name!r} already exists") from None
    save_graph(session, graph_id, graph, bank, artifacts)
    return graph_summary(session, graph_id)


# ---- grow -----------------------------------------------------------------------------
@dataclass
class GrowResult:
    graph: str
    strategy: str
    epochs: int = 0
    expansions: int = 0
    relinks: int = 0
    size_frames: int = 0
    epoch_ids: list[int] = field(default_factory=list)
    #: "epoch <id>: <why>" for each epoch ranked by a fallback (STATERANK did not converge)
    ranking_fallbacks: list[str] = field(default_factory=list)


class GrowthBusy(ValueError):
    """An epoch of the graph is running on the workers; eager growth would race it."""


def grow_graph(
    scope: Scope,
    settings: Settings,
    *,
    name: str | int,
    strategy: str | None = None,
    frames: int | None = None,
    expansions: int | None = None,
    to_frames: int | None = None,
    renders: bool | None = None,
    batch_size: int | None = None,
    progress: Progress | None = None,
) -> GrowResult:
    """Grow in-process by a budget (frames, expansions, or up to a size), epoch by epoch.

    Each epoch is the very unit the Celery ``grow_epoch`` task runs, step by step
    (:mod:`app.services.growth`): plan (rank, pick the top BLEND edges, relink lazily),
    simulate each clip, integrate the expansions in plan order, render (when
    ``renders``, default ``settings.growth_renders``). Every step runs in a
    ``scope()``: :func:`app.db.transaction` makes each step durable (an interrupted grow
    keeps its finished steps, and the next grow first finishes the interrupted epoch);
    :func:`app.services.growth.in_session` runs all in one caller-owned transaction.
    """
    from app.services.growth import plan_epoch, run_epoch, running_epoch

    if sum(b is not None for b in (frames, expansions, to_frames)) > 1:
        raise ValueError("give one growth budget: frames, expansions or a size to reach")
    if frames is None and expansions is None and to_frames is None:
        expansions = settings.batch_size
    for budget in (frames, expansions, to_frames):
        if budget is not None and budget <= 0:
            raise ValueError("the growth budget must be positive")
    renders = settings.growth_renders if renders is None else renders
    batch = batch_size or settings.batch_size
    with scope() as session:
        row = get_graph_row(session, name)
        graph_id, n_controls, frames_per_clip = row.id, row.n_controls, row.frames_per_clip
        chosen = parse_strategy(strategy) if strategy else parse_strategy(row.strategy)
        size = size_frames(session, graph_id)
        interrupted = running_epoch(session, graph_id) if settings.eager else None
        interrupted_id = None if interrupted is None else interrupted.id
    result = GrowResult(graph=str(row.name), strategy=chosen.value)
    per_expansion = n_controls * frames_per_clip

    def advance(_: object) -> None:
        if progress is not None:
            progress(1 if expansions is not None else per_expansion)

    if interrupted_id is not None:  # embedded: nobody else can be running it
        result.expansions += len(
            run_epoch(scope, settings, interrupted_id, renders=renders, on_expansion=advance)
        )
        size = _epoch_size(scope, interrupted_id)
    if frames is not None:
        to_frames = size + frames
    while True:
        if to_frames is not None:
            left = -(-(to_frames - size) // per_expansion)
        else:
            assert expansions is not None
            left = expansions - result.expansions
        if left <= 0:
            break
        with scope() as session:
            plan = plan_epoch(session, settings, graph_id, count=min(left, batch), strategy=chosen)
        if plan is None:
            raise GrowthBusy(f"graph {result.graph!r} has an epoch running on the workers")
        done = run_epoch(scope, settings, plan.epoch_id, renders=renders, on_expansion=advance)
        size = _epoch_size(scope, plan.epoch_id)
        result.epochs += 1
        result.expansions += len(done)
        result.relinks += plan.relinks
        result.epoch_ids.append(plan.epoch_id)
        if plan.ranking_fallback is not None:
            result.ranking_fallbacks.append(f"epoch {plan.epoch_id}: {plan.ranking_fallback}")
        if not plan.expansions:
            break
    result.size_frames = size
    return result


def _epoch_size(scope: Scope, epoch_id: int) -> int:
    with scope() as session:
        return session.get_one(GrowthEpoch, epoch_id).size_frames


# ---- render and publish ----------------------------------------------------------------
def render_missing_animations(
    session: Session, loaded: LoadedGraph, progress: Progress | None = None
) -> int:
    """Render every edge that has no animation yet; return how many were rendered.

    A SIM edge shows its clip (rendered once per clip and kept on the clip row); a BLEND
    edge shows eq. 8's blend of its dead-end clip into its target's clip.
    """
    graph_id, graph, bank, dyn = loaded.row.id, loaded.graph, loaded.bank, loaded.dynamics
    n = graph.n_controls
    missing = [
        vertex * n + control
        for vertex, control in session.execute(
            select(Edge.vertex, Edge.control).where(
                Edge.graph_id == graph_id, Edge.animation.is_(None)
            )
        )
    ]
    clip_animations: dict[int, str | None] = {
        clip: animation
        for clip, animation in session.execute(
            select(Clip.idx, Clip.animation).where(
                Clip.graph_id == graph_id, Clip.animation.is_not(None)
            )
        )
    }
    new_clips: dict[int, str] = {}
    edges: dict[int, str] = {}
    for edge in missing:
        clip = graph.edge_clip[edge]
        if graph.edge_kind[edge] == EdgeKind.SIM:
            digest = clip_animations.get(clip) or new_clips.get(clip)
            if digest is None:
                digest = _store_strip(session, loaded, dyn.render(bank.frames(clip)))
                new_clips[clip] = digest
        else:
            target_clip = graph.edge_clip[graph.edge_target[edge]]
            frames = dyn.blend(bank.frames(clip), bank.frames(target_clip))
            digest = _store_strip(session, loaded, dyn.render(frames))
        edges[edge] = digest
        if progress is not None:
            progress(1)
    set_animations(session, graph_id, clips=new_clips, edges=edges)
    return len(edges)


def _store_strip(session: Session, loaded: LoadedGraph, images: np.ndarray) -> str:
    return loaded.artifacts.put_bytes(
        encode_strip(images), media_type=STRIP_MEDIA_TYPE, session=session
    )


def count_missing_animations(session: Session, graph_id: int) -> int:
    return len(
        session.scalars(
            select(Edge.vertex).where(Edge.graph_id == graph_id, Edge.animation.is_(None))
        ).all()
    )


@dataclass
class PublishResult:
    graph: str
    publication_id: int
    number: int
    relinked: int
    rendered: int
    size_frames: int


def publish_graph(
    session: Session,
    settings: Settings,
    *,
    name: str | int,
    render: bool = True,
    progress: Progress | None = None,
) -> PublishResult:
    """Pre-publish relinking, animations for every edge, then a frozen publication.

    ``render=False`` freezes the graph without animations: the experiment's bots play
    edges, not pictures, and rendering would cost more than growing.
    """
    loaded = open_graph(session, settings, name)
    refiner = refiner_for(session, settings, loaded, Strategy.BASELINE)
    relinked = len(refiner.publish()[1])
    save_graph(session, loaded.row.id, loaded.graph, loaded.bank, loaded.artifacts)
    rendered = render_missing_animations(session, loaded, progress) if render else 0
    publication_id = publish(session, loaded.row.id, loaded.graph)
    row = session.get_one(PublicationRow, publication_id)
    return PublishResult(
        graph=loaded.row.name,
        publication_id=publication_id,
        number=row.number,
        relinked=relinked,
        rendered=rendered,
        size_frames=loaded.graph.size_frames,
    )


# ---- play -------------------------------------------------------------------------------
def latest_publication_id(session: Session, graph_id: int) -> int:
    row = latest_publication(session, graph_id)
    if row is None:
        raise NothingPublished(f"graph {graph_id} has no publication yet: run `srg publish`")
    return row.id


@dataclass
class PlayResult:
    graph: str
    publication_id: int
    traces: int
    steps: int
    observed_mean_error: float
    high_error_fraction: float
    mean_score_per_step: float


def play_graph(
    session: Session,
    settings: Settings,
    *,
    name: str | int,
    bot: str = "goal-directed",
    sessions: int = 20,
    mean_steps: int = 90,
    seed: int = 0,
) -> PlayResult:
    """Bots play the latest publication in-process; their traces are stored as uploads."""
    kind = parse_bot(bot)
    if sessions <= 0 or mean_steps < 2:
        raise ValueError("sessions must be positive and mean steps at least 2")
    row = get_graph_row(session, name)
    publication_id = latest_publication_id(session, row.id)
    publication = load_publication(session, publication_id)
    traces = play_sessions(publication, kind, sessions=sessions, mean_steps=mean_steps, seed=seed)
    player_id = bot_player(session, f"bot-{kind.value}")
    run = uuid.uuid4().hex  # each play is new play data, as each browser session is
    for index, trace in enumerate(traces):
        key = f"local-{run}-{index}"
        record_trace(session, publication_id, player_id, key, trace, publication=publication)
    dynamics = make_dynamics(row.dynamics, row.scene.get("preset"), row.scene.get("fluid"))
    threshold = settings.high_error_threshold or dynamics.high_error_threshold
    steps = np.concatenate(traces)
    return PlayResult(
        graph=row.name,
        publication_id=publication_id,
        traces=len(traces),
        steps=len(steps),
        observed_mean_error=observed_mean_error(traces, publication.edge_err, row.n_controls),
        high_error_fraction=high_error_fraction(
            traces, publication.edge_err, row.n_controls, threshold
        ),
        mean_score_per_step=float(
            publication.edge_score[steps[:, 0] * row.n_controls + steps[:, 1]].mean()
        ),
    )


# ---- report -----------------------------------------------------------------------------
def graph_summary(session: Session, name: str | int) -> dict[str, object]:
    """What `srg status` shows: sizes from the stored rows, publications, epochs, play."""
    row = get_graph_row(session, name)
    kinds: dict[int, int] = {
        kind: count
        for kind, count in session.execute(
            select(Edge.kind, func.count()).where(Edge.graph_id == row.id).group_by(Edge.kind)
        )
    }
    frames = size_frames(session, row.id)
    latest = latest_publication(session, row.id)
    epochs = session.scalar(select(func.count()).where(GrowthEpoch.graph_id == row.id)) or 0
    return {
        "id": row.id,
        "name": row.name,
        "dynamics": row.dynamics,
        "preset": row.scene.get("preset"),
        "strategy": row.strategy,
        "player_model": row.player_model,
        "growing": row.growing,
        "size_frames": int(frames),
        "sim_edges": int(kinds.get(int(EdgeKind.SIM), 0)),
        "blend_edges": int(kinds.get(int(EdgeKind.BLEND), 0)),
        "epochs": int(epochs),
        "latest_publication": None if latest is None else latest.number,
        "unrendered_edges": count_missing_animations(session, row.id),
        "play": play_summary(session, row.id),
    }


def list_graphs(session: Session) -> list[dict[str, object]]:
    return [graph_summary(session, gid) for gid in session.scalars(select(Graph.id))]
