"""What an experiment runs: its plan, fixed and stored when it is created.

The plan is stored as JSON with the experiment, and a resume runs the stored plan
again, so every option that changes a figure lives here, the high-error threshold
included (docs/experiment.md).

A seed is a world: it seeds the start state of every graph of its runs
(``Dynamics.initial_state``) as well as the bots that play them, so that the interval
over seeds samples the graphs' variability, trace-blind strategies' included
(docs/experiment.md, "World seeds"). Models and settings are chosen on
:data:`SELECTION_SEEDS`; an experiment runs either on them or on none of them
(docs/experiment.md, "Selection and evaluation seeds").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Literal

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import Conflict, InvalidInput, NotFound
from app.core.growth.kinds import Strategy, parse_strategy
from app.core.names import check_name
from app.core.players.kinds import BotKind, PlayerModelKind, parse_bot, parse_player_model
from app.db.limits import MAX_WORLD
from app.db.sessions import transaction
from app.liquid.devices import LiquidDevices
from app.services.dynamics import (
    DYNAMICS_NAMES,
    UnknownDynamics,
    make_dynamics,
    threshold_in_force,
)
from app.services.experiment.players import (
    FRESH,
    POPULATION,
    PlayerGroup,
    check_shares,
    share_sessions,
)
from app.store.experiments import (
    add_experiment,
    existing_graph_names,
    experiment_id,
    experiment_plan,
)

#: the seeds on which the project's models and settings are chosen, fixed before any
#: evaluation run: a figure reported as evidence comes from other seeds; 15-19 were
#: added for confirming a choice on worlds it was not chosen on (docs/experiment.md)
SELECTION_SEEDS = tuple(range(10, 20))

#: what an experiment's seeds are for: choosing models and settings, or judging them
SeedRole = Literal["selection", "evaluation"]


class ExperimentExists(Conflict):
    """An experiment of that name is stored: resume it or choose another name."""


class NothingToResume(NotFound):
    """No experiment of that name is stored."""


@dataclass(frozen=True)
class ExperimentPlan:
    """What an experiment runs (docs/experiment.md).

    A plan with sr-crowd always runs sr-heuristic too: it is sr-crowd's control, the
    same STATERANK growth under the heuristic player model, so that a gain sr-crowd
    shares with it is told apart as STATERANK's rather than the players'. It is added
    (before sr-crowd) when not given. max-error runs only when asked for.

    Every seed is a world (``worlds``): the graphs of its runs start from
    ``initial_state(seed)``, trace-blind strategies get a run per seed. A plan stored
    before world seeds (``worlds=False``) keeps its layout: one trace-blind graph per
    strategy from the canonical start, its strategies and seeds as stored.
    """

    dynamics: str = "toy"
    preset: str | None = None
    fluid: str | None = None
    strategies: tuple[Strategy, ...] = (
        Strategy.BASELINE,
        Strategy.SR_HEURISTIC,
        Strategy.SR_CROWD,
    )
    #: evaluation seeds unless all of them are :attr:`selection_seeds`
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
    #: the crowds play as one: one run per seed of each strategy that learns, taught by
    #: every crowd's traces (docs/experiment.md, "Judges")
    pooled: bool = False
    #: crowds that play every run at every checkpoint and teach none: their traces are
    #: not stored, so a learned model is judged by players it never saw
    judges: tuple[BotKind, ...] = ()
    #: each crowd's share of ``sessions`` at every checkpoint, in ``bots``' order (pooled
    #: crowds only; empty: every crowd plays ``sessions``)
    shares: tuple[float, ...] = ()
    #: every crowd's kind also judges: as many sessions as the crowd plays, on other
    #: seeds, never stored (the paper's test players; docs/experiment.md, "Judges")
    fresh_judges: bool = False
    #: the pre-registered plan the experiment runs under, as (path, sha256 of its bytes):
    #: a resume refuses a plan file that changed (docs/experiment.md, "Pre-registration")
    preregistration: tuple[str, str] | None = None
    #: whether each seed is a world (its graphs start from ``initial_state(seed)``)
    worlds: bool = True
    #: the seeds models and settings are chosen on (:data:`SELECTION_SEEDS` when made)
    selection_seeds: tuple[int, ...] = SELECTION_SEEDS

    @property
    def role(self) -> SeedRole:
        """``selection`` when the seeds are selection seeds, else ``evaluation``."""
        return "selection" if set(self.seeds) <= set(self.selection_seeds) else "evaluation"

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
        if self.worlds:
            self._check_world_seeds()
            object.__setattr__(self, "strategies", _with_control(self.strategies))
        if not self.bots or len(set(self.bots)) != len(self.bots):
            raise InvalidInput("give one or more distinct bots")
        if len(set(self.judges)) != len(self.judges) or set(self.judges) & set(self.bots):
            raise InvalidInput("judges must be distinct bots that are not among the crowds")
        if self.judges and len(self.bots) > 1 and not self.pooled:
            raise InvalidInput(
                "judges play one learning run per seed: give one crowd, or pool the crowds"
            )
        if self.shares:
            check_shares(self.shares, len(self.bots), self.sessions, pooled=self.pooled)
        if min(self.sessions, self.batch_size, self.fixed_graph_sessions) < 1:
            raise InvalidInput("sessions and batch size must be positive")
        if self.mean_steps < 2:
            raise InvalidInput("mean steps must be at least 2")
        if self.high_error_threshold is not None and not self.high_error_threshold > 0:
            raise InvalidInput("the high-error threshold must be positive")
        _check_checkpoints(self.checkpoints)

    def _check_world_seeds(self) -> None:
        """Seeds are worlds (:data:`~app.services.creation.MAX_WORLD`, as the graphs
        store them), all selection seeds or none of them."""
        outside = [s for s in self.seeds if not 0 <= s <= MAX_WORLD]
        if outside:
            raise InvalidInput(
                f"seeds are worlds, at most {MAX_WORLD} and non-negative: got {_listed(outside)}"
            )
        chosen = [s for s in self.seeds if s in self.selection_seeds]
        if chosen and len(chosen) < len(self.seeds):
            others = [s for s in self.seeds if s not in self.selection_seeds]
            raise InvalidInput(
                f"seeds {_listed(chosen)} are selection seeds ({_listed(self.selection_seeds)}) "
                f"and {_listed(others)} are not: give only selection seeds or none of them"
            )

    def crowd_sessions(self, bot: BotKind) -> int:
        """The sessions ``bot``'s crowd plays at each checkpoint of a run."""
        if not self.shares:
            return self.sessions
        return share_sessions(self.shares[self.bots.index(bot)], self.sessions)

    def groups(self, run: Run) -> list[PlayerGroup]:
        """Who plays ``run`` at each checkpoint: its crowds (stored), their fresh judges
        (when ``fresh_judges``), then the other judges."""
        crowds = [PlayerGroup(b.value, b, self.crowd_sessions(b), True) for b in run.crowds]
        fresh = [
            PlayerGroup(FRESH + group.label, group.bot, group.sessions, False)
            for group in crowds
            if self.fresh_judges
        ]
        judges = [PlayerGroup(b.value, b, self.sessions, False) for b in self.judges]
        return [*crowds, *fresh, *judges]

    @property
    def populations(self) -> dict[str, tuple[str, ...]]:
        """The labels whose steps are also judged together: a pooled plan's crowds
        (:data:`POPULATION`) and their fresh judges (``fresh-population``)."""
        if not (self.pooled and len(self.bots) > 1):
            return {}
        crowds = tuple(b.value for b in self.bots)
        together = {POPULATION: crowds}
        if self.fresh_judges:
            together[FRESH + POPULATION] = tuple(FRESH + c for c in crowds)
        return together

    @classmethod
    def quick(cls, dynamics: str = "toy", **changes: Any) -> ExperimentPlan:
        """Minutes, not hours: three small checkpoints."""
        return cls(dynamics=dynamics, **{"checkpoints": (1_000, 3_000, 6_000), **changes})

    @property
    def players(self) -> tuple[str, ...]:
        """The label of everyone whose play is measured: the crowds, their fresh judges,
        then the other judges."""
        fresh = tuple(FRESH + b.value for b in self.bots) if self.fresh_judges else ()
        return (*(b.value for b in self.bots), *fresh, *(b.value for b in self.judges))

    @property
    def runs(self) -> list[Run]:
        """Every run is one world seed. A strategy that reads no traces has one run per
        seed, played by that seed's bots of every crowd: its growth reads no traces, so
        a graph per crowd would be the same graph grown again. A strategy that learns
        from traces has one run per crowd and seed, played by its own crowd (with
        ``pooled``, one run per seed, played and taught by every crowd). Judges play
        every run without teaching any.

        A plan stored before world seeds has one run of each trace-blind strategy,
        from the canonical start, played by every seed's bots of every crowd."""
        return [run for strategy in self.strategies for run in self._runs_of(strategy)]

    def _runs_of(self, strategy: Strategy) -> list[Run]:
        if not (self.worlds or strategy.learns_from_traces):
            return [Run(strategy, self.seeds, self.bots)]
        world = {seed: seed if self.worlds else None for seed in self.seeds}
        if strategy.learns_from_traces and not self.pooled:
            return [
                Run(strategy, (seed,), (bot,), world[seed])
                for bot in self.bots
                for seed in self.seeds
            ]
        return [Run(strategy, (seed,), self.bots, world[seed]) for seed in self.seeds]

    def run_graph(self, experiment: str, run: Run) -> str:
        """The stored graph of ``run``: ``EXPERIMENT.STRATEGY.SEED``, with the crowd's
        name before the seed for a run that learns in a plan with several crowds; a
        trace-blind run of a plan stored before world seeds is ``EXPERIMENT.STRATEGY``."""
        if not run.strategy.learns_from_traces:
            if not self.worlds:
                return f"{experiment}.{run.strategy.value}"
            return run_graph_name(experiment, run.strategy, run.seeds[0])
        crowd = run.crowds[0] if len(self.bots) > 1 and not self.pooled else None
        return run_graph_name(experiment, run.strategy, run.seeds[0], crowd)

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["strategies"] = [s.value for s in self.strategies]
        data["seeds"], data["checkpoints"] = list(self.seeds), list(self.checkpoints)
        data["player_model"] = self.player_model.value
        data["bots"] = [b.value for b in self.bots]
        data["judges"] = [b.value for b in self.judges]
        data["selection_seeds"] = list(self.selection_seeds)
        data["shares"] = list(self.shares)
        data["preregistration"] = (
            None if self.preregistration is None else list(self.preregistration)
        )
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
        values["judges"] = tuple(parse_bot(b) for b in data.get("judges", ()))
        # plans stored before world seeds resume as they were: one trace-blind graph
        # per strategy, from the canonical start
        values["worlds"] = bool(data.get("worlds", False))
        if "selection_seeds" in values:
            values["selection_seeds"] = tuple(int(s) for s in values["selection_seeds"])
        values["shares"] = tuple(float(s) for s in data.get("shares", ()))
        if data.get("preregistration"):
            path, digest = data["preregistration"]
            values["preregistration"] = (str(path), str(digest))
        return cls(**values)


@dataclass(frozen=True)
class Run:
    """One stored graph of an experiment: a strategy, the seeds and crowds whose bots
    play it (each pair gets its own checkpoint rows), and the world seed its start
    state is made from (None: the canonical start, in plans stored before worlds)."""

    strategy: Strategy
    seeds: tuple[int, ...]
    crowds: tuple[BotKind, ...]
    world: int | None = None


def run_graph_name(
    experiment: str, strategy: Strategy, seed: int, crowd: BotKind | None = None
) -> str:
    """The graph of a run of one seed (:meth:`ExperimentPlan.run_graph`)."""
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


def _with_control(strategies: tuple[Strategy, ...]) -> tuple[Strategy, ...]:
    """``strategies`` with sr-heuristic before sr-crowd when sr-crowd has not got it."""
    if Strategy.SR_CROWD not in strategies or Strategy.SR_HEURISTIC in strategies:
        return strategies
    at = strategies.index(Strategy.SR_CROWD)
    return (*strategies[:at], Strategy.SR_HEURISTIC, *strategies[at:])


def _listed(values: Sequence[int]) -> str:
    return ", ".join(str(v) for v in values)


def _check_checkpoints(values: Sequence[int]) -> None:
    if not values or any(v <= 0 for v in values) or list(values) != sorted(set(values)):
        raise InvalidInput(f"checkpoints must be increasing positive frame counts, got {values}")
