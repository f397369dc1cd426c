"""SQLAlchemy models; importing this package registers every table on ``Base.metadata``,
each table and column with its comment (:mod:`app.models.comments`)."""

from app.models.base import Base
from app.models.comments import describe
from app.models.experiment import Experiment, ExperimentCheckpoint
from app.models.graph import (
    Artifact,
    Clip,
    Edge,
    ExpansionClip,
    Graph,
    GrowthEpoch,
    GrowthRequest,
    SimulatedClip,
    Vertex,
)
from app.models.play import (
    EdgeKindName,
    GraphSessions,
    PlayCount,
    Player,
    PlayLength,
    PlayVisit,
    Publication,
    PublicationEdge,
    Trace,
    TraceStep,
)

describe(Base.metadata)

__all__ = [
    "Artifact",
    "Base",
    "Clip",
    "Edge",
    "EdgeKindName",
    "Experiment",
    "ExperimentCheckpoint",
    "ExpansionClip",
    "Graph",
    "GrowthEpoch",
    "GraphSessions",
    "GrowthRequest",
    "PlayCount",
    "PlayLength",
    "PlayVisit",
    "Player",
    "Publication",
    "PublicationEdge",
    "SimulatedClip",
    "Trace",
    "TraceStep",
    "Vertex",
]
