"""What a blend's error costs when growth ranks it (docs/design.md, "What a blend's error
costs in growth").

Growth expands the blends with the largest ``weight * cost(err)``. The paper's cost is
the error itself, so growth minimises the expected error per step. That is blind to how
the error is spread: a blend a player meets rarely but that is large enough to be seen
weighs no more than a common faint one with the same product, and which of the large
ones growth happens to leave on a route decides a world's error from 10,000 frames on
(docs/experiment.md, the null). Squaring it weighs each blend's error by how visible it
is (its ratio to the visibility threshold, a constant that does not change the order),
so growth minimises the expected squared error per step instead. Selected against the
mean on seeds 10-14 and not made the default (docs/experiment.md, "`squared`"): it
also reorders the faint blends, which are most of what a young graph's players meet.
``squared-large`` squares only the large ones and leaves the faint ones to the mean.
"""

from __future__ import annotations

from enum import StrEnum

#: where ``squared-large`` turns from the error to its square, as a share of the
#: visibility threshold: half of it, where the reports call a blend large
LARGE_SHARE = 0.5


class RankError(StrEnum):
    #: the error itself: growth minimises the expected error per step (the paper's)
    MEAN = "mean"
    #: its square: growth minimises the expected squared error per step
    SQUARED = "squared"
    #: the error up to half the visibility threshold, beyond it the square scaled to meet
    #: the error there: faint blends rank as under ``mean``, large ones as under ``squared``
    SQUARED_LARGE = "squared-large"

    def cost(self, err: float, threshold: float) -> float:
        """What a blend with error ``err`` costs a player who takes it, where errors
        above ``threshold`` are visibly wrong."""
        if self is RankError.MEAN:
            return err
        if self is RankError.SQUARED:
            return err * err
        if not threshold > 0:
            raise ValueError(f"{self.value} needs a positive visibility threshold, not {threshold}")
        knee = LARGE_SHARE * threshold
        return err if err <= knee else err * err / knee
