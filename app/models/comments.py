"""What every table and column holds, said once for the models and the database.

An analyst reads the schema in ``psql`` (``\\d+ traces``) rather than in Python, so each
table and column carries its sentence as a comment on PostgreSQL (SQLite keeps none).
:func:`describe` sets them on the models' metadata, so that ``compare_metadata`` holds the
database to them; migration 0011 writes them with ``COMMENT ON``. A table or column added
later comes with its comment here (tests/cli/test_cli_analytics_sql.py checks that
none is missing on PostgreSQL).
"""

from __future__ import annotations

from sqlalchemy import MetaData

#: table -> (what one row is, {column: what it holds})
COMMENTS: dict[str, tuple[str, dict[str, str]]] = {
    "artifacts": (
        "A content-addressed file under the artifact directory (clip bundles, strips, "
        "arrays), named by its sha256.",
        {
            "hash": "sha256 of the file's bytes, hex: its name and its key",
            "size": "bytes of the file",
            "media_type": "what the file is, as a MIME type",
            "created_at": "when the row was written (UTC)",
        },
    ),
    "graphs": (
        "A precomputed state graph: its dynamics and scene, how it grows, and who plays it.",
        {
            "id": "the graph's id",
            "name": "the graph's unique name (srg init NAME)",
            "dynamics": "toy or liquid",
            "scene": "the scene of the dynamics (preset, fluid, ...), as JSON",
            "n_controls": "controls N a player chooses from at every vertex",
            "frames_per_clip": "simulated frames of one clip (one edge)",
            "seed": "seed of the graph's own random choices",
            "world": "world seed of the start state; NULL: the dynamics' canonical start",
            "strategy": "how it grows: max-error, baseline, sr-heuristic or sr-crowd",
            "player_model": "the crowd model sr-crowd learns: eq2, shrunk, mixed or mixed-error",
            "growing": "whether beat grows it on every tick (srg set-growing)",
            "revision": "bumped by every save; a save that finds another lost a race",
            "created_at": "when the graph was created (UTC)",
        },
    ),
    "vertices": (
        "A state of a graph: the end of the clip that produced it.",
        {
            "graph_id": "the graph (graphs.id)",
            "idx": "the vertex's index in its graph, stable across publications",
            "control": "the control of the clip that produced the vertex",
            "clip_idx": "the clip that produced the vertex (clips.idx); NULL for the start",
        },
    ),
    "clips": (
        "A simulated clip of a graph: from a source vertex under one control.",
        {
            "graph_id": "the graph (graphs.id)",
            "idx": "the clip's index in its graph",
            "source": "the vertex the clip starts from (vertices.idx)",
            "control": "the control held during the clip",
            "kinetic": "kinetic energy at the clip's end",
            "potential": "float64 bytes: one potential energy per control",
            "score": "the game's score of the clip",
            "descriptor": "float32 bytes of the clip's end-state descriptor",
            "bundle": "the clip's arrays artifact (artifacts.hash)",
            "animation": "the clip's rendered strip (artifacts.hash); NULL if not rendered",
        },
    ),
    "edges": (
        "An edge of a graph as it grows: a vertex and control, and where it leads.",
        {
            "graph_id": "the graph (graphs.id)",
            "vertex": "the vertex the edge leaves (vertices.idx)",
            "control": "the control that takes it",
            "kind": "0 sim (simulated), 1 blend (blended into a target): edge_kinds.kind",
            "clip_idx": "the clip the edge plays (clips.idx)",
            "dst": "the vertex it leads to",
            "target": "a blend's simulated target, as an edge index (vertex * N + control)",
            "err": "the edge's error: 0 for a sim edge, the blend's distance otherwise",
            "animation": "the edge's rendered strip (artifacts.hash); NULL if not rendered",
        },
    ),
    "growth_epochs": (
        "One epoch of growth of a graph: the expansions planned and how far they went.",
        {
            "id": "the epoch's id",
            "graph_id": "the graph (graphs.id)",
            "number": "1, 2, ... per graph",
            "strategy": "the strategy that planned it",
            "status": "running, finished or failed",
            "started_at": "when it was planned (UTC)",
            "finished_at": "when it finished (UTC); NULL until then",
            "expansions": "expansions integrated",
            "relinks": "blend edges relinked",
            "size_frames": "the graph's simulated frames after it",
            "plan": "the planned expansions in order, as JSON [[edge, dead-end clip], ...]",
            "warm_start": "STATERANK's ranking at planning (artifacts.hash): the next start",
            "heartbeat": "unix time of the last progress",
            "renders": "whether its clips are rendered",
        },
    ),
    "growth_requests": (
        "A request to grow a graph by some expansions, over the HTTP API.",
        {
            "id": "the request's id",
            "graph_id": "the graph (graphs.id)",
            "expansions": "expansions asked for",
            "runs_on": "server or workers",
            "state": "queued, running, finished or failed",
            "reason": "why it failed, in one line",
            "done": "expansions done, once finished",
            "epoch_id": "the epoch the workers planned for it (growth_epochs.id)",
            "created_at": "when it was asked for (UTC)",
            "finished_at": "when it finished (UTC); NULL until then",
        },
    ),
    "expansion_clips": (
        "A clip simulated by a worker for an epoch, before the epoch integrates it.",
        {
            "epoch_id": "the epoch (growth_epochs.id)",
            "position": "the expansion's place in the epoch's plan",
            "control": "the control of the clip",
            "clip": "the clip's arrays artifact (artifacts.hash)",
            "animation": "the clip's strip as once rendered (artifacts.hash); no longer written",
        },
    ),
    "simulated_clips": (
        "A finished simulation, by what determines it, so a re-sent task reuses it.",
        {
            "key": "sha256 of the dynamics' identity, the control and the start state",
            "clip": "the clip's arrays artifact (artifacts.hash)",
            "created_at": "when it was simulated (UTC)",
        },
    ),
    "publications": (
        "A frozen, playable copy of a graph: what players and bots play.",
        {
            "id": "the publication's id",
            "graph_id": "the graph (graphs.id)",
            "number": "1, 2, ... per graph, in publication order",
            "created_at": "when it was published (UTC)",
            "n_vertices": "vertices of the graph when published",
            "n_edges": "edges of the graph when published",
            "size_frames": "simulated frames of the graph when published",
            "start": "the vertex every session starts from",
            "high_error_threshold": "the error above which a step looked wrong, in force "
            "when published; NULL for publications made before it was stored",
        },
    ),
    "publication_edges": (
        "An edge as a publication froze it: what a player on it saw.",
        {
            "publication_id": "the publication (publications.id)",
            "vertex": "the vertex the edge leaves",
            "control": "the control that takes it",
            "dst": "the vertex it leads to",
            "kind": "0 sim, 1 blend: edge_kinds.kind",
            "err": "the edge's error: 0 for a sim edge, the blend's distance otherwise",
            "score": "the game's score of the edge",
            "animation": "the edge's strip (artifacts.hash); NULL in a version for bots",
        },
    ),
    "edge_kinds": (
        "The kinds of an edge, by number (edges.kind, publication_edges.kind).",
        {
            "kind": "the number stored in edges.kind and publication_edges.kind",
            "name": "sim (simulated) or blend (blended into a simulated target)",
        },
    ),
    "players": (
        "A player: a person's browser or a bot, registered once.",
        {
            "id": "the player's id",
            "name": "the player's unique name",
            "kind": "person or bot, said at registration",
            "token_hash": "sha256 of the bearer token; the token is never stored",
            "created_at": "when the player registered (UTC)",
        },
    ),
    "traces": (
        "A session: one player's play on one publication, uploaded once.",
        {
            "id": "the session's id",
            "publication_id": "the publication played (publications.id)",
            "player_id": "who played (players.id)",
            "idempotency_key": "the client's key: an upload sent twice is stored once",
            "created_at": "when it was uploaded (UTC)",
            "n_steps": "steps of the session",
            "error": "the summed error of its steps on the publication's edges",
            "high_error_steps": "its steps above the publication's high_error_threshold; "
            "NULL where the publication stored none",
            "ordinal": "its place among the graph's sessions (0, 1, ...), given when the play "
            "sums count it; NULL until then",
        },
    ),
    "trace_steps": (
        "A step of a session: the vertex the player was at and the control taken.",
        {
            "trace_id": "the session (traces.id)",
            "step": "0, 1, ... in the session",
            "vertex": "the vertex the player was at",
            "control": "the control the player took there",
        },
    ),
    "graph_sessions": (
        "How many of a graph's sessions the play sums count: the next one's ordinal.",
        {
            "graph_id": "the graph (graphs.id)",
            "sessions": "sessions counted so far",
        },
    ),
    "play_counts": (
        "Steps taken with a control at a vertex of a publication, by sessions of one fold "
        "bucket: what the crowd models read.",
        {
            "publication_id": "the publication (publications.id)",
            "player_kind": "the kind of player whose sessions are summed (players.kind)",
            "bucket": "the sessions' ordinal in the graph modulo the fold buckets",
            "vertex": "the vertex",
            "control": "the control taken there",
            "steps": "steps taken",
        },
    ),
    "play_lengths": (
        "Sessions of a publication by their length in steps.",
        {
            "publication_id": "the publication (publications.id)",
            "player_kind": "the kind of player whose sessions are counted (players.kind)",
            "n_steps": "a session length in steps",
            "sessions": "sessions of that length",
        },
    ),
    "play_visits": (
        "Sessions of a publication that stepped at a vertex at least once.",
        {
            "publication_id": "the publication (publications.id)",
            "player_kind": "the kind of player whose sessions are counted (players.kind)",
            "vertex": "the vertex",
            "sessions": "sessions that stepped there",
        },
    ),
    "experiments": (
        "A stored experiment (srg experiment): its plan, so that it can be resumed.",
        {
            "id": "the experiment's id",
            "name": "the experiment's unique name",
            "plan": "the plan as JSON: what a resume must run again",
            "created_at": "when it was created (UTC)",
        },
    ),
    "experiment_checkpoints": (
        "The figures of one run of an experiment at one checkpoint, as one crowd played it.",
        {
            "id": "the row's id",
            "experiment_id": "the experiment (experiments.id)",
            "strategy": "the run's strategy",
            "seed": "the run's seed (its world and its bots)",
            "bot": "the crowd that played",
            "checkpoint": "index into the plan's checkpoints",
            "graph_id": "the run's graph (graphs.id)",
            "publication_id": "the publication played (publications.id)",
            "figures": "the checkpoint's figures, as JSON",
            "arrays": "per-step errors, densities and layout (artifacts.hash)",
            "seconds": "seconds the checkpoint took",
            "created_at": "when it was stored (UTC)",
        },
    ),
}


def describe(metadata: MetaData) -> None:
    """Set the comment of every table and column :data:`COMMENTS` describes on
    ``metadata`` (the models')."""
    for name, (table_comment, columns) in COMMENTS.items():
        table = metadata.tables[name]
        table.comment = table_comment
        for column, comment in columns.items():
            table.columns[column].comment = comment
