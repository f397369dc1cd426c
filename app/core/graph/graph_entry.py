"""A stored graph as the layers above the store see it: a value, not a database row.

The store hands out a :class:`GraphEntry` (``app.store.graph_catalogue.graph_entry``), so
that services and shells never hold a row past the session it came from, and the scene
a graph's dynamics is rebuilt from is typed once, here, instead of read from a dict
wherever it is needed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.core.errors import InvalidInput

#: the frame rate of a graph whose scene does not say (toy graphs made before it did)
DEFAULT_FPS = 30.0


@dataclass(frozen=True)
class GraphScene:
    """What rebuilds a graph's dynamics: the liquid's preset and fluid, and its frame rate.

    Stored as a JSON object of the keys that are set: a toy graph has no preset, and a
    liquid graph grown before the fluid was stored has none either (it is ``low``).
    """

    fps: float | None = None
    preset: str | None = None
    fluid: str | None = None

    def to_json(self) -> dict[str, Any]:
        fields = {"fps": self.fps, "preset": self.preset, "fluid": self.fluid}
        return {key: value for key, value in fields.items() if value is not None}

    @classmethod
    def from_json(cls, data: Mapping[str, Any] | None) -> GraphScene:
        """The scene of a stored JSON object; a key of the wrong type is refused."""
        data = data or {}
        fps, preset, fluid = data.get("fps"), data.get("preset"), data.get("fluid")
        if fps is not None and (isinstance(fps, bool) or not isinstance(fps, int | float)):
            raise InvalidInput(f"a graph scene's fps is a number, got {fps!r}")
        for key, value in (("preset", preset), ("fluid", fluid)):
            if value is not None and not isinstance(value, str):
                raise InvalidInput(f"a graph scene's {key} is a string, got {value!r}")
        return cls(None if fps is None else float(fps), preset, fluid)


@dataclass(frozen=True)
class GraphEntry:
    """A stored graph's identity and settings, as its row held them when read."""

    id: int
    name: str
    dynamics: str
    n_controls: int
    frames_per_clip: int
    scene: GraphScene
    strategy: str
    player_model: str
    growing: bool
    #: the world seed its start state was made from (None: the dynamics' canonical start)
    world: int | None = None

    @property
    def fps(self) -> float:
        return DEFAULT_FPS if self.scene.fps is None else self.scene.fps

    @property
    def frames_per_expansion(self) -> int:
        """Simulated frames one expansion adds: a clip per control."""
        return self.n_controls * self.frames_per_clip
