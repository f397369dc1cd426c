"""The band of Figs. 5 and 6: a mean over seeds with Student's t interval of that mean."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from app.core.evaluation.seed_interval import seed_interval


def test_the_interval_is_student_s_t_of_each_column() -> None:
    values = np.array([[1.0, 10.0], [2.0, 20.0], [4.0, 30.0]])
    spread = seed_interval(values)
    for column in range(2):
        low, high = stats.t.interval(
            0.95, 2, loc=values[:, column].mean(), scale=stats.sem(values[:, column])
        )
        assert spread.low[column] == pytest.approx(low)
        assert spread.high[column] == pytest.approx(high)
    np.testing.assert_allclose(spread.mean, values.mean(axis=0))
    assert list(spread.seeds) == [3, 3]


def test_one_seed_has_a_mean_and_no_interval() -> None:
    spread = seed_interval(np.array([[0.5, 0.25]]))
    np.testing.assert_allclose(spread.mean, [0.5, 0.25])
    assert np.isnan(spread.low).all() and np.isnan(spread.high).all()


def test_a_seed_without_the_figure_is_left_out() -> None:
    spread = seed_interval(np.array([[1.0, np.nan, np.nan], [3.0, 2.0, np.nan]]))
    assert list(spread.seeds) == [2, 1, 0]
    assert spread.mean[0] == 2.0 and spread.mean[1] == 2.0 and np.isnan(spread.mean[2])
    assert np.isfinite(spread.low[0]) and np.isnan(spread.low[1:]).all()


def test_the_level_must_lie_between_0_and_1() -> None:
    with pytest.raises(ValueError, match="level"):
        seed_interval(np.ones((2, 2)), level=1.0)
