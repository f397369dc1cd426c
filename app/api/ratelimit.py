"""Rate limits per player and per client address, with the ``limits`` library.

Three limits, each a moving window (``limits``' exact strategy): trace uploads per player
(``uploads_per_minute``), trace uploads per client address (``address_upload_rate``) and
player registrations per client address (``registration_rate``), so that registering
fresh players neither bypasses the upload limit nor grows the players table without
bound. The windows live in Redis when one is configured (``rate_limit_storage``, else
``redis_url`` or a Redis broker), so every server process shares them; else in memory,
per process. Should that Redis fail, each process falls back to its own in-memory
windows until it answers again: the limits then hold per process, never not at all.

The client address is the peer's, unless the peer is one of ``trusted_proxies``: then
``X-Forwarded-For`` is read from the right, and the right-most address that is not a
trusted proxy is the client (addresses to its left are whatever the client sent). A hop
some proxies write with its port or in brackets (``203.0.113.5:4711``, ``[2001:db8::5]``,
``[2001:db8::5]:443``) is read as the bare address, so it counts in the client's bucket.
IPv6 clients are counted per /64, the block one subscriber usually holds.
"""

from __future__ import annotations

import ipaddress
import logging
import math
import re
import time
from collections.abc import Callable, Sequence
from typing import Literal, TypeVar

from fastapi import Depends, Request
from limits import RateLimitItem, RateLimitItemPerMinute, parse_many
from limits.errors import ConfigurationError, StorageError
from limits.storage import MemoryStorage, MovingWindowSupport, Storage, storage_from_string
from limits.strategies import MovingWindowRateLimiter

from app.api.deps import current_player
from app.api.errors import ApiError
from app.config import ApiSettings, Settings
from app.core.errors import InvalidInput

log = logging.getLogger(__name__)
T = TypeVar("T")

Network = ipaddress.IPv4Network | ipaddress.IPv6Network
#: seconds a request waits at most for the shared storage before it counts as down
STORAGE_TIMEOUT_S = 1.0
IPV6_CLIENT_PREFIX = 64
#: a forwarded hop with a port, or an IPv6 one in brackets (with or without a port)
HOP_WITH_PORT = re.compile(r"\[(?P<bracketed>[^\]]+)\](?::[0-9]+)?|(?P<ipv4>[0-9.]+):[0-9]+")


class RateLimits:
    """The API's rate limits and the storage of their windows."""

    def __init__(self, settings: Settings) -> None:
        self.player_uploads: list[RateLimitItem] = [
            RateLimitItemPerMinute(settings.api.uploads_per_minute)
        ]
        self.address_uploads = _setting("address_upload_rate", parse_many, settings.api)
        self.registrations = _setting("registration_rate", parse_many, settings.api)
        self.trusted_proxies = _setting("trusted_proxies", parse_networks, settings.api)
        if settings.api.rate_limit_storage:
            self.storage = _setting("rate_limit_storage", _storage, settings.api)
        else:
            self.storage = _storage(settings.resolved_redis_url or "memory://")
        self.shared = not isinstance(self.storage, MemoryStorage)
        self._limiter = MovingWindowRateLimiter(self.storage)
        self._fallback = MovingWindowRateLimiter(MemoryStorage())
        self._storage_down = False

    def wait(self, items: Sequence[RateLimitItem], *identifiers: str) -> float:
        """Take one hit of each limit; 0 if all allow it, else the seconds until one does."""
        for item in items:
            # After a failure the shared storage is tried again on each request: recovering
            # costs what failing does (a refused connection, or STORAGE_TIMEOUT_S at worst).
            try:
                allowed = self._limiter.hit(item, *identifiers)
                reset = 0.0 if allowed else self._window_reset(self._limiter, item, identifiers)
            except StorageError as exc:
                self._went_down(exc)
                allowed = self._fallback.hit(item, *identifiers)
                reset = 0.0 if allowed else self._window_reset(self._fallback, item, identifiers)
            if not allowed:
                return max(reset - time.time(), 0.001)
        return 0.0

    def storage_state(self) -> Literal["shared", "per-process"]:
        """Where the windows are now: ``shared`` only while the shared storage answers."""
        if self.shared and self.storage.check():
            self._storage_down = False
            return "shared"
        return "per-process"

    @staticmethod
    def _window_reset(
        limiter: MovingWindowRateLimiter, item: RateLimitItem, identifiers: tuple[str, ...]
    ) -> float:
        """When the oldest hit of the full window leaves it (epoch seconds)."""
        return limiter.get_window_stats(item, *identifiers).reset_time

    def _went_down(self, exc: StorageError) -> None:
        if not self._storage_down:
            log.warning(
                "rate limit storage unreachable, limits hold per process: %s", exc.storage_error
            )
        self._storage_down = True


def _setting(name: str, parse: Callable[[str], T], settings: ApiSettings) -> T:
    """The setting ``name`` parsed; a value the parser refuses is the operator's to fix, so
    it is an :class:`InvalidInput` naming the variable (``srg serve`` says it in one line)."""
    try:
        return parse(getattr(settings, name))
    except (ValueError, ConfigurationError) as exc:
        raise InvalidInput(f"SRG_{name.upper()}: {exc}") from None


def _storage(uri: str) -> Storage:
    options: dict[str, float | str | bool] = {"wrap_exceptions": True}
    if uri.startswith(("redis://", "rediss://", "redis+unix://")):
        options |= {
            "socket_timeout": STORAGE_TIMEOUT_S,
            "socket_connect_timeout": STORAGE_TIMEOUT_S,
        }
    storage = storage_from_string(uri, **options)
    if not isinstance(storage, Storage) or not isinstance(storage, MovingWindowSupport):
        raise ValueError(f"rate limit storage {uri!r} has no moving windows")
    return storage


def parse_networks(spec: str) -> tuple[Network, ...]:
    """``"10.0.0.0/8, 127.0.0.1"`` as networks; a bad entry is a ``ValueError``."""
    return tuple(
        ipaddress.ip_network(part.strip(), strict=False) for part in spec.split(",") if part.strip()
    )


def client_address(request: Request, trusted_proxies: Sequence[Network]) -> str:
    """The client's address: the peer's, or what trusted proxies say in X-Forwarded-For."""
    peer = request.client.host if request.client else ""
    if not _is_trusted(peer, trusted_proxies):
        return peer
    forwarded = [
        bare_address(hop.strip())
        for header in request.headers.getlist("x-forwarded-for")
        for hop in header.split(",")
        if hop.strip()
    ]
    for hop in reversed(forwarded):
        if not _is_trusted(hop, trusted_proxies):
            return hop
    return forwarded[0] if forwarded else peer


def bare_address(hop: str) -> str:
    """A forwarded hop without its port or brackets; any other as it is."""
    match = HOP_WITH_PORT.fullmatch(hop)
    if match is None:
        return hop
    return match["bracketed"] if match["bracketed"] is not None else match["ipv4"]


def address_key(address: str) -> str:
    """The key an address is counted under: itself, or its /64 for IPv6."""
    try:
        parsed = ipaddress.ip_address(address)
    except ValueError:
        return address
    if isinstance(parsed, ipaddress.IPv6Address):
        if parsed.ipv4_mapped is not None:
            return str(parsed.ipv4_mapped)
        return str(ipaddress.ip_network(f"{parsed}/{IPV6_CLIENT_PREFIX}", strict=False))
    return str(parsed)


def _is_trusted(address: str, trusted_proxies: Sequence[Network]) -> bool:
    try:
        parsed = ipaddress.ip_address(address)
    except ValueError:
        return False
    return any(parsed in network for network in trusted_proxies)


def retry_after_header(wait_seconds: float) -> str:
    """``Retry-After`` takes whole seconds; round up so a client that waits succeeds."""
    return str(max(1, math.ceil(wait_seconds)))


def _refuse_if_waiting(wait: float, what: str) -> None:
    if wait > 0:
        raise ApiError(
            429,
            f"too many {what}; retry later",
            headers={"Retry-After": retry_after_header(wait)},
            details={"retry_after_seconds": round(wait, 3)},
        )


def limited_registration(request: Request) -> None:
    """A registration within the client address's rate; 429 beyond."""
    limits: RateLimits = request.app.state.rate_limits
    address = address_key(client_address(request, limits.trusted_proxies))
    _refuse_if_waiting(limits.wait(limits.registrations, "registrations", address), "registrations")


def limited_uploader(request: Request, player_id: int = Depends(current_player)) -> int:
    """The uploading player, within its own rate and its client address's; 429 beyond."""
    limits: RateLimits = request.app.state.rate_limits
    address = address_key(client_address(request, limits.trusted_proxies))
    _refuse_if_waiting(limits.wait(limits.address_uploads, "uploads", address), "uploads")
    _refuse_if_waiting(
        limits.wait(limits.player_uploads, "player-uploads", str(player_id)), "uploads"
    )
    return player_id
