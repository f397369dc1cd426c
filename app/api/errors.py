"""Every error the API returns is a JSON object ``{"error": "...", "details": ...}``.

Routes raise :class:`ApiError` for the API's own refusals; the handlers installed by
:func:`install_error_handlers` turn it, FastAPI's request validation errors, Starlette's
own HTTP errors and any :class:`~app.core.errors.SrgError` (a graph not found: 404, a
name refused: 422, ...; the ``http_status`` of its kind) into that one shape
(:class:`~app.api.schemas.ErrorBody`), so a client needs one code path for failures.
A database that cannot serve (unreachable, not a database, damaged, locked past the write
retries, not migrated: :func:`~app.db.errors.database_unavailable`) is a 503 naming the problem
alone, neither the URL nor the file, so any route can answer it; the error is logged in
full. Any other exception is a bug: a 500 that says no more than "internal error".
:func:`error_responses` declares the same shape in the OpenAPI document for each status a
route can answer.

Under ``/api`` a path no route serves is a 404, and a method no route of that path takes
(any method, ``PROPFIND`` too) is a 405 whose ``Allow`` lists every method the path's
routes take (:class:`NoRoute`): such requests never fall through to the web client's
static files.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from sqlalchemy.exc import DBAPIError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match, Mount, Route
from starlette.types import Receive, Scope, Send

from app.api.head import routed_method
from app.api.schemas import ErrorBody
from app.core.errors import SrgError
from app.db.engines import parse_database_url
from app.db.errors import database_unavailable

log = logging.getLogger(__name__)

#: the methods a path is tried with to list its ``Allow``
ANY_METHOD = ["GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS", "TRACE", "CONNECT"]

#: what each status means, as the OpenAPI document says it
ERROR_DESCRIPTIONS = {
    400: "a malformed Content-Length, or a body that cannot be read as JSON text (not UTF-8)",
    401: "no bearer token (Authorization: Bearer <token>)",
    403: "a token that is not accepted here",
    404: "no such graph, publication or animation",
    409: "conflicts with the current state",
    413: "body or trace too large",
    422: "invalid request",
    429: "over a rate limit: retry after Retry-After seconds",
    503: "the database cannot serve: unreachable, damaged, locked or not migrated",
}
_HEADER_OF = {
    401: {"WWW-Authenticate": {"description": "Bearer", "schema": {"type": "string"}}},
    429: {
        "Retry-After": {
            "description": "whole seconds to wait",
            "schema": {"type": "string", "pattern": "^[0-9]+$"},
        }
    },
}


class ApiError(Exception):
    """An error with an HTTP status, a message, JSON details and response headers."""

    def __init__(
        self,
        status: int,
        message: str,
        *,
        headers: Mapping[str, str] | None = None,
        details: Any = None,
    ) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.headers = dict(headers or {})
        self.details = details


def error_response(
    status: int, message: str, headers: Mapping[str, str] | None = None, details: Any = None
) -> JSONResponse:
    return JSONResponse({"error": message, "details": details}, status_code=status, headers=headers)


def error_responses(*statuses: int, **descriptions: str) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` declaring ``ErrorBody`` for each status.

    ``descriptions`` overrides the generic one, keyed ``s409`` for status 409.
    """
    return {
        status: {
            "model": ErrorBody,
            "description": descriptions.get(f"s{status}", ERROR_DESCRIPTIONS[status]),
            **({"headers": _HEADER_OF[status]} if status in _HEADER_OF else {}),
        }
        for status in statuses
    }


def validation_details(exc: ValidationError | RequestValidationError) -> list[dict[str, Any]]:
    """Where and what: pydantic's errors without their input echo or exception objects."""
    return [
        {"loc": [str(part) for part in err.get("loc", ())], "msg": err.get("msg", "invalid")}
        for err in exc.errors()
    ]


def allowed_methods(request: Request) -> list[str]:
    """Every method some route of the request's path takes (the last route and the
    static files aside): each is tried against the app's routes, as the router would."""
    routes = [
        route
        for route in request.app.router.routes
        if not isinstance(route, Mount)
        and not (isinstance(route, Route) and isinstance(route.endpoint, NoRoute))
    ]
    return [
        method
        for method in ANY_METHOD
        if any(
            route.matches({**request.scope, "method": routed_method(method)})[0] is Match.FULL
            for route in routes
        )
    ]


class NoRoute:
    """The last ``/api`` route: 405 with the path's methods in ``Allow``, else 404.

    An ASGI app rather than a function: Starlette routes a function endpoint for the
    methods it lists (GET alone by default), an app for every method there is.
    """

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        request = Request(scope)
        path = scope["path"]
        allowed = allowed_methods(request)
        if allowed:
            message = f"{request.method} is not allowed on {path}"
            response = error_response(405, message, {"Allow": ", ".join(allowed)})
        else:
            response = error_response(404, f"no route {path}")
        await response(scope, receive, send)


def install_error_handlers(app: FastAPI) -> None:
    async def api_error(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ApiError)
        return error_response(exc.status, exc.message, exc.headers, exc.details)

    async def invalid_request(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, RequestValidationError)
        return error_response(422, "invalid request", details=validation_details(exc))

    async def http_error(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, StarletteHTTPException)
        details = getattr(exc, "details", None)
        return error_response(exc.status_code, str(exc.detail), exc.headers, details)

    async def user_error(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, SrgError)
        message = str(exc.args[0] if exc.args else exc)
        return error_response(exc.http_status, message, details=exc.details)

    async def unexpected(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error", exc_info=exc)
        return error_response(500, "internal error")

    async def database_error(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, DBAPIError)
        url = parse_database_url(request.app.state.settings.resolved_database_url)
        unavailable = database_unavailable(exc, url)
        if unavailable is None:
            return await unexpected(request, exc)
        log.error("%s", unavailable)
        dialect = url.get_backend_name()
        return error_response(
            503,
            f"the database is unavailable: {unavailable.problem}",
            details={"database": dialect, "reason": unavailable.problem},
        )

    app.add_exception_handler(ApiError, api_error)
    app.add_exception_handler(RequestValidationError, invalid_request)
    app.add_exception_handler(StarletteHTTPException, http_error)
    app.add_exception_handler(SrgError, user_error)
    app.add_exception_handler(DBAPIError, database_error)
    app.add_exception_handler(Exception, unexpected)
