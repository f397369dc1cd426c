"""What an experiment runs: its plan, fixed and stored when it is created.

The plan is stored as JSON with the experiment, and a resume runs the stored plan
again, so every option that changes a figure lives here, the high-error threshold
included (docs/experiment.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.bots import BotKind, parse_bot
from app.core.errors import Conflict, InvalidInput, NotFound
from app.core.names import check_name
from app.core.player_models import PlayerModelKind, parse_player_model
from app.core.strategies import Strategy, parse_strategy
from app.db.sessions import transaction
from app.liquid.devices import LiquidDevices
from app.services.dynamics import (
    DYNAMICS_NAMES,
    UnknownDynamics,
    make_dynamics,
    threshold_in_force,
)
from app.store.experiments import (
    add_experiment,
    existing_graph_names,
    experiment_id,
    experiment_plan,
)


class ExperimentExists(Conflict):
    """An experiment of that name is stored: resume it or choose another name."""


class NothingToResume(NotFound):
    """No experiment of that name is stored."""


@dataclass(frozen=True)
class ExperimentPlan:
    dynamics: str = "toy"
    preset: str | None = None
    fluid: str | None = None
    strategies: tuple[Strategy, ...] = (
        Strategy.MAX_ERROR,
        Strategy.BASELINE,
        Strategy.SR_HEURISTIC,
        Strategy.SR_CROWD,
    )
    seeds: tuple[int, ...] = (0, 1, 2)
    checkpoints: tuple[int, ...] = (2_000, 5_000, 10_000, 20_000)
    sessions: int = 30
    mean_steps: int = 60
    batch_size: int = 8
    #: the crowd model sr-crowd learns
    player_model: PlayerModelKind = PlayerModelKind.EQ2
    #: the crowds: each plays every checkpoint of the runs that read no traces, and grows
    #: its own run of each strategy that learns from traces (docs/experiment.md, "Crowds")
    bots: tuple[BotKind, ...] = (BotKind.GOAL_DIRECTED,)
    #: sessions per half of the fixed-graph setting (Fig. 8), on baseline's last checkpoint
    fixed_graph_sessions: int = 100
    #: fixed when the experiment is created (the calibration's, unless set), so that every
    #: checkpoint, resumed or not, counts high-error steps against one threshold
    high_error_threshold: float | None = None

    def checkpoint_index(self, frames: int | None) -> int:
        """The index of the checkpoint at ``frames`` (the last when None)."""
        if frames is None:
            return len(self.checkpoints) - 1
        if frames not in self.checkpoints:
            known = ", ".join(str(c) for c in self.checkpoints)
            raise InvalidInput(f"--through must be one of the plan's checkpoints ({known})")
        return self.checkpoints.index(frames)

    def __post_init__(self) -> None:
        if self.dynamics not in DYNAMICS_NAMES:
            raise UnknownDynamics(f"unknown dynamics {self.dynamics!r}")
        if self.dynamics == "toy" and (self.preset or self.fluid):
            raise InvalidInput("the toy dynamics has no preset or fluid: leave them out")
        if not self.strategies or len(set(self.strategies)) != len(self.strategies):
            raise InvalidInput("give one or more distinct strategies")
        if not self.seeds or len(set(self.seeds)) != len(self.seeds):
            raise InvalidInput("give one or more distinct seeds")
        if not self.bots or len(set(self.bots)) != len(self.bots):
            raise InvalidInput("give one or more distinct bots")
        if min(self.sessions, self.batch_size, self.fixed_graph_sessions) < 1:
            raise InvalidInput("sessions and batch size must be positive")
        if self.mean_steps < 2:
            raise InvalidInput("mean steps must be at least 2")
        if self.high_error_threshold is not None and not self.high_error_threshold > 0:
            raise InvalidInput("the high-error threshold must be positive")
        _check_checkpoints(self.checkpoints)

    @classmethod
    def quick(cls, dynamics: str = "toy", **changes: Any) -> ExperimentPlan:
        """Minutes, not hours: three small checkpoints."""
        return cls(dynamics=dynamics, **{"checkpoints": (1_000, 3_000, 6_000), **changes})

    @property
    def runs(self) -> list[Run]:
        """One run of each strategy that reads no traces, played by every seed's bots of
        every crowd: its growth reads neither traces nor seeds, so a graph per seed or per
        crowd would be the same graph grown again. One run per crowd and seed of each
        strategy that learns from traces, played by its own crowd with its seed's bots."""
        return [
            run
            for strategy in self.strategies
            for run in (
                [Run(strategy, (seed,), (bot,)) for bot in self.bots for seed in self.seeds]
                if strategy.learns_from_traces
                else [Run(strategy, self.seeds, self.bots)]
            )
        ]

    def run_graph(self, experiment: str, run: Run) -> str:
        """The stored graph of ``run``: ``EXPERIMENT.STRATEGY`` for a run that reads no
        traces; ``EXPERIMENT.STRATEGY.SEED`` for one that learns, with the crowd's name
        before the seed in a plan with several crowds."""
        if not run.strategy.learns_from_traces:
            return f"{experiment}.{run.strategy.value}"
        crowd = run.crowds[0] if len(self.bots) > 1 else None
        return run_graph_name(experiment, run.strategy, run.seeds[0], crowd)

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["strategies"] = [s.value for s in self.strategies]
        data["seeds"], data["checkpoints"] = list(self.seeds), list(self.checkpoints)
        data["player_model"] = self.player_model.value
        data["bots"] = [b.value for b in self.bots]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ExperimentPlan:
        known = {f.name for f in fields(cls)}
        values = {k: v for k, v in data.items() if k in known}
        values["strategies"] = tuple(parse_strategy(s) for s in values["strategies"])
        values["seeds"] = tuple(int(s) for s in values["seeds"])
        values["checkpoints"] = tuple(int(c) for c in values["checkpoints"])
        if "player_model" in values:
            values["player_model"] = parse_player_model(values["player_model"])
        # plans stored before crowds name one bot
        bots = data.get("bots", [data["bot"]] if "bot" in data else None)
        if bots is not None:
            values["bots"] = tuple(parse_bot(b) for b in bots)
        return cls(**values)


@dataclass(frozen=True)
class Run:
    """One stored graph of an experiment: a strategy, and the seeds and crowds whose bots
    play it (each pair gets its own checkpoint rows)."""

    strategy: Strategy
    seeds: tuple[int, ...]
    crowds: tuple[BotKind, ...]


def run_graph_name(
    experiment: str, strategy: Strategy, seed: int, crowd: BotKind | None = None
) -> str:
    """The graph of a learning run (:meth:`ExperimentPlan.run_graph`)."""
    middle = strategy.value if crowd is None else f"{strategy.value}.{crowd.value}"
    return f"{experiment}.{middle}.{seed}"


def create_experiment(settings: Settings, name: str, plan: ExperimentPlan) -> ExperimentPlan:
    """Store a new experiment's plan, its high-error threshold fixed; return that plan.

    The threshold is ``SRG_HIGH_ERROR_THRESHOLD``, else the dynamics' calibrated one.
    Raises :class:`ExperimentExists` if the name is taken, and ``make_dynamics``'s errors
    (an unknown preset or fluid, a missing calibration) before anything is stored.
    """
    _check_name(name)
    devices = LiquidDevices.from_settings(settings)
    dynamics = make_dynamics(plan.dynamics, plan.preset, plan.fluid, devices=devices)
    if plan.high_error_threshold is None:
        plan = replace(plan, high_error_threshold=threshold_in_force(settings, dynamics))
    with transaction(settings) as session:
        if experiment_id(session, name) is not None:
            raise ExperimentExists(
                f"an experiment named {name!r} exists: add --resume, or choose another --name"
            )
        runs = [plan.run_graph(name, run) for run in plan.runs]
        clashes = existing_graph_names(session, runs)
        if clashes:
            taken = ", ".join(clashes)
            raise ExperimentExists(f"graphs named {taken} exist: choose another --name")
        add_experiment(session, name, plan.to_dict())
    return plan


def stored_plan(settings: Settings, name: str) -> ExperimentPlan:
    """The plan of a stored experiment; :class:`NothingToResume` if there is none."""
    with transaction(settings) as session:
        plan = experiment_plan(session, name)
    if plan is None:
        raise NothingToResume(f"no experiment named {name!r} to resume")
    return ExperimentPlan.from_dict(plan)


def stored_experiment_id(session: Session, name: str) -> int:
    """The id of a stored experiment; :class:`NothingToResume` if there is none."""
    found = experiment_id(session, name)
    if found is None:
        raise NothingToResume(f"no experiment named {name!r}")
    return found


def parse_checkpoints(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise InvalidInput(
            f"checkpoints must be comma-separated frame counts, got {text!r}"
        ) from None
    _check_checkpoints(values)
    return values


def _check_name(name: str) -> None:
    # 120, not the column's 200: the run graphs' names add ".<strategy>[.<crowd>].<seed>"
    check_name(name, what="experiment", max_length=120)


def _check_checkpoints(values: Sequence[int]) -> None:
    if not values or any(v <= 0 for v in values) or list(values) != sorted(set(values)):
        raise InvalidInput(f"checkpoints must be increasing positive frame counts, got {values}")
