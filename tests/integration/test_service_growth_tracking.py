"""Growth as its callers follow it (app.services.growth_tracking): a request queued, run
and ended or failed with a reason a poll can show, the running epoch's number and
heartbeat, and the refusal while another process holds the graph's growth claim."""

from __future__ import annotations

import errno

import pytest
from sqlalchemy.orm import Session

from app.core.errors import InvalidInput
from app.services.growth_tracking import (
    RequestState,
    RequestView,
    end_request,
    epochs_after,
    fail_request,
    failure_reason,
    last_epoch_number,
    latest_request,
    queue_request,
    refuse_if_growing_elsewhere,
    running_epoch_number,
    running_epoch_state,
    start_request,
)
from app.store.epochs import EpochStatus, finish_epoch, record_heartbeat, start_epoch
from app.store.graph_catalogue import create_graph
from app.store.growth_claims import GrowingElsewhere, growth_claim


@pytest.fixture
def graph_id(session: Session) -> int:
    return create_graph(session, name="tank", dynamics="toy", n_controls=3, frames_per_clip=10)


def test_a_queued_request_is_polled_from_queued_to_finished(
    session: Session, graph_id: int
) -> None:
    assert latest_request(session, graph_id) is None
    request = queue_request(session, graph_id, 5, "server")
    assert latest_request(session, graph_id) == RequestView(
        request, 5, "server", RequestState.QUEUED, None, None
    )
    epoch = start_epoch(session, graph_id, "sr-crowd")
    start_request(session, request, epoch)
    polled = latest_request(session, graph_id)
    assert polled is not None and (polled.state, polled.epoch_id) == (RequestState.RUNNING, epoch)
    end_request(session, request, done=5)
    polled = latest_request(session, graph_id)
    assert polled is not None and (polled.state, polled.reason) == (RequestState.FINISHED, None)


def test_a_request_on_a_worker_ends_with_its_epoch(session: Session, graph_id: int) -> None:
    request = queue_request(session, graph_id, 2, "workers")
    epoch = start_epoch(session, graph_id, "sr-crowd")
    start_request(session, request, epoch)
    finish_epoch(session, epoch, expansions=2, relinks=0, size_frames=200)
    polled = latest_request(session, graph_id)
    assert polled is not None and polled.state is RequestState.FINISHED


def test_the_latest_request_is_the_one_polled(session: Session, graph_id: int) -> None:
    queue_request(session, graph_id, 1, "server")
    newer = queue_request(session, graph_id, 3, "workers")
    polled = latest_request(session, graph_id)
    assert polled is not None and (polled.id, polled.expansions, polled.runs_on) == (
        newer,
        3,
        "workers",
    )


@pytest.mark.parametrize(
    ("exc", "reason"),
    [
        (InvalidInput("the budget must be positive"), "the budget must be positive"),
        (InvalidInput(), "InvalidInput"),
        (RuntimeError("broker gone\nTraceback follows"), "RuntimeError: broker gone"),
        (KeyError("plan"), "KeyError: 'plan'"),
        (ConnectionRefusedError(), "ConnectionRefusedError"),
        (
            FileNotFoundError(errno.ENOENT, "No such file or directory", "/srv/secret/path"),
            "FileNotFoundError: No such file or directory",
        ),
    ],
    ids=["user-error", "bare-user-error", "bug-two-lines", "key-error", "bare-bug", "os-error"],
)
def test_a_request_nothing_will_run_is_failed_with_a_one_line_reason(
    session: Session, graph_id: int, exc: BaseException, reason: str
) -> None:
    assert failure_reason(exc).splitlines()[0] == reason
    request = queue_request(session, graph_id, 4, "workers")
    fail_request(session, request, exc)
    polled = latest_request(session, graph_id)
    assert polled is not None and polled.id == request
    assert (polled.state, polled.reason) == (RequestState.FAILED, reason)
    assert "/srv/secret" not in (polled.reason or "")  # the server's paths stay in its log


def test_a_long_failure_is_cut_to_the_column(session: Session, graph_id: int) -> None:
    request = queue_request(session, graph_id, 1, "server")
    fail_request(session, request, InvalidInput("x" * 2_000))
    polled = latest_request(session, graph_id)
    assert polled is not None and polled.reason == "x" * 500


def test_the_running_epoch_is_told_by_its_number_and_heartbeat(
    session: Session, graph_id: int
) -> None:
    assert running_epoch_number(session, graph_id) is None
    assert running_epoch_state(session, graph_id) is None
    assert last_epoch_number(session, graph_id) == 0
    first = start_epoch(session, graph_id, "sr-crowd")
    assert running_epoch_number(session, graph_id) == 1
    assert running_epoch_state(session, graph_id) == (first, None)  # no progress yet
    record_heartbeat(session, first)
    state = running_epoch_state(session, graph_id)
    assert state is not None and state[0] == first and state[1] is not None
    finish_epoch(session, first, expansions=1, relinks=0, size_frames=130)
    assert running_epoch_number(session, graph_id) is None
    second = start_epoch(session, graph_id, "sr-crowd")
    assert running_epoch_number(session, graph_id) == 2 == last_epoch_number(session, graph_id)
    assert running_epoch_state(session, graph_id) == (second, None)
    after = epochs_after(session, graph_id, 0, 10)
    assert [(e.number, e.status) for e in after] == [
        (1, EpochStatus.FINISHED),
        (2, EpochStatus.RUNNING),
    ]
    assert [e.number for e in epochs_after(session, graph_id, 1, 10)] == [2]
    assert [e.number for e in epochs_after(session, graph_id, 0, 1)] == [1]


def test_a_graph_grown_by_another_process_is_refused(session: Session, graph_id: int) -> None:
    engine = session.get_bind().engine
    refuse_if_growing_elsewhere(session, graph_id, "tank")  # nobody grows it
    with growth_claim(engine, graph_id, "tank"):  # an `srg grow` holds the claim
        with pytest.raises(GrowingElsewhere) as refused:
            refuse_if_growing_elsewhere(session, graph_id, "tank", details={"request": 7})
        assert "graph 'tank' is being grown by another process" in str(refused.value)
        assert refused.value.details == {"request": 7}
        refuse_if_growing_elsewhere(session, graph_id + 1, "other")  # its claim is its own
    refuse_if_growing_elsewhere(session, graph_id, "tank")  # released with the grower
    with growth_claim(engine, graph_id, "tank"):  # and the check took nothing for itself
        pass
