"""``srg bench ...``: speed and memory figures as JSON (targets live here, never in tests)."""

from __future__ import annotations

import json

import typer

bench_app = typer.Typer(help="Benchmarks; each prints JSON.", no_args_is_help=True)


def _print(result: dict[str, object]) -> None:
    typer.echo(json.dumps(result, indent=2, default=str))


@bench_app.command("rank")
def bench_rank_command(
    edges: int = typer.Option(1_000_000, help="edges of the synthetic grown graph"),
    controls: int = typer.Option(3, help="controls N"),
    seed: int = typer.Option(0),
    json_output: bool = typer.Option(True, "--json/--no-json", help="print JSON (default)"),
) -> None:
    """One cold and one warm STATERANK (after one expansion), next to networkx.pagerank."""
    from app.bench.rank import bench_rank

    if edges < controls * 10:
        raise ValueError(f"--edges must be at least {controls * 10}")
    _print(bench_rank(n_edges=edges, n_controls=controls, seed=seed))


@bench_app.command(
    "experiment", context_settings={"allow_extra_args": True, "ignore_unknown_options": True}
)
def bench_experiment_command(ctx: typer.Context) -> None:
    """Wall and CPU time of `srg experiment ARGS...` from an empty database.

    For example: srg bench experiment --dynamics liquid --preset tiny --seeds 0
    --checkpoints 2000,5000,10000,20000 (the paper's four strategies to 20k frames).
    """
    from app.bench.experiment import bench_experiment

    if any(arg in ("--json", "--resume", "--name", "--out") for arg in ctx.args):
        raise ValueError(
            "the benchmark runs a fresh experiment: leave out --json, --resume, --name, --out"
        )
    _print(bench_experiment(list(ctx.args)))
