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
mean on seeds 10-14 and not made the default (docs/experiment.md, "`squared`").
"""

from __future__ import annotations

from enum import StrEnum


class RankError(StrEnum):
    #: the error itself: growth minimises the expected error per step (the paper's)
    MEAN = "mean"
    #: its square: growth minimises the expected squared error per step
    SQUARED = "squared"

    def cost(self, err: float) -> float:
        """What a blend with error ``err`` costs a player who takes it."""
        return err * err if self is RankError.SQUARED else err
