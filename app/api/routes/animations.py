"""Animation strips, served by content hash with caching headers to match.

The URL names the bytes (sha256), so a response can be cached forever: ``immutable``
and a year's ``max-age``; the hash is also the strong ``ETag``. Only image artifacts
are served: clip bundles are internal data.
"""

from __future__ import annotations

import re

from fastapi import APIRouter, Depends, Request, Response
from fastapi.responses import FileResponse
from sqlalchemy.orm import Session

from app.api.deps import get_session
from app.api.errors import ApiError
from app.api.queries import animation_media_type
from app.store.artifacts import ArtifactStore

router = APIRouter(prefix="/api/animations", tags=["animations"])

SHA256_HEX = re.compile(r"[0-9a-f]{64}")
IMMUTABLE = "public, max-age=31536000, immutable"


@router.get("/{digest}", response_class=FileResponse)
def animation(digest: str, request: Request, session: Session = Depends(get_session)) -> Response:
    media_type = animation_media_type(session, digest) if SHA256_HEX.fullmatch(digest) else None
    store: ArtifactStore = request.app.state.artifacts
    path = store.path_for(digest) if media_type else None
    if path is None or not path.is_file():
        raise ApiError(404, f"no animation {digest}")
    headers = {"ETag": f'"{digest}"', "Cache-Control": IMMUTABLE}
    if f'"{digest}"' in request.headers.get("if-none-match", ""):
        return Response(status_code=304, headers=headers)
    return FileResponse(path, media_type=media_type, headers=headers)
