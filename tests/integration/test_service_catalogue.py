"""The graph catalogue as the shells read it (app.services.catalogue): graphs by name or
id, their sizes, publications and published edges, and the animations a publish would
still render."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from service_settings import session_settings
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree_clips
from app.db.limits import MAX_ROW_ID
from app.services.catalogue import (
    GraphEntry,
    find_graph,
    get_publication,
    graph_ids,
    graph_listings,
    graph_publication,
    graph_publications,
    latest_publication_id,
    missing_animations,
    published_edges,
    size_frames,
)
from app.services.creation import init_graph
from app.services.publishing import publish_graph
from app.store.graph_catalogue import GraphNotFound
from app.store.publications import NothingPublished, PublicationNotFound

TOY = ToyDynamics()
#: the toy's initial tree of depth 2: its vertices' edges and its clips' frames
TREE_EDGES = (1 + TOY.n_controls) * TOY.n_controls
TREE_FRAMES = initial_tree_clips(TOY.n_controls, 2) * TOY.frames_per_clip


@pytest.fixture
def settings(db_url: str, tmp_path: Path) -> Iterator[Settings]:
    yield from session_settings(db_url, tmp_path)


def new_graph(session: Session, settings: Settings, name: str) -> int:
    return int(init_graph(session, settings, name=name)["id"])  # type: ignore[call-overload]


def test_a_graph_is_found_by_its_name_and_by_its_id(session: Session, settings: Settings) -> None:
    graph_id = new_graph(session, settings, "tank")
    for name_or_id in ("tank", graph_id, str(graph_id), f"00{graph_id}"):
        entry = find_graph(session, name_or_id)
        assert isinstance(entry, GraphEntry)
        assert (entry.id, entry.name, entry.dynamics) == (graph_id, "tank", "toy")
        assert (entry.n_controls, entry.frames_per_clip) == (TOY.n_controls, TOY.frames_per_clip)


@pytest.mark.parametrize(
    ("name_or_id", "message"),
    [
        ("nope", "no graph 'nope'"),
        (MAX_ROW_ID + 1, f"no graph '{MAX_ROW_ID + 1}'"),
        ("9" * 30, f"no graph '{'9' * 30}'"),  # more digits than any id: no overflow
        (0, "no graph '0'"),
        ("tank\x00", "no graph 'tank\\x00'"),  # PostgreSQL refuses NUL in text
        ("²", "no graph '²'"),  # a digit to str.isdigit, not an id
        ("x" * 100, "no graph 'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx'... (100 characters)"),
    ],
    ids=["unknown", "past-the-largest-id", "thirty-digits", "zero", "nul", "superscript", "long"],
)
def test_what_names_no_graph_is_not_found(
    session: Session, settings: Settings, name_or_id: str | int, message: str
) -> None:
    new_graph(session, settings, "tank")
    with pytest.raises(GraphNotFound) as refused:
        find_graph(session, name_or_id)
    assert str(refused.value) == message
    with pytest.raises(GraphNotFound):
        missing_animations(session, name_or_id)


def test_graph_ids_and_listings_come_oldest_first(session: Session, settings: Settings) -> None:
    assert graph_ids(session) == [] and graph_listings(session) == []
    first, second = new_graph(session, settings, "b-first"), new_graph(session, settings, "a-2")
    assert graph_ids(session) == [first, second]
    listed = graph_listings(session)
    assert [g.name for g in listed] == ["b-first", "a-2"]
    assert [(g.latest_publication, g.animated) for g in listed] == [(None, False)] * 2
    assert (listed[0].dynamics, listed[0].n_controls) == ("toy", TOY.n_controls)


def test_the_size_counts_every_clip_of_the_graph(session: Session, settings: Settings) -> None:
    graph_id = new_graph(session, settings, "tank")
    assert size_frames(session, graph_id) == TREE_FRAMES


def test_every_edge_misses_its_animation_until_a_publish_renders_it(
    session: Session, settings: Settings
) -> None:
    graph_id = new_graph(session, settings, "tank")
    assert missing_animations(session, "tank") == TREE_EDGES
    assert missing_animations(session, graph_id) == TREE_EDGES
    publish_graph(session, settings, name="tank", render=False)
    assert missing_animations(session, "tank") == TREE_EDGES  # bots' publications render none
    assert [g.animated for g in graph_listings(session)] == [False]
    rendered = publish_graph(session, settings, name="tank")
    assert rendered.rendered == TREE_EDGES
    assert missing_animations(session, "tank") == 0
    assert [(g.latest_publication, g.animated) for g in graph_listings(session)] == [(2, True)]


def test_publications_are_listed_and_read_as_published(
    session: Session, settings: Settings
) -> None:
    graph_id = new_graph(session, settings, "tank")
    with pytest.raises(NothingPublished, match="graph 'tank' has no publication yet"):
        latest_publication_id(session, "tank")
    bare = publish_graph(session, settings, name="tank", render=False)
    drawn = publish_graph(session, settings, name="tank")
    assert latest_publication_id(session, "tank") == drawn.publication_id
    assert latest_publication_id(session, graph_id) == drawn.publication_id
    listed = graph_publications(session, graph_id)
    assert [(p.id, p.number) for p in listed] == [
        (bare.publication_id, 1),
        (drawn.publication_id, 2),
    ]
    summary = get_publication(session, drawn.publication_id)
    assert summary == listed[1] == graph_publication(session, graph_id, drawn.publication_id)
    assert (summary.graph_id, summary.size_frames, summary.n_edges) == (
        graph_id,
        TREE_FRAMES,
        TREE_EDGES,
    )
    edges = published_edges(session, drawn.publication_id)
    assert len(edges) == TREE_EDGES
    assert all(edge.animation is not None for edge in edges)
    assert all(edge.animation is None for edge in published_edges(session, bare.publication_id))
    assert all(0 <= edge.dst < summary.n_vertices for edge in edges)


def test_a_publication_of_another_graph_is_not_found_under_this_one(
    session: Session, settings: Settings
) -> None:
    mine, other = new_graph(session, settings, "mine"), new_graph(session, settings, "other")
    theirs = publish_graph(session, settings, name="other", render=False).publication_id
    assert graph_publication(session, other, theirs).graph_id == other
    with pytest.raises(PublicationNotFound, match=f"no publication {theirs} of graph 'mine'"):
        graph_publication(session, mine, theirs)
    with pytest.raises(PublicationNotFound, match=f"no publication {theirs + 1} of graph 'mine'"):
        graph_publication(session, mine, theirs + 1)
