"""The cloud matcher's numpy assignment finds scipy's optimum (``linear_sum_assignment``, which it replaces).

The optimal total cost is unique even where several assignments reach it, so the totals are
compared: each is a sum of n float64 costs in its own order, each within (n - 1) * eps of the
sum of |costs| (Higham, Accuracy and Stability, 4.2), so they may differ by twice that.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from touch_gestures.skin.assignment import min_cost_assignment

EPS = np.finfo(np.float64).eps


def check(cost: np.ndarray) -> None:
    n = len(cost)
    cols = min_cost_assignment(cost)
    assert sorted(cols.tolist()) == list(range(n))                       # one to one
    rows, theirs = linear_sum_assignment(cost)
    ours, best = cost[np.arange(n), cols], cost[rows, theirs]
    bound = 2 * max(n - 1, 1) * EPS * (np.abs(ours).sum() + np.abs(best).sum())
    assert abs(ours.sum() - best.sum()) <= bound


@pytest.mark.parametrize('seed', range(4))
def test_random_costs_of_every_scale_and_size(seed):
    rng = np.random.default_rng(seed)
    for trial in range(400):
        n = int(rng.integers(1, 40))
        cost = rng.random((n, n)) * 10.0 ** rng.uniform(-6, 6)
        if trial % 3 == 0:
            cost = np.round(cost / cost.max(), 1)     # many ties
        if trial % 5 == 0:
            cost -= 0.5                               # negative costs too
        check(cost)


def test_point_clouds_as_the_matcher_sees_them():
    rng = np.random.default_rng(7)
    for _ in range(300):
        p = rng.random((32, 2))
        q = p[rng.permutation(32)] + rng.normal(0.0, rng.uniform(0.0, 0.3), (32, 2))
        check(np.sqrt(((p[:, None] - q[None]) ** 2).sum(axis=2)))


def test_rejects_what_has_no_assignment():
    with pytest.raises(ValueError, match='square'):
        min_cost_assignment(np.zeros((2, 3)))
    with pytest.raises(ValueError, match='finite'):
        min_cost_assignment(np.array([[0.0, np.nan], [1.0, 2.0]]))
