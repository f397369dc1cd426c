"""Every error the API returns is a JSON object ``{"error": "...", ...}``.

Routes raise :class:`ApiError`; the handlers installed by :func:`install_error_handlers`
turn it, FastAPI's request validation errors, Starlette's own HTTP errors (unknown route,
wrong method) and the store's not-found errors (404) into that one shape, so a client
needs one code path for failures.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.api.queries import NoPublication
from app.store.graphs import GraphNotFound
from app.store.publications import PublicationNotFound

log = logging.getLogger(__name__)

#: store lookups that fail because the client named something that does not exist
NOT_FOUND = (GraphNotFound, PublicationNotFound, NoPublication)


class ApiError(Exception):
    """An error with an HTTP status, a message, extra JSON fields and response headers."""

    def __init__(
        self,
        status: int,
        message: str,
        *,
        headers: Mapping[str, str] | None = None,
        **fields: Any,
    ) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.headers = dict(headers or {})
        self.fields = fields


def error_response(
    status: int, message: str, headers: Mapping[str, str] | None = None, **fields: Any
) -> JSONResponse:
    return JSONResponse({"error": message, **fields}, status_code=status, headers=headers)


def validation_details(exc: ValidationError | RequestValidationError) -> list[dict[str, Any]]:
    """Where and what: pydantic's errors without their input echo or exception objects."""
    return [
        {"loc": [str(part) for part in err.get("loc", ())], "msg": err.get("msg", "invalid")}
        for err in exc.errors()
    ]


def install_error_handlers(app: FastAPI) -> None:
    async def api_error(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ApiError)
        return error_response(exc.status, exc.message, exc.headers, **exc.fields)

    async def invalid_request(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, RequestValidationError)
        return error_response(422, "invalid request", details=validation_details(exc))

    async def http_error(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, StarletteHTTPException)
        return error_response(exc.status_code, str(exc.detail), exc.headers)

    async def not_found(_: Request, exc: Exception) -> JSONResponse:
        return error_response(404, str(exc.args[0]) if exc.args else "not found")

    async def unexpected(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error", exc_info=exc)
        return error_response(500, "internal error")

    app.add_exception_handler(ApiError, api_error)
    app.add_exception_handler(RequestValidationError, invalid_request)
    app.add_exception_handler(StarletteHTTPException, http_error)
    for not_found_type in NOT_FOUND:
        app.add_exception_handler(not_found_type, not_found)
    app.add_exception_handler(Exception, unexpected)
