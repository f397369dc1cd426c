"""``srg results``: a stored experiment judged, from its database alone."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from app.cli.choices import seed_list
from app.cli.output import JSON_HELP, emit
from app.core.errors import InvalidInput

if TYPE_CHECKING:
    from app.core.evaluation.scoreboard import Bar
    from app.services.experiment.scoreboard import StoredPlay

app = typer.Typer(help="A stored experiment judged from its database.", no_args_is_help=True)


@app.command("scoreboard")
def scoreboard(
    name: str = typer.Argument(..., help="the stored experiment"),
    primary_players: str | None = typer.Option(
        None,
        help="whose error the primary endpoint is (default: the fresh population, else "
        "the population, else the first crowd)",
    ),
    outside: Path | None = typer.Option(
        None,
        help="an outside judge's JSON lines on the experiment's publications (one per "
        "world, strategy and publication: publication_id, mean_error, high_share)",
    ),
    plays: list[Path] | None = typer.Option(
        None,
        "--from",
        help="judge these play files (srg results export; repeat the option) instead of "
        "the database: the parts of a study grown on several machines",
    ),
    figures: Path | None = typer.Option(
        None,
        help="also draw the visibly-wrong share against frames and the error histograms "
        "(the paper's Figs. 6 and 7) into this directory",
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """The primary endpoint, every bar with its interval and verdict, and frames to a
    clean game (docs/experiment.md, "Scoreboard").

    Bars that cannot fail (no error or no visibly wrong step in any world, every arm clean
    at the first checkpoint) are listed and left out of the count.
    """
    from app.services.experiment.scoreboard import scoreboard as judge
    from app.services.experiment.scoreboard import scoreboard_figures

    play = _play(name, outside, plays)
    board = judge(play, primary_players=primary_players)
    if figures is not None:
        for drawn in scoreboard_figures(board, play, figures):
            typer.echo(f"figure: {drawn}", err=True)
    if json_output:
        emit(board.to_dict(), as_json=True)
        return
    typer.echo(f"{name}: {len(board.seeds)} worlds ({_listed(board.seeds)})")
    if board.missing:
        typer.echo(f"not reached by every run: {_listed(board.missing)} frames")
    for bar in (board.primary, *board.bars):
        typer.echo(_bar_line(bar, reached=bar.frames not in board.missing))
    for clean in board.clean:
        spread = "; ".join(
            f"{strategy} {_frames(s['median'])} ({_frames(s['min'])}-{_frames(s['max'])}, "
            f"{s['reached']} of {len(board.seeds)} worlds)"
            for strategy, s in clean.summary().items()
        )
        typer.echo(f"frames to under {clean.bar:.1%} visibly wrong, median (range): {spread}")
    met, judged = board.counted()
    typer.echo(f"{met} of {judged} bars that can fail met")


@app.command("export")
def export(
    name: str = typer.Argument(..., help="the stored experiment"),
    path: Path = typer.Argument(..., help="the play file to write (.npz)"),
    outside: Path | None = typer.Option(
        None, help="an outside judge's JSON lines on its publications, kept in the file"
    ),
    only_seeds: str | None = typer.Option(
        None, help="only the rows of these comma-separated seeds (the worlds grown here)"
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Write what the scoreboard reads of a stored experiment (every checkpoint row's
    per-step errors, an outside judge's figures) to one small file, to judge later with
    --from beside the parts grown elsewhere (docs/experiment.md, "A study over several
    machines")."""
    from app.services.experiment.play_files import of_seeds, write_play

    play = _play(name, outside, None)
    if only_seeds is not None:
        play = of_seeds(play, seed_list(only_seeds, "--only-seeds"))
    write_play(play, path)
    written = {"path": str(path), "checkpoint_rows": len(play.rows), "outside": len(play.outside)}
    emit(written, as_json=json_output, title=f"{name}: play written")


def _play(name: str, outside: Path | None, plays: list[Path] | None) -> StoredPlay:
    """The play judged: read from the database, or merged from play files."""
    if not plays:
        from app.config import get_settings
        from app.services.experiment.scoreboard import read_play

        return read_play(get_settings(), name, outside)
    from app.services.experiment.play_files import read_plays

    if outside is not None:
        raise InvalidInput("--outside is read when a play file is written (srg results export)")
    play = read_plays(plays)
    if play.name != name:
        raise InvalidInput(f"{plays[0]} holds the experiment {play.name!r}, not {name!r}")
    return play


def _bar_line(bar: Bar, *, reached: bool) -> str:
    where = f"{bar.players} at {bar.frames}" if bar.players else f"over worlds, to {bar.frames}"
    if bar.low is None or bar.high is None:
        estimate = "n/a" if bar.mean is None else f"{bar.mean:.3g}"
    else:
        estimate = f"{bar.mean:.3g} [{bar.low:.3g}, {bar.high:.3g}]"
    verdict = "met" if bar.met else "NOT met"
    if not reached:
        verdict = "not reached by every run yet, not counted"
    elif not bar.can_fail:
        verdict = "cannot fail, not counted"
    head = "PRIMARY " if bar.primary else ""
    return f"{head}{bar.endpoint}, {where}: {estimate} ({bar.rule}: {verdict})"


def _frames(value: float | int | None) -> str:
    return "beyond" if value is None else f"{value:,.0f}"


def _listed(values: tuple[int, ...]) -> str:
    return ", ".join(str(v) for v in values)
