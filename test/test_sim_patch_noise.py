"""The simulated people's smooth noise is scipy's first-order filter, bit for bit, without scipy in the driver."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from touch_sim.patch import people


@pytest.mark.parametrize('n', [0, 1, 2, 37, 2000])
def test_smooth_noise_is_the_first_order_filter(n):
    for seed in range(50):
        corr_s = 0.05 + seed / 50
        ours = people._smooth_noise(np.random.default_rng(seed), n, 0.3, corr_s)
        rng = np.random.default_rng(seed)            # the same draws, in the same order
        alpha = people.TRACK_DT / corr_s
        noise = rng.normal(0.0, 0.3 * math.sqrt(2 * alpha), n)
        start = rng.normal(0.0, 0.3) * (1 - alpha)
        theirs = lfilter([1.0], [1.0, -(1.0 - alpha)], noise, zi=[start])[0]
        assert ours.dtype == theirs.dtype and np.array_equal(ours, theirs)
