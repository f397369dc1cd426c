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
