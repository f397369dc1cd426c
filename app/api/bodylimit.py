"""Every request body bounded: 413 before it is parsed, whatever the route.

An ASGI middleware, because FastAPI reads a route's JSON body before any dependency
runs. A declared ``Content-Length`` over the limit is answered 413 at once, unread; a
body without one (chunked) is counted while the route reads it, and reading past the
limit raises :class:`BodyTooLarge` (an HTTP exception, which FastAPI lets through as
it is rather than as "error parsing the body"), answered 413 by the error handlers.
Trace uploads have their own limit (``max_trace_bytes``); every other body has
``max_body_bytes``. A ``Content-Length`` that is not one decimal number (``abc``, ``-1``,
two different values; RFC 9110 8.6 lets a list of one value repeated pass) is a 400 in
the API's error shape: no body can be read by it. So is a ``Content-Length`` beside a
``Transfer-Encoding``: the two frame the body differently, and a proxy in front that
reads the other one than the server does lets a second request hide in the body
(request smuggling, RFC 9112 6.3 and 11.2); the connection is closed after that 400,
its unread bytes never parsed as a request.
"""

from __future__ import annotations

from collections.abc import Mapping

from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.api.errors import error_response


class BodyTooLarge(StarletteHTTPException):
    def __init__(self, limit: int) -> None:
        super().__init__(413, f"body larger than {limit} bytes")
        self.details = {"max_bytes": limit}


class BodyLimit:
    def __init__(self, app: ASGIApp, *, default: int, per_path: Mapping[str, int]) -> None:
        self.app = app
        self.default = default
        self.per_path = dict(per_path)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.per_path.get(scope["path"].rstrip("/"), self.default)
        try:
            declared = _content_length(scope)
        except MalformedContentLength as exc:
            await error_response(400, str(exc))(scope, receive, send)
            return
        if declared is not None and _has_header(scope, b"transfer-encoding"):
            closing = {"Connection": "close"}
            await error_response(400, TWO_FRAMINGS, headers=closing)(scope, receive, send)
            return
        if declared is not None and declared > limit:
            too_large = BodyTooLarge(limit)
            response = error_response(413, str(too_large.detail), details=too_large.details)
            await response(scope, receive, send)
            return
        received = 0

        async def bounded_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise BodyTooLarge(limit)
            return message

        await self.app(scope, bounded_receive, send)


TWO_FRAMINGS = "Content-Length with Transfer-Encoding: a request frames its body with one"


class MalformedContentLength(ValueError):
    def __init__(self) -> None:
        super().__init__("malformed Content-Length: it must be one decimal number of bytes")


def _content_length(scope: Scope) -> int | None:
    """The declared length, ``None`` without one; every header and list item counted."""
    values = {
        part.strip()
        for name, value in scope["headers"]
        if name == b"content-length"
        for part in value.split(b",")
    }
    if not values:
        return None
    (value, *others) = values
    if others or not value.isdigit():  # bytes.isdigit: ASCII digits only
        raise MalformedContentLength
    return int(value)


def _has_header(scope: Scope, name: bytes) -> bool:
    return any(header == name for header, _ in scope["headers"])
