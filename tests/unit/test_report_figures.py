"""The experiment report's plots: both axes labelled with units, every title, label and
legend inside the figure and clear of the others and of the data, Figs. 5 and 6 ticked at
the checkpoints with a band only where seeds give one; the contact sheet captions its
frames."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import RendererAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.legend import Legend
from matplotlib.patches import StepPatch
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from app.reports.contact_sheet import Tile, contact_sheet
from app.reports.figures import (
    FIGURES,
    plot_density_graph,
    plot_density_scatter,
    plot_histograms,
    plot_metric,
)

COMPARED = ("baseline", "sr-crowd")
STRATEGIES = ("max-error", "baseline", "sr-heuristic", "sr-crowd")
#: the checkpoints of the plan, and the sizes the graphs reached (an epoch overshoots)
CHECKPOINTS = [300, 600, 1000, 1500]
REACHED = [300, 600, 1020, 1500]


def result(seeds: int = 1, strategies: tuple[str, ...] = COMPARED) -> dict[str, Any]:
    def rows(seed: int) -> list[dict[str, Any]]:
        return [
            {
                "size_frames": size,
                "observed_mean_error": (1.0 + 0.1 * seed) / (i + 1),
                "high_error_fraction": 0.5 / (i + 1 + seed),
                "high_error_threshold": 0.5,
                "n_steps": 100,
                "density_correlation": 0.5,
                "arrays": "digest",
            }
            for i, size in enumerate(REACHED)
        ]

    return {
        "plan": {"dynamics": "liquid", "seeds": list(range(seeds)), "checkpoints": CHECKPOINTS},
        "results": {s: {str(seed): rows(seed) for seed in range(seeds)} for s in strategies},
    }


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


class Drawn(NamedTuple):
    """A saved figure and the renderer it was drawn with (``plt.close`` takes its canvas)."""

    figure: Figure
    renderer: RendererAgg

    def extent(self, artist: Text | Axes | Legend) -> Bbox:
        return artist.get_window_extent(self.renderer)


@pytest.fixture
def saved(monkeypatch: pytest.MonkeyPatch) -> list[Drawn]:
    """Every figure saved, as laid out and drawn by its savefig."""
    drawn: list[Drawn] = []
    save = Figure.savefig

    def record(self: Figure, *args: Any, **kwargs: Any) -> None:
        save(self, *args, **kwargs)
        drawn.append(Drawn(self, self.canvas.get_renderer()))

    monkeypatch.setattr(Figure, "savefig", record)
    return drawn


def plot_all(directory: Path, seeds: int = 1, strategies: tuple[str, ...] = COMPARED) -> None:
    for key, (title, ylabel, name) in FIGURES.items():
        plot_metric(result(seeds, strategies), key, title, ylabel, directory / name)
    plot_histograms(result(seeds, strategies), arrays, directory / "histogram.png")
    plot_density_scatter(result(seeds, strategies), arrays, directory / "scatter.png")
    plot_density_graph(result(seeds, strategies), "sr-crowd", arrays, directory / "graph.png")


def texts(figure: Figure) -> list[Text]:
    """The figure's title and legends' text, and each axes' title and axis labels."""
    found = list(figure.texts)  # the suptitle among them
    for ax in figure.axes:
        found += [ax.title, ax.xaxis.label, ax.yaxis.label]
    for legend in legends(figure):
        found += legend.get_texts()
    return [text for text in found if text.get_text()]


def legends(figure: Figure) -> list[Legend]:
    return figure.legends + [ax.get_legend() for ax in figure.axes if ax.get_legend()]


def test_every_axis_is_labelled_with_its_unit(tmp_path: Path, saved: list[Drawn]) -> None:
    plot_all(tmp_path)
    labels = [(ax.get_xlabel(), ax.get_ylabel()) for drawn in saved for ax in drawn.figure.axes]
    assert len(labels) == 7
    for x, y in labels:
        assert x and y and "(" in x and "(" in y, (x, y)
    assert "mean error per step (eq. 3, m³/√J)" in [y for _, y in labels]


@pytest.mark.parametrize("strategies", [("sr-crowd",), COMPARED, STRATEGIES])
def test_titles_labels_and_legends_lie_inside_the_figure_and_apart(
    tmp_path: Path, saved: list[Drawn], strategies: tuple[str, ...]
) -> None:
    """The finding: the density scatter's title was cut at both ends and two of its axis
    labels overlapped."""
    plot_all(tmp_path, strategies=strategies)
    for drawn in saved:
        assert isinstance(drawn.figure.get_layout_engine(), ConstrainedLayoutEngine)
        whole = drawn.figure.bbox.padded(1.0)
        boxes = [(text.get_text(), drawn.extent(text)) for text in texts(drawn.figure)]
        for text, box in boxes:
            assert whole.containsx(box.x0) and whole.containsx(box.x1), text
            assert whole.containsy(box.y0) and whole.containsy(box.y1), text
        for i, (text, box) in enumerate(boxes):
            for other, other_box in boxes[i + 1 :]:
                assert not box.overlaps(other_box), (text, other)


def test_the_legends_sit_off_the_data(tmp_path: Path, saved: list[Drawn]) -> None:
    """The finding: the histogram's legend hid baseline's tallest bar. Every legend lies
    outside every axes, so over no bar, line or point."""
    plot_all(tmp_path, seeds=3)
    for drawn in saved:
        assert legends(drawn.figure)
        for legend in legends(drawn.figure):
            for ax in drawn.figure.axes:
                assert not drawn.extent(legend).overlaps(drawn.extent(ax))
    (histogram,) = [d for d in saved if "Fig. 7" in d.figure.axes[0].get_title()]
    (ax,) = histogram.figure.axes
    bars = [bar for patch in ax.patches for bar in bar_extents(ax, histogram.extent(ax), patch)]
    assert len(bars) > 2 * 5
    for legend in legends(histogram.figure):
        assert not any(histogram.extent(legend).overlaps(bar) for bar in bars)


def bar_extents(ax: Axes, frame: Bbox, patch: Any) -> list[Bbox]:
    """Where each non-empty bin of a histogram's StepPatch lies on the canvas: its width,
    from the axes' floor (a log axis has no zero) up to its height."""
    if not isinstance(patch, StepPatch):
        return []
    values, edges, _ = patch.get_data()
    boxes = []
    for value, left, right in zip(values, edges[:-1], edges[1:], strict=True):
        if value > 0:
            (x0, top), (x1, _) = ax.transData.transform([(left, value), (right, value)])
            boxes.append(Bbox([[x0, frame.y0], [x1, top]]))
    return boxes


@pytest.mark.parametrize("key", list(FIGURES))
def test_figs_5_and_6_tick_at_the_checkpoints(tmp_path: Path, saved: list[Drawn], key: str) -> None:
    """The finding: a log axis under one decade ticked 3x10^2, 4x10^2 and 6x10^2."""
    title, ylabel, name = FIGURES[key]
    plot_metric(result(), key, title, ylabel, tmp_path / name)
    (ax,) = saved[0].figure.axes
    assert list(ax.get_xticks()) == CHECKPOINTS
    assert [label.get_text() for label in ax.get_xticklabels()] == ["300", "600", "1,000", "1,500"]
    assert list(ax.get_xticks(minor=True)) == []


def test_one_seed_draws_no_band_and_promises_none(tmp_path: Path, saved: list[Drawn]) -> None:
    """The finding: Figs. 5 and 6 promised a band ("min to max") that one seed cannot give."""
    for key, (title, ylabel, name) in FIGURES.items():
        plot_metric(result(seeds=1), key, title, ylabel, tmp_path / name)
    for drawn in saved:
        (ax,) = drawn.figure.axes
        assert not [c for c in ax.collections if isinstance(c, PolyCollection)]
        words = " ".join(text.get_text() for text in texts(drawn.figure))
        assert "interval" not in words and "band" not in words, words
        assert "one seed" in ax.get_title()


def test_several_seeds_draw_each_strategy_s_band_and_say_what_it_is(
    tmp_path: Path, saved: list[Drawn]
) -> None:
    title, ylabel, name = FIGURES["observed_mean_error"]
    plot_metric(result(seeds=3), "observed_mean_error", title, ylabel, tmp_path / name)
    (drawn,) = saved
    (ax,) = drawn.figure.axes
    bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bands) == len(COMPARED)
    (legend,) = drawn.figure.legends
    assert "95 % interval over 3 seeds" in [text.get_text() for text in legend.get_texts()]
    assert "mean over 3 seeds" in ax.get_title()


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
