"""Graphs and their latest publication: what a client needs to start playing."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request, Response
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import get_session
from app.api.queries import latest_publication_id, list_graphs, publication_out
from app.api.schemas import GraphSummary, PublicationOut

router = APIRouter(prefix="/api/graphs", tags=["graphs"])


@router.get("")
def graphs(session: Session = Depends(get_session)) -> list[GraphSummary]:
    return list_graphs(session)


@router.get("/{name}/publication", response_model=PublicationOut)
def latest_publication(
    name: str, request: Request, session: Session = Depends(get_session)
) -> Response:
    """The latest publication, rendered to JSON once per publication (it never changes).

    ``no-cache``: browsers revalidate, because a newer publication may appear any time.
    """
    graph, publication_id = latest_publication_id(session, name)
    rendered: FrozenCache[bytes] = request.app.state.publication_json
    body = rendered.get_or_load(
        publication_id,
        lambda: publication_out(session, graph, publication_id).model_dump_json().encode(),
    )
    return Response(body, media_type="application/json", headers={"Cache-Control": "no-cache"})
