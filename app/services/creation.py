"""Creating a graph: the initial tree (paper Fig. 3), its leaves blended back."""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.graph_entry import GraphScene
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import parse_strategy
from app.core.names import check_name
from app.core.players.kinds import parse_player_model
from app.db.limits import MAX_WORLD
from app.liquid.devices import LiquidDevices
from app.services.dynamics import make_dynamics
from app.services.loading import artifact_store
from app.services.progress import Advance
from app.services.status import graph_summary
from app.store.graph_catalogue import GraphExists, create_graph, graph_exists, graph_name_length
from app.store.graph_persistence import save_graph

#: the most simulated clips ``srg init --depth`` may ask of the initial tree; past it the
#: tree grows as N^depth and a typo would run for ever (growth refines from there)
MAX_INITIAL_CLIPS = 1_000


def check_initial_depth(depth: int, n_controls: int) -> None:
    """Refuse an initial tree too shallow to blend (depth < 2) or past MAX_INITIAL_CLIPS."""
    if depth < 2:
        raise InvalidInput("the initial tree needs depth >= 2 so that leaves have SIM targets")
    clips, level, deepest = 0, 1, 1
    for _ in range(1, depth):
        level *= n_controls
        clips += level
        if clips > MAX_INITIAL_CLIPS:
            raise InvalidInput(
                f"depth {depth} makes an initial tree of more than {MAX_INITIAL_CLIPS} "
                f"simulated clips for {n_controls} controls: at most depth {deepest}"
            )
        deepest += 1


def check_world(world: int | None) -> None:
    """Refuse a negative world seed (``np.random.default_rng`` takes none) or one past the
    integer column that stores it."""
    if world is not None and not 0 <= world <= MAX_WORLD:
        raise InvalidInput(f"a world seed is an integer from 0 to {MAX_WORLD}, got {world}")


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
    progress: Advance | None = None,
    world: int | None = None,
) -> dict[str, object]:
    """Store the initial tree of a new graph; return its summary.

    ``progress(1)`` follows each clip of the tree
    (``app.core.growth.expansion.initial_tree_clips``).

    ``world`` is the seed of the start state (``Dynamics.initial_state``; None, the
    canonical start); it is stored with the graph, non-negative (docs/experiment.md,
    "World seeds").

    ``player_model`` is the crowd model sr-crowd learns (default ``SRG_PLAYER_MODEL``).

    Everything is checked before anything is written: the name (:func:`check_name`, the
    same on every backend), the strategy, the dynamics with its preset and fluid (the
    toy has neither), the depth and the artifact directory.
    """
    check_name(name, what="graph", max_length=graph_name_length())
    check_world(world)
    chosen = parse_strategy(strategy)
    crowd_model = parse_player_model(player_model or settings.growth.player_model)
    if dynamics == "toy" and preset is not None:
        raise InvalidInput(f"the toy has no preset (got {preset!r}); presets are the liquid's")
    if graph_exists(session, name):
        raise GraphExists(f"a graph named {name!r} already exists")
    model = make_dynamics(dynamics, preset, fluid, devices=LiquidDevices.from_settings(settings))
    check_initial_depth(depth, model.n_controls)
    artifacts = artifact_store(settings)
    bank = MemoryClipBank()
    graph = initial_tree(
        model,
        bank,
        depth=depth,
        prefilter_k=settings.growth.prefilter_k,
        progress=progress,
        world=world,
    )
    graph_id = create_graph(
        session,
        name=name,
        dynamics=dynamics,
        n_controls=model.n_controls,
        frames_per_clip=model.frames_per_clip,
        scene=GraphScene(fps=model.fps, preset=preset, fluid=fluid),
        seed=seed,
        strategy=chosen.value,
        player_model=crowd_model.value,
        world=world,
    )
    save_graph(session, graph_id, graph, bank, artifacts)
    return graph_summary(session, graph_id)
