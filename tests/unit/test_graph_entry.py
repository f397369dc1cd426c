"""A stored graph's scene is typed once: what it stores, what it reads back, what it refuses."""

from __future__ import annotations

import pytest

from app.core.errors import InvalidInput
from app.core.graph.graph_entry import DEFAULT_FPS, GraphEntry, GraphScene


def test_a_scene_stores_only_the_keys_it_has_and_reads_them_back() -> None:
    liquid = GraphScene(fps=30.0, preset="paper", fluid="high")
    assert liquid.to_json() == {"fps": 30.0, "preset": "paper", "fluid": "high"}
    assert GraphScene.from_json(liquid.to_json()) == liquid
    toy = GraphScene(fps=24.0)
    assert toy.to_json() == {"fps": 24.0}
    assert GraphScene.from_json({}) == GraphScene.from_json(None) == GraphScene()


def test_a_scene_of_an_older_graph_reads_as_the_low_fluid_at_the_default_rate() -> None:
    old = GraphScene.from_json({"preset": "small", "fps": 30})  # before the fluid was stored
    assert old.fluid is None and old.fps == 30.0 and isinstance(old.fps, float)
    entry = GraphEntry(1, "g", "toy", 3, 10, GraphScene(), "sr-crowd", "eq2", growing=False)
    assert entry.fps == DEFAULT_FPS
    assert entry.frames_per_expansion == 30


@pytest.mark.parametrize(
    "stored", [{"fps": "30"}, {"fps": True}, {"preset": 3}, {"fluid": ["high"]}]
)
def test_a_scene_of_the_wrong_types_is_refused(stored: dict[str, object]) -> None:
    with pytest.raises(InvalidInput, match="graph scene"):
        GraphScene.from_json(stored)
