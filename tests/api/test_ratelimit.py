"""The token bucket: capacity per minute, continuous refill, per-key isolation."""

from __future__ import annotations

import pytest

from app.api.ratelimit import TokenBucketLimiter, retry_after_header


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_a_full_bucket_allows_a_burst_then_refills_at_the_rate() -> None:
    clock = Clock()
    limiter = TokenBucketLimiter(60, clock=clock)
    assert all(limiter.acquire(1) == 0 for _ in range(60))
    assert limiter.acquire(1) == pytest.approx(1.0)
    clock.now = 0.5
    assert limiter.acquire(1) == pytest.approx(0.5)
    clock.now = 1.0
    assert limiter.acquire(1) == 0
    assert limiter.acquire(2) == 0  # another player has its own bucket


def test_retry_after_rounds_up_to_whole_seconds() -> None:
    assert retry_after_header(0.01) == "1"
    assert retry_after_header(1.2) == "2"


def test_the_rate_must_be_positive() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        TokenBucketLimiter(0)
