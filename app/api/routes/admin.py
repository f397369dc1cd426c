"""Admin actions on a graph: publish the current version, grow it by some expansions.

Both need ``Authorization: Bearer <admin_token>``; the work is done by the graph
services that the CLI calls too, and the route commits what they wrote.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.encoders import jsonable_encoder
from sqlalchemy.orm import Session

from app.api.deps import get_session, require_admin
from app.api.schemas import AdminResult, GrowRequest

router = APIRouter(prefix="/api/graphs", tags=["admin"], dependencies=[Depends(require_admin)])


@router.post("/{name}/publish")
def publish(name: str, request: Request, session: Session = Depends(get_session)) -> AdminResult:
    from app.services.graphs import publish_graph

    result = publish_graph(session, request.app.state.settings, name=name)
    session.commit()
    return AdminResult(graph=name, result=_as_dict(result))


@router.post("/{name}/grow")
def grow(
    name: str,
    request: Request,
    body: GrowRequest | None = None,
    session: Session = Depends(get_session),
) -> AdminResult:
    from app.services.graphs import grow_graph
    from app.services.growth import in_session

    expansions = (body or GrowRequest()).expansions
    settings = request.app.state.settings
    result = grow_graph(in_session(session), settings, name=name, expansions=expansions)
    session.commit()
    return AdminResult(graph=name, result=_as_dict(result))


def _as_dict(result: object) -> dict[str, object]:
    encoded = jsonable_encoder(result)
    return encoded if isinstance(encoded, dict) else {"value": encoded}
