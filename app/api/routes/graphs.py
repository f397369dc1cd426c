"""Graphs and their publications: what a client needs to start playing.

A client plays the latest publication; a judge replaying an experiment plays a stored
older one, by its id, from the graph's list of publications.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Path, Request, Response
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import get_session
from app.api.encoding import IMMUTABLE, EncodedJson, accepts_gzip, etag_matches
from app.api.errors import error_responses
from app.api.graph_bodies import list_graphs, list_publications, publication_out
from app.api.schemas import INT32_MAX, GraphSummary, PublicationListed, PublicationOut
from app.services.catalogue import GraphEntry, find_graph, graph_publication, latest_publication_id

router = APIRouter(prefix="/api/graphs", tags=["graphs"])

_ETAG_HEADER = {"ETag": {"description": "weak; send it back in If-None-Match"}}


@router.get("")
def graphs(session: Session = Depends(get_session)) -> list[GraphSummary]:
    """Every graph with its latest publication, if any: what a client offers to play."""
    return list_graphs(session)


def _publication_response(
    session: Session,
    request: Request,
    graph: GraphEntry,
    publication_id: int,
    cache_control: str,
) -> Response:
    """The publication, rendered to JSON and gzipped once per publication (a publication
    never changes), or 304 when ``If-None-Match`` names its ETag."""
    rendered: FrozenCache[EncodedJson] = request.app.state.publication_json
    encoded = rendered.get_or_load(
        publication_id,
        lambda: EncodedJson.of(
            publication_out(session, graph, publication_id).model_dump_json().encode()
        ),
    )
    headers = {"Cache-Control": cache_control, "ETag": encoded.etag, "Vary": "Accept-Encoding"}
    if etag_matches(request.headers.get("if-none-match", ""), encoded.etag):
        return Response(status_code=304, headers=headers)
    if accepts_gzip(request.headers.get("accept-encoding", "")):
        headers["Content-Encoding"] = "gzip"
        return Response(encoded.gzipped, media_type="application/json", headers=headers)
    return Response(encoded.body, media_type="application/json", headers=headers)


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
    """The latest publication.

    ``no-cache``: browsers revalidate (``If-None-Match``, answered 304 while the
    publication is still the latest), because a newer one may appear any time.
    """
    graph = find_graph(session, name)
    publication_id = latest_publication_id(session, graph.id)
    return _publication_response(session, request, graph, publication_id, "no-cache")


@router.get("/{name}/publications", responses=error_responses(404, s404="no such graph"))
def publications(name: str, session: Session = Depends(get_session)) -> list[PublicationListed]:
    """The graph's stored publications, oldest first: every version one can still play."""
    return list_publications(session, find_graph(session, name))


@router.get(
    "/{name}/publications/{publication_id}",
    response_model=PublicationOut,
    responses={
        200: {"headers": _ETAG_HEADER},
        304: {"description": "If-None-Match names the publication's ETag"},
        **error_responses(
            404,
            422,
            s404="no such graph, or no publication of that id of the graph",
            s422="the id is not a positive 32-bit integer",
        ),
    },
)
def stored_publication(
    name: str,
    publication_id: Annotated[int, Path(ge=1, le=INT32_MAX)],
    request: Request,
    session: Session = Depends(get_session),
) -> Response:
    """A stored publication of the graph, the latest or an older one, by its id.

    ``immutable``: a publication never changes once stored, so its URL may be cached
    for good (the latest route's body is this one's while it is the latest, ETag too).
    """
    graph = find_graph(session, name)
    publication = graph_publication(session, graph.id, publication_id)
    return _publication_response(session, request, graph, publication.id, IMMUTABLE)
