"""Graphs and their latest publication: what a client needs to start playing."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request, Response
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import get_session
from app.api.encoding import EncodedJson, accepts_gzip, etag_matches
from app.api.errors import error_responses
from app.api.graph_bodies import list_graphs, publication_out
from app.api.schemas import GraphSummary, PublicationOut
from app.services.catalogue import find_graph, latest_publication_id

router = APIRouter(prefix="/api/graphs", tags=["graphs"])

_ETAG_HEADER = {"ETag": {"description": "weak; send it back in If-None-Match"}}


@router.get("")
def graphs(session: Session = Depends(get_session)) -> list[GraphSummary]:
    return list_graphs(session)


@router.get(
    "/{name}/publication",
    response_model=PublicationOut,
    responses={
        200: {"headers": _ETAG_HEADER},
        304: {"description": "If-None-Match names the latest publication's ETag"},
        **error_responses(404, s404="no such graph, or none of its versions published"),
    },
)
def latest_publication(
    name: str, request: Request, session: Session = Depends(get_session)
) -> Response:
    """The latest publication, rendered to JSON and gzipped once per publication.

    ``no-cache``: browsers revalidate (``If-None-Match``, answered 304 while the
    publication is still the latest), because a newer one may appear any time.
    """
    graph = find_graph(session, name)
    publication_id = latest_publication_id(session, graph.id)
    rendered: FrozenCache[EncodedJson] = request.app.state.publication_json
    encoded = rendered.get_or_load(
        publication_id,
        lambda: EncodedJson.of(
            publication_out(session, graph, publication_id).model_dump_json().encode()
        ),
    )
    headers = {"Cache-Control": "no-cache", "ETag": encoded.etag, "Vary": "Accept-Encoding"}
    if etag_matches(request.headers.get("if-none-match", ""), encoded.etag):
        return Response(status_code=304, headers=headers)
    if accepts_gzip(request.headers.get("accept-encoding", "")):
        headers["Content-Encoding"] = "gzip"
        return Response(encoded.gzipped, media_type="application/json", headers=headers)
    return Response(encoded.body, media_type="application/json", headers=headers)
