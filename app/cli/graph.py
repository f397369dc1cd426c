"""``srg init``, ``grow``, ``publish``, ``play``, ``status``, ``gc``: persisted graphs.

Each command runs one service call in one transaction: it commits when the service
returns and rolls back (writing nothing) when it raises. Those that write refuse a
damaged SQLite file first (:func:`app.db.engines.require_intact`).
"""

from __future__ import annotations

from contextlib import ExitStack
from functools import partial

import typer

from app.cli.choices import DynamicsName, Fluid, LiquidPreset, value_of
from app.cli.output import JSON_HELP, emit, progress_bar
from app.core.errors import InvalidInput
from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind, PlayerModelKind
from app.db.limits import MAX_ROW_ID, MAX_WORLD


def init(
    name: str = typer.Argument(..., help="name of the new graph"),
    dynamics: DynamicsName = typer.Option(DynamicsName.TOY, help="the dynamics the graph runs"),
    preset: LiquidPreset | None = typer.Option(None, help="liquid preset (default small)"),
    fluid: Fluid | None = typer.Option(None, help="liquid fluid (default low)"),
    strategy: Strategy = typer.Option(Strategy.SR_CROWD, help="how the graph grows"),
    depth: int = typer.Option(
        2, min=2, help="depth of the initial simulation tree (at most 6 for three controls)"
    ),
    player_model: PlayerModelKind | None = typer.Option(
        None, help="crowd model sr-crowd learns (default SRG_PLAYER_MODEL)"
    ),
    world: int | None = typer.Option(
        None,
        min=0,
        max=MAX_WORLD,
        help="world seed of the start state (default: the canonical start)",
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Create a graph: the initial tree of the dynamics, its leaves blended back."""
    from app.config import get_settings
    from app.core.growth.expansion import initial_tree_clips
    from app.core.liquid.defaults import DEFAULT_LIQUID_PRESET
    from app.db.engines import require_intact
    from app.db.sessions import transaction
    from app.services.creation import init_graph
    from app.services.dynamics import control_count
    from app.services.progress import Advance

    scene_preset = value_of(preset)
    if dynamics is DynamicsName.LIQUID and scene_preset is None:
        scene_preset = DEFAULT_LIQUID_PRESET
    settings = get_settings()
    require_intact(settings)
    shown: Advance | None = None
    with ExitStack() as bar, transaction(settings) as session:

        def advance(n: int) -> None:  # the bar shows once the first clip is simulated,
            nonlocal shown  # after every check (the depth's too): a refusal stays one line
            if shown is None:
                total = initial_tree_clips(control_count(dynamics), depth)
                shown = bar.enter_context(progress_bar(total, "clips of the initial tree"))
            shown(n)

        summary = init_graph(
            session,
            settings,
            name=name,
            dynamics=dynamics.value,
            preset=scene_preset,
            fluid=value_of(fluid),
            strategy=strategy.value,
            depth=depth,
            player_model=value_of(player_model),
            progress=advance,
            world=world,
        )
    emit(summary, json_output)


def grow(
    name: str = typer.Argument(..., help="graph name or id"),
    strategy: Strategy | None = typer.Option(None, help="override the graph's strategy"),
    frames: int | None = typer.Option(
        None, min=1, max=MAX_ROW_ID, help="budget in simulated frames"
    ),
    expansions: int | None = typer.Option(None, min=1, max=MAX_ROW_ID, help="budget in expansions"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Grow a graph in-process (eagerly) by a budget of frames or expansions."""
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.db.sessions import transaction
    from app.services.growing import grow_graph

    if frames is not None and expansions is not None:
        raise InvalidInput("give --frames or --expansions, not both")
    settings = get_settings()
    require_intact(settings)
    total = frames if frames is not None else expansions or settings.growth.batch_size
    label = "frames" if frames is not None else "expansions"
    with progress_bar(total, label) as advance:
        result = grow_graph(
            partial(transaction, settings),
            settings,
            name=name,
            strategy=value_of(strategy),
            frames=frames,
            expansions=expansions,
            progress=advance,
        )
    emit(result, json_output)


def publish(
    name: str = typer.Argument(..., help="graph name or id"),
    render: bool = typer.Option(
        True,
        "--render/--no-render",
        help="render missing animations (--no-render: a version for bots and scripts, "
        "which play edges, not pictures)",
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Relink every blend, render what is missing (strips whose file is missing or
    corrupt included), freeze a publication for players."""
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.db.sessions import transaction
    from app.services.catalogue import missing_animations
    from app.services.publishing import publish_graph

    settings = get_settings()
    require_intact(settings)
    with transaction(settings) as session:
        missing = missing_animations(session, name)
        with progress_bar(missing if render else 0, "animations") as advance:
            result = publish_graph(session, settings, name=name, render=render, progress=advance)
    emit(result, json_output)


def play(
    name: str = typer.Argument(..., help="graph name or id"),
    bot: BotKind = typer.Option(BotKind.GOAL_DIRECTED, help="the bot that plays"),
    sessions: int = typer.Option(20, min=1, help="sessions to play"),
    mean_steps: int = typer.Option(90, min=2, help="mean session length in steps"),
    seed: int | None = typer.Option(
        None,
        min=0,
        help="the bots' seed (default: a fresh one, printed, so a run can be repeated)",
    ),
    url: str | None = typer.Option(None, help="play over HTTP against `srg serve` at this URL"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Bots play the latest publication; their traces are stored like players' uploads,
    under a bot player."""
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.db.sessions import transaction
    from app.services.play import fresh_seed, play_graph

    seed = fresh_seed() if seed is None else seed
    if url is not None:
        from app.api.client import play_over_http

        emit(
            play_over_http(
                url, name, bot.value, sessions=sessions, mean_steps=mean_steps, seed=seed
            ),
            json_output,
        )
        return
    settings = get_settings()
    require_intact(settings)
    with transaction(settings) as session:
        result = play_graph(
            session,
            settings,
            name=name,
            bot=bot.value,
            sessions=sessions,
            mean_steps=mean_steps,
            seed=seed,
        )
    emit(result, json_output)


def status(
    name: str | None = typer.Argument(None, help="graph name or id (default: all graphs)"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Sizes, publications, epochs and play (traces, players, last upload) of one graph or all."""
    from app.config import get_settings
    from app.db.sessions import transaction
    from app.services.catalogue import graph_ids
    from app.services.status import graph_summary

    with transaction(get_settings()) as session:
        graphs = [name] if name is not None else graph_ids(session)
        rows = [graph_summary(session, graph) for graph in graphs]
    if json_output:
        emit(rows if name is None else rows[0], as_json=True)
        return
    if not rows:
        typer.echo("no graphs yet: srg init NAME")
    for row in rows:
        play = row.pop("play")
        assert isinstance(play, dict)
        emit({**row, **play}, as_json=False, title=f"graph {row['name']}")


def gc(
    older_than: float | None = typer.Option(
        None,
        "--older-than",
        min=0,
        help="grace period in seconds: newer files and rows are kept "
        "(default SRG_ARTIFACT_GC_GRACE, 3600)",
    ),
    dry_run: bool = typer.Option(False, "--dry-run", help="count what would go; delete nothing"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Delete artifact files and rows that nothing references (what an interrupted grow left).

    Only files last modified and rows created more than --older-than seconds ago are
    collected, so that what a running step (srg grow, a worker) wrote and is about to
    reference survives: keep it above the longest step. Safe to run while graphs grow;
    srg beat also runs it every SRG_ARTIFACT_GC_INTERVAL seconds.
    """
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.services.artifact_gc import collect_artifacts, count_fanout_directories, grace_seconds

    settings = get_settings()
    grace = grace_seconds(settings, older_than)  # refused before the bar shows
    if not dry_run:
        require_intact(settings)
    directories = count_fanout_directories(settings)
    with progress_bar(directories, "artifact directories") as advance:
        result = collect_artifacts(settings, older_than=grace, dry_run=dry_run, progress=advance)
    emit(result, json_output)


def fsck(
    repair: bool = typer.Option(
        False,
        "--repair",
        help="recompute corrupt or missing clips from their stored states, and strips "
        "from their clips",
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Check every artifact against its hash and the database file; exit 1 if something
    is still wrong.

    A file that fails is moved aside (corrupt/ under the artifact directory) so that
    nothing reads it again. With --repair, a clip is simulated again from the state it
    started from, and a strip rendered again from its clip, each stored only if its bytes
    hash to what the database holds; a warm start is forgotten; anything else is
    reported. Safe to run while graphs grow.
    """
    from app.config import get_settings
    from app.services.fsck import count_to_scan
    from app.services.fsck import fsck as check

    settings = get_settings()
    with progress_bar(count_to_scan(settings), "artifacts") as advance:
        result = check(settings, repair=repair, progress=advance)
    emit(result, json_output)
    if not result.sound:
        raise typer.Exit(1)
