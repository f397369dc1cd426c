"""The argument checks the player models share: what a model's inputs must be."""

from __future__ import annotations

import numpy as np


def check_distributions(rows: np.ndarray, what: str) -> None:
    """Raise ValueError unless every row of ``rows`` is a probability distribution."""
    if np.any(rows < 0.0) or not np.allclose(rows.sum(axis=1), 1.0):
        raise ValueError(f"{what} rows must be probability distributions (non-negative, sum 1)")


def check_counts(counts: np.ndarray) -> None:
    """Raise ValueError unless control counts are finite and non-negative."""
    if not np.all(np.isfinite(counts)) or np.any(counts < 0.0):
        raise ValueError("control_counts must be finite and non-negative")


def checked_controls(vertex_control: np.ndarray, n_controls: int) -> np.ndarray:
    """``vertex_control`` as int64, once it is a 1-D array of controls in 0..N-1;
    ValueError otherwise."""
    if n_controls < 1:
        raise ValueError(f"n_controls must be at least 1, got {n_controls}")
    vertex_control = np.asarray(vertex_control)
    if vertex_control.ndim != 1:
        raise ValueError(f"vertex_control must be 1-D, got shape {vertex_control.shape}")
    if vertex_control.size and not np.issubdtype(vertex_control.dtype, np.integer):
        raise ValueError(f"vertex_control must hold integers, got dtype {vertex_control.dtype}")
    if vertex_control.size and not 0 <= vertex_control.min() <= vertex_control.max() < n_controls:
        raise ValueError(f"vertex_control holds controls outside 0..{n_controls - 1}")
    return vertex_control.astype(np.int64, copy=False)
