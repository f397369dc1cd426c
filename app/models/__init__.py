"""SQLAlchemy models; importing this package registers every table on ``Base.metadata``."""

from app.models.base import Base
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
    GraphSessions,
    PlayCount,
    Player,
    PlayLength,
    Publication,
    PublicationEdge,
    Trace,
    TraceStep,
)

__all__ = [
    "Artifact",
    "Base",
    "Clip",
    "Edge",
    "Experiment",
    "ExperimentCheckpoint",
    "ExpansionClip",
    "Graph",
    "GrowthEpoch",
    "GraphSessions",
    "GrowthRequest",
    "PlayCount",
    "PlayLength",
    "Player",
    "Publication",
    "PublicationEdge",
    "SimulatedClip",
    "Trace",
    "TraceStep",
    "Vertex",
]
