"""Rate limits per player and per client address, shared through Redis, behind proxies.

The finding: registering a player needed nothing and had no limit (300 registrations in
1.9 s), so fresh players bypassed the per-player upload limit and the players table grew
without bound.
"""

from __future__ import annotations

import uuid
from pathlib import Path

import pytest
from api_helpers import Published, make_client, player_count, register, row_counts, walk
from sqlalchemy.orm import Session
from starlette.requests import Request

from app.api.ratelimit import address_key, client_address, parse_networks, retry_after_header

#: a Redis database of the tests' server; keys expire within the minute of their window
SHARED_REDIS = "redis://127.0.0.1:6379/15"
#: nothing listens there: a Redis that is down
DOWN_REDIS = "redis://127.0.0.1:1/0"


def upload(published: Published, key: str) -> dict[str, object]:
    steps = walk(published.publication, [0, 1])
    return {"publication_id": published.publication_id, "idempotency_key": key, "steps": steps}


def fresh_ipv6() -> str:
    """An address of a /64 no other test or run uses (2001:db8::/32 is for documentation)."""
    block = uuid.uuid4().int
    return f"2001:db8:{block >> 112 & 0xFFFF:x}:{block >> 96 & 0xFFFF:x}::1"


def test_registrations_per_address_are_limited(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    """The finding, re-tried: a burst of registrations from one address is cut at the rate."""
    before = player_count(session)
    with make_client(session, db_url, artifact_dir, registration_rate="5/minute") as client:
        replies = [client.post("/api/players") for _ in range(30)]
        assert [r.status_code for r in replies] == [201] * 5 + [429] * 25
        refused = replies[-1]
        assert int(refused.headers["Retry-After"]) >= 1
        assert refused.json()["error"] == "too many registrations; retry later"
        assert 0 < refused.json()["details"]["retry_after_seconds"] <= 60
    with make_client(
        session, db_url, artifact_dir, registration_rate="5/minute", peer="198.51.100.7"
    ) as elsewhere:
        assert elsewhere.post("/api/players").status_code == 201  # another address, its own
    assert player_count(session) == before + 6


def test_fresh_players_do_not_bypass_the_upload_limit(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    with make_client(
        session,
        db_url,
        artifact_dir,
        registration_rate="100/minute",
        address_upload_rate="3/minute",
    ) as client:
        statuses = [
            client.post("/api/traces", json=upload(published, "k"), headers=register(client))
            for _ in range(5)
        ]
        assert [r.status_code for r in statuses] == [201, 201, 201, 429, 429]
        assert statuses[3].json()["error"] == "too many uploads; retry later"
    assert row_counts(session) == (3, 6, 6)


def test_x_forwarded_for_counts_only_behind_a_trusted_proxy(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    limited = {"registration_rate": "2/minute", "trusted_proxies": "10.0.0.0/8"}
    spoofed = [{"X-Forwarded-For": f"203.0.113.{i}"} for i in range(4)]
    # Directly from the internet: a forged X-Forwarded-For buys no fresh quota.
    with make_client(session, db_url, artifact_dir, peer="198.51.100.9", **limited) as direct:
        statuses = [direct.post("/api/players", headers=h).status_code for h in spoofed]
        assert statuses == [201, 201, 429, 429]
    # Through the proxy: each client is its own address, whatever it forged on the left.
    with make_client(session, db_url, artifact_dir, peer="10.1.2.3", **limited) as proxied:
        for client_ip in ("203.0.113.1", "203.0.113.2"):
            forwarded = {"X-Forwarded-For": f"1.1.1.1, {client_ip}, 10.9.9.9"}
            statuses = [proxied.post("/api/players", headers=forwarded).status_code for _ in "abc"]
            assert statuses == [201, 201, 429]


def _request(peer: str, forwarded: list[str]) -> Request:
    headers = [(b"x-forwarded-for", value.encode()) for value in forwarded]
    return Request({"type": "http", "client": (peer, 1234), "headers": headers})


@pytest.mark.parametrize(
    ("peer", "forwarded", "client"),
    [
        ("198.51.100.1", ["203.0.113.5"], "198.51.100.1"),  # peer not trusted: header ignored
        ("10.0.0.1", ["203.0.113.5"], "203.0.113.5"),
        ("10.0.0.1", ["6.6.6.6, 203.0.113.5, 10.0.0.7"], "203.0.113.5"),  # right-most untrusted
        ("10.0.0.1", ["6.6.6.6", "203.0.113.5"], "203.0.113.5"),  # repeated headers, in order
        ("10.0.0.1", ["10.0.0.8, 10.0.0.7"], "10.0.0.8"),  # all trusted: the first
        ("10.0.0.1", [], "10.0.0.1"),
        ("::1", ["2001:db8::5"], "2001:db8::5"),
        # hops some proxies write with a port or in brackets: the bare address
        ("10.0.0.1", ["203.0.113.5:4711"], "203.0.113.5"),
        ("10.0.0.1", ["[2001:db8::5]"], "2001:db8::5"),
        ("10.0.0.1", ["[2001:db8::5]:443, 10.0.0.7:8080"], "2001:db8::5"),  # proxy skipped
    ],
)
def test_the_client_address(peer: str, forwarded: list[str], client: str) -> None:
    trusted = parse_networks("10.0.0.0/8, ::1")
    assert client_address(_request(peer, forwarded), trusted) == client


def test_a_hop_with_a_port_or_brackets_counts_in_the_client_s_bucket(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    """Each spelling of one client's address was a bucket of its own: a fresh quota."""
    limited = {"registration_rate": "3/minute", "trusted_proxies": "10.0.0.0/8"}
    with make_client(session, db_url, artifact_dir, peer="10.1.2.3", **limited) as proxied:
        spellings = ["203.0.113.9", "203.0.113.9:50000", "[203.0.113.9]", "[::ffff:203.0.113.9]:1"]
        statuses = [
            proxied.post("/api/players", headers={"X-Forwarded-For": hop}).status_code
            for hop in spellings
        ]
        assert statuses == [201, 201, 201, 429]


def test_ipv6_clients_count_per_64_and_bad_proxies_fail_at_startup() -> None:
    assert address_key("2001:db8:1:2:aaaa::1") == address_key("2001:db8:1:2:bbbb::9")
    assert address_key("2001:db8:1:2::1") != address_key("2001:db8:1:3::1")
    assert address_key("::ffff:203.0.113.5") == "203.0.113.5"
    with pytest.raises(ValueError):
        parse_networks("10.0.0.0/8, proxy.example")


@pytest.mark.redis
def test_two_servers_on_one_redis_share_the_limits(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    """Two app instances (as two server processes) with one Redis: one window between them."""
    shared = {"rate_limit_storage": SHARED_REDIS, "registration_rate": "3/minute"}
    address = fresh_ipv6()
    with (
        make_client(session, db_url, artifact_dir, peer=address, **shared) as first,
        make_client(session, db_url, artifact_dir, peer=address, **shared) as second,
    ):
        statuses = [c.post("/api/players").status_code for c in (first, second, first, second)]
        assert statuses == [201, 201, 201, 429]
        assert first.get("/api/health").json()["rate_limits"] == "shared"


def test_a_redis_that_is_down_leaves_the_limits_per_process(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    """No 500 and no free pass: each process keeps its own windows until Redis is back."""
    settings = {"rate_limit_storage": DOWN_REDIS, "registration_rate": "2/minute"}
    with make_client(session, db_url, artifact_dir, **settings) as client:
        statuses = [client.post("/api/players").status_code for _ in range(3)]
        assert statuses == [201, 201, 429]
        assert client.get("/api/health").json()["rate_limits"] == "per-process"


def test_retry_after_rounds_up_to_whole_seconds() -> None:
    assert retry_after_header(0.01) == "1"
    assert retry_after_header(1.2) == "2"
