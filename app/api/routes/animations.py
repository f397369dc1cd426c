"""Animation clips and their posters, served by content hash with caching headers to match.

The URL names the bytes (sha256), so a response can be cached forever: ``immutable``
and a year's ``max-age``; the hash is also the strong ``ETag``. That promise holds only
for bytes that match the hash, so every response hashes the bytes it sends (the store's
:meth:`~app.store.artifacts.ArtifactStore.get_bytes`): a file that rotted since it was
stored, even with its size and modification time kept, is a 503, never served. Only
image artifacts are served: clip bundles are internal data. A poster (the clip's first frame, for a
first paint before clips are decoded) and the phone's clip (the frames at half their
size, for a small screen) are cut from the stored clip on request rather than stored:
they are derived data, and as cacheable as the clip they come from, so storage pays for one size
only. HEAD answers as GET without the body, as on every route (:mod:`app.api.head`).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request, Response
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import get_session
from app.api.encoding import IMMUTABLE, etag_matches
from app.api.errors import ApiError, error_responses
from app.render.animation import (
    POSTER_MEDIA_TYPE,
    STRIP_MEDIA_TYPE,
    decode_strip,
    encode_poster,
    phone_strip,
)
from app.services.animations import animation_bytes

router = APIRouter(prefix="/api/animations", tags=["animations"])

SHA256_HEX = re.compile(r"[0-9a-f]{64}")
CORRUPT = "the stored file no longer matches its hash: moved aside, not served"


def _stored(session: Session, request: Request, digest: str) -> tuple[bytes, str]:
    """The bytes, checked against their hash, and media type of an animation artifact.

    A 404 when there is none; a file whose bytes no longer match the hash is never
    served under it (its ETag would be a lie, cached for a year): the store moves it
    aside and :class:`~app.store.artifacts.ArtifactCorrupt` answers 503.
    """
    found = (
        animation_bytes(session, request.app.state.artifacts, digest)
        if SHA256_HEX.fullmatch(digest)
        else None
    )
    if found is None:
        raise ApiError(404, f"no animation {digest}")
    return found


def _not_modified(request: Request, etag: str) -> Response | None:
    headers = {"ETag": etag, "Cache-Control": IMMUTABLE}
    if etag_matches(request.headers.get("if-none-match", ""), etag):
        return Response(status_code=304, headers=headers)
    return None


_CACHING_HEADERS = {
    "ETag": {"description": "strong; send it back in If-None-Match", "schema": {"type": "string"}},
    "Cache-Control": {"description": IMMUTABLE, "schema": {"type": "string"}},
}
_NOT_MODIFIED: dict[int | str, dict[str, object]] = {
    304: {"description": "If-None-Match names the ETag", "headers": _CACHING_HEADERS}
}
_IMAGE = {"schema": {"type": "string", "format": "binary"}}
ANIMATION_RESPONSES: dict[int | str, dict[str, object]] = {
    200: {
        "description": "the clip in its stored media type (VP9 in IVF; WebP strips before)",
        "content": {STRIP_MEDIA_TYPE: _IMAGE, "image/webp": _IMAGE, "image/*": _IMAGE},
        "headers": _CACHING_HEADERS,
    },
    **_NOT_MODIFIED,
    **error_responses(404, 503, s404="no animation of that hash", s503=CORRUPT),
}
POSTER_RESPONSES: dict[int | str, dict[str, object]] = {
    200: {
        "description": "the strip's first frame",
        "content": {POSTER_MEDIA_TYPE: _IMAGE},
        "headers": _CACHING_HEADERS,
    },
    **_NOT_MODIFIED,
    **error_responses(
        404,
        422,
        503,
        s404="no animation of that hash",
        s422="not a strip of that many frames",
        s503=CORRUPT,
    ),
}
PHONE_RESPONSES: dict[int | str, dict[str, object]] = {
    **POSTER_RESPONSES,
    200: {
        "description": "the clip with every frame at half its size",
        "content": {STRIP_MEDIA_TYPE: _IMAGE},
        "headers": _CACHING_HEADERS,
    },
}
FramesQuery = Annotated[int, Query(ge=1, le=1000, description="frames in the strip (k)")]


@router.get("/{digest}", response_class=Response, responses=ANIMATION_RESPONSES)
def animation(digest: str, request: Request, session: Session = Depends(get_session)) -> Response:
    """An edge's animation strip by its digest (the publication names it), immutable."""
    body, media_type = _stored(session, request, digest)
    etag = f'"{digest}"'
    headers = {"ETag": etag, "Cache-Control": IMMUTABLE}
    return _not_modified(request, etag) or Response(body, media_type=media_type, headers=headers)


def _derived(
    session: Session,
    request: Request,
    digest: str,
    frames: int,
    kind: str,
    derive: Callable[[bytes], bytes],
    media_type: str,
) -> Response:
    """An image derived from a strip of ``frames`` frames, cacheable like the strip.

    Cutting one costs a decode and an encode (about 0.1 s for a phone clip), so each is
    cut once per process and kept (``app.state.derived``): the stored clip never changes.
    """
    stored, _ = _stored(session, request, digest)
    etag = f'"{digest}-{kind}-{frames}"'
    cached = _not_modified(request, etag)
    if cached is not None:
        return cached
    try:
        derived: FrozenCache[bytes] = request.app.state.derived
        body = derived.get_or_load((digest, kind, frames), lambda: derive(stored))
    except (ValueError, OSError) as exc:  # not a strip of that many frames, or no image
        raise ApiError(
            422, f"animation {digest} is not a strip of {frames} frames: {exc}"
        ) from None
    headers = {"ETag": etag, "Cache-Control": IMMUTABLE}
    return Response(body, media_type=media_type, headers=headers)


@router.get("/{digest}/poster", response_class=Response, responses=POSTER_RESPONSES)
def poster(
    digest: str, frames: FramesQuery, request: Request, session: Session = Depends(get_session)
) -> Response:
    """The first frame of a strip of ``frames`` frames, as a still image."""

    def first_frame(data: bytes) -> bytes:
        return encode_poster(decode_strip(data, frames))

    return _derived(session, request, digest, frames, "poster", first_frame, POSTER_MEDIA_TYPE)


@router.get("/{digest}/phone", response_class=Response, responses=PHONE_RESPONSES)
def phone(
    digest: str, frames: FramesQuery, request: Request, session: Session = Depends(get_session)
) -> Response:
    """The strip of ``frames`` frames at half their size, for a small screen."""

    def half(data: bytes) -> bytes:
        return phone_strip(data, frames)

    return _derived(session, request, digest, frames, "phone", half, STRIP_MEDIA_TYPE)
