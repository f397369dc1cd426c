"""The runs of an experiment through their checkpoints, resumable, in parallel processes.

Growth goes through a :data:`Grower`: in-process (:func:`grow_in_process`), or the
Celery ``grow_epoch`` workflow on workers (``app.tasks.growth.grow_on_workers``), which
the shell picks. Runs (the plan's :class:`~app.services.experiment.plan.Run`) are
independent, so they go to parallel processes, one checkpoint at a time: every run
reaches a checkpoint before any grows towards the next, so an experiment stopped
anywhere holds a complete comparison up to its last checkpoint. A run skips the
checkpoints already stored, which is what makes ``--resume`` work (docs/experiment.md).
"""

from __future__ import annotations

import ctypes
import os
import resource
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import partial
from multiprocessing import get_context
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any

from app.config import Settings
from app.core.errors import InvalidInput
from app.db.sessions import transaction
from app.services.creation import init_graph
from app.services.experiment.checkpoint import checkpoint_figures
from app.services.experiment.plan import ExperimentPlan, stored_experiment_id
from app.services.experiment.results import collect
from app.services.growing import grow_graph
from app.services.loading import artifact_store
from app.services.progress import Advance
from app.store.experiments import add_checkpoint, done_checkpoints, frames_of_graphs
from app.store.graph_catalogue import graph_exists

#: seconds between two looks at the run processes (and the frames they grew)
PROGRESS_POLL = 1.0
#: seconds between a run process's two looks at whether its parent still lives (where
#: the kernel cannot be asked to kill it with its parent)
PARENT_POLL = 0.5
#: prctl(2)'s option naming the signal a process gets when its parent dies (linux/prctl.h)
PR_SET_PDEATHSIG = 1

#: grows the stored graph ``name`` to at least ``to_frames`` frames, ``batch`` blends an epoch
Grower = Callable[[str, int, int, Advance | None], None]


def grow_in_process(
    settings: Settings, name: str, to_frames: int, batch: int, progress: Advance | None
) -> None:
    """Grow in this process, every step its own transaction, without renders.

    A :data:`Grower` once its settings are bound (``functools.partial``, which a
    spawned run process can unpickle).
    """
    grow_graph(
        partial(transaction, settings),
        settings,
        name=name,
        to_frames=to_frames,
        renders=False,
        batch_size=batch,
        progress=progress,
    )


def run_experiment(
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    grower: Grower,
    *,
    jobs: int = 1,
    progress: Advance | None = None,
    through: int | None = None,
    runs: Sequence[int] | None = None,
) -> dict[str, Any]:
    """Run (or finish) the runs ``runs`` (indices into ``plan.runs``; all when None) of
    the stored experiment ``name`` of ``plan``, through checkpoint index ``through`` (all
    when None); return :func:`collect`'s result up to there.

    ``jobs > 1`` runs that many (strategy, seed) runs at once in spawned processes
    (PyOpenCL contexts do not survive a fork); progress then comes from the database.
    The plan, read or stored once by the caller, is handed to every run, spawned ones
    included.
    """
    started = time.perf_counter()
    reported = 0
    chosen = list(range(len(plan.runs)) if runs is None else runs)
    for last in range(len(plan.checkpoints) if through is None else through + 1):
        if jobs <= 1:
            for run in chosen:
                run_one(settings, name, plan, run, grower, progress, last=last)
        else:
            reported = _run_in_processes(
                settings, name, plan, grower, jobs, progress, last, reported, chosen
            )
    seconds = time.perf_counter() - started
    return collect(settings, name, plan_of_runs(plan, runs), seconds=seconds, through=through)


def runs_of_seeds(plan: ExperimentPlan, seeds: tuple[int, ...] | None) -> list[int]:
    """The indices of ``plan``'s runs that any of ``seeds`` plays (every run when None)."""
    if seeds is None:
        return list(range(len(plan.runs)))
    if not seeds or set(seeds) - set(plan.seeds):
        known = ", ".join(str(s) for s in plan.seeds)
        raise InvalidInput(f"--only-seeds must name seeds of the plan ({known})")
    return [i for i, run in enumerate(plan.runs) if set(run.seeds) & set(seeds)]


def plan_of_runs(plan: ExperimentPlan, runs: Sequence[int] | None) -> ExperimentPlan:
    """``plan`` as far as ``runs`` go (all: ``plan``): the seeds they play, what the result
    and the report of a part grown alone (``--only-seeds``) cover."""
    if runs is None:
        return plan
    played = {seed for run in runs for seed in plan.runs[run].seeds}
    return replace(plan, seeds=tuple(seed for seed in plan.seeds if seed in played))


def _run_in_processes(
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    grower: Grower,
    jobs: int,
    progress: Advance | None,
    last: int,
    reported: int,
    chosen: list[int],
) -> int:
    """The runs ``chosen`` through checkpoint ``last`` in at most ``jobs`` spawned processes at a
    time; the first failure stops them all (what they finished is stored, so ``--resume``
    goes on from there). Returns the frames reported to ``progress`` so far,
    ``reported`` included.

    Every run process is started by this (the main) thread: the kernel's parent-death
    signal (:func:`die_with_parent`) follows the thread that started a process, so run
    processes started by a pool's helper thread were killed when that thread ended,
    while waiting for work, holding the pool's queue lock, and the pool never closed.
    """
    context = get_context("spawn")
    waiting = list(chosen)
    running: dict[int, tuple[BaseProcess, Connection]] = {}
    try:
        while waiting or running:
            while waiting and len(running) < jobs:
                run = waiting.pop(0)
                receive, send = context.Pipe(duplex=False)
                started: BaseProcess = context.Process(
                    target=_run_process,
                    args=(os.getpid(), send, settings, name, plan, run, grower, last),
                    name=f"{name}-run-{run}",
                )
                started.start()
                send.close()
                running[run] = (started, receive)
            time.sleep(PROGRESS_POLL)
            for run, (child, receive) in list(running.items()):
                if receive.poll():
                    error = receive.recv()
                elif child.is_alive():
                    continue
                else:
                    error = RuntimeError(f"run {run} ended with exit code {child.exitcode}")
                child.join()
                receive.close()
                del running[run]
                if error is not None:
                    raise error
            if progress is not None:
                grown = frames_grown(settings, name, plan, chosen)
                progress(grown - reported)
                reported = grown
    finally:
        for child, receive in running.values():
            child.kill()
            child.join()
            receive.close()
    return reported


def _run_process(
    parent: int,
    report: Connection,
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    run: int,
    grower: Grower,
    last: int,
) -> None:
    """A run process's body: one run through checkpoint ``last``; sends None when done or
    the run's error (which the experiment's process raises)."""
    die_with_parent(parent)
    try:
        run_one(settings, name, plan, run, grower, None, last)
    except Exception as error:  # handed to the parent, which raises it
        report.send(error)
        return
    report.send(None)


def die_with_parent(parent: int) -> None:
    """In a run process: die with the experiment's process.

    A pool's processes outlive a SIGKILLed parent (nothing terminates them) and would go
    on writing to the graphs a ``--resume`` is about to grow. On Linux the kernel kills
    the run process when its parent dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``, kept
    across its exec): no code of the run process has to notice, as a thread watching the
    parent's pid did up to seconds late, after checkpoints were written, behind a main
    thread holding the GIL. Elsewhere that thread is what there is. A parent already
    gone when this runs (the run process was still starting) shows in its pid: the run
    process exits before it takes a run.
    """
    if sys.platform == "linux":
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    else:
        threading.Thread(
            target=_exit_when_orphaned, args=(parent,), name="die-with-parent", daemon=True
        ).start()
    if os.getppid() != parent:
        os._exit(1)


def _exit_when_orphaned(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(PARENT_POLL)
    os._exit(1)


def frames_grown(settings: Settings, name: str, plan: ExperimentPlan, runs: Sequence[int]) -> int:
    """Frames stored so far over the graphs of ``runs`` (what the progress bar counts)."""
    graphs = [plan.run_graph(name, plan.runs[run]) for run in runs]
    with transaction(settings) as session:
        return frames_of_graphs(session, graphs)


def run_one(
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    run_index: int,
    grower: Grower,
    progress: Advance | None = None,
    last: int | None = None,
) -> None:
    """The run ``run_index`` of the stored experiment ``name``'s ``plan`` through its
    checkpoints (up to index ``last``, all when None), skipping those already stored (a
    resume). Its graph starts from the run's world (``Run.world``)."""
    run = plan.runs[run_index]
    strategy = run.strategy
    graph = plan.run_graph(name, run)
    with transaction(settings) as session:
        stored_id = stored_experiment_id(session, name)
        done = done_checkpoints(
            session, stored_id, strategy.value, run.seeds[0], run.crowds[0].value
        )
        exists = graph_exists(session, graph)
    if not exists:
        with transaction(settings) as session:
            summary = init_graph(
                session,
                settings,
                name=graph,
                dynamics=plan.dynamics,
                preset=plan.preset,
                fluid=plan.fluid,
                strategy=strategy.value,
                seed=run.seeds[0],
                player_model=plan.player_model.value,
                world=run.world,
            )
        if progress is not None:
            progress(int(summary["size_frames"]))  # type: ignore[call-overload]
    for index, checkpoint in enumerate(plan.checkpoints[: None if last is None else last + 1]):
        if index in done:
            continue
        started = time.perf_counter()
        grower(graph, checkpoint, plan.batch_size, progress)
        grow_seconds = time.perf_counter() - started
        with transaction(settings) as session:
            crowds = checkpoint_figures(session, settings, plan, graph, run, index)
            seconds = round(time.perf_counter() - started, 3)
            for (seed, bot), figures, arrays in crowds:
                figures["grow_seconds"] = round(grow_seconds, 3)
                figures["checkpoint_seconds"] = seconds
                figures["resident_mb"] = round(_resident_mb(), 1)
                add_checkpoint(
                    session,
                    stored_id,
                    strategy=strategy.value,
                    seed=seed,
                    bot=bot,
                    checkpoint=index,
                    graph_id=figures.pop("graph_id"),
                    publication_id=figures["publication_id"],
                    figures=figures,
                    arrays=artifact_store(settings).put_arrays(arrays, session=session),
                    seconds=seconds,
                )


def _resident_mb() -> float:
    """Peak resident memory of this process (Linux reports ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
