"""Every plot of the experiment report labels both axes with units; the contact sheet
captions its frames."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

from app.reports.contact_sheet import Tile, contact_sheet
from app.reports.experiment import (
    FIGURES,
    plot_density_graph,
    plot_density_scatter,
    plot_histograms,
    plot_metric,
)


def result() -> dict[str, Any]:
    rows = [
        {
            "size_frames": size,
            "observed_mean_error": error,
            "high_error_fraction": error / 2,
            "high_error_threshold": 0.5,
            "n_steps": 100,
            "density_correlation": 0.5,
            "arrays": "digest",
        }
        for size, error in ((300, 1.0), (600, 0.5))
    ]
    strategies = {s: {"0": rows} for s in ("baseline", "sr-crowd")}
    return {"plan": {"dynamics": "liquid", "seeds": [0]}, "results": strategies}


def arrays(_: str) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {
        "step_errors": rng.random(50),
        "predicted_density": rng.random(12) / 12,
        "observed_density": rng.random(12) / 12,
        "vertex_descriptors": rng.random((4, 216)),
        "edge_dst": rng.integers(0, 4, 12),
        "edge_kind": np.array([0, 1] * 6),
    }


@pytest.fixture
def labels(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """(x label, y label) of every axes of every saved figure."""
    seen: list[tuple[str, str]] = []
    save = Figure.savefig

    def record(self: Figure, *args: Any, **kwargs: Any) -> None:
        seen.extend((ax.get_xlabel(), ax.get_ylabel()) for ax in self.axes)
        save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", record)
    return seen


def test_every_axis_is_labelled_with_its_unit(
    tmp_path: Path, labels: list[tuple[str, str]]
) -> None:
    for key, (title, ylabel, name) in FIGURES.items():
        plot_metric(result(), key, title, ylabel, tmp_path / name)
    plot_histograms(result(), arrays, tmp_path / "histogram.png")
    plot_density_scatter(result(), arrays, tmp_path / "scatter.png")
    plot_density_graph(result(), "sr-crowd", arrays, tmp_path / "graph.png")
    assert len(labels) == 7
    for x, y in labels:
        assert x and y and "(" in x and "(" in y, (x, y)
    assert "mean error per step (eq. 3, m³/√J)" in [y for _, y in labels]


def test_the_contact_sheet_has_a_title_and_a_caption_under_each_frame() -> None:
    frame = np.zeros((30, 40, 3), dtype=np.uint8)
    tiles = [Tile(frame, ("vertex 1, control 0", "simulated")) for _ in range(5)]
    sheet = contact_sheet("graph g, publication 1", tiles, columns=4)
    assert sheet.shape[1] >= 4 * 180 and sheet.shape[2] == 3
    enlarged = 180 // 40 + 1  # 40 px frames enlarged five times to hold a caption
    title_band = sheet[:20]
    assert (title_band < 128).any()
    first_caption = sheet[20 + 4 + 30 * enlarged : 20 + 4 + 30 * enlarged + 32, :180]
    assert (first_caption < 128).any() and not (first_caption < 128).all()
