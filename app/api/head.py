"""HEAD is GET without the body, on every route: one middleware, no HEAD route per GET.

Starlette's own routes take HEAD wherever they take GET; FastAPI's take only the methods
they declare, so a HEAD of a JSON route was a 405. RFC 9110 (9.3.2) wants HEAD answered
as GET would be, minus the content: a HEAD is routed as a GET (:func:`routed_method`,
which the ``Allow`` of a 405 asks too) and the body of the answer is dropped on its way
out, so the status and every header (``Content-Length``, ``ETag``, ...) are GET's by
construction.
"""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send


def routed_method(method: str) -> str:
    """The method a request is routed by: HEAD as GET, any other as itself."""
    return "GET" if method == "HEAD" else method


class HeadAsGet:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] != "HEAD":
            await self.app(scope, receive, send)
            return

        async def headers_only(message: Message) -> None:
            if message["type"] == "http.response.start":
                await send(message)
            elif not message.get("more_body", False):  # the last part (or a whole file)
                await send({"type": "http.response.body", "body": b"", "more_body": False})

        await self.app({**scope, "method": routed_method("HEAD")}, receive, headers_only)
