"""How uvicorn serves the API: the options ``srg serve`` and the loopback server share.

uvicorn's HTTP/1.1 parser (h11) refuses a request it cannot frame (a malformed or
conflicting ``Content-Length``, a bad request line or header) before the app sees it,
with a 400 in plain text: :class:`JsonRefusalH11` writes that 400 in the API's error
shape instead, like every other error (h11 even where httptools is installed, whose
refusals are plain text too). uvicorn's own proxy-header handling is off: the app alone
decides whose ``X-Forwarded-For`` to trust (``SRG_TRUSTED_PROXIES``), where uvicorn would
trust any from loopback.
"""

from __future__ import annotations

import socket
from typing import Any

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from app.api.errors import error_response
from app.core.errors import Unavailable

UNREADABLE = "invalid HTTP request: a malformed Content-Length, request line or header"


class JsonRefusalH11(H11Protocol):
    def send_400_response(self, msg: str) -> None:
        """uvicorn's refusal (``msg`` is its plain "Invalid HTTP request received.")."""
        response = error_response(400, UNREADABLE)
        headers = [*response.raw_headers, (b"connection", b"close")]
        for event in (
            h11.Response(status_code=400, headers=headers, reason=b"Bad Request"),
            h11.Data(data=bytes(response.body)),
            h11.EndOfMessage(),
        ):
            output = self.conn.send(event)
            if output is not None:
                self.transport.write(output)
        self.transport.close()


#: for ``uvicorn.run`` and ``uvicorn.Config``
UVICORN_OPTIONS: dict[str, Any] = {"http": JsonRefusalH11, "proxy_headers": False}


def require_listenable(host: str, port: int) -> None:
    """Bind ``host:port`` once and let go, so that a used port or a host that names no
    interface is one line before the server starts: uvicorn logs it and exits 3."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds
            probe.bind(address)
    except OSError as exc:
        raise Unavailable(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
