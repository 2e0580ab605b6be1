"""The decision's distance and margin against their definition: ties, one class, NaN and inf."""

from __future__ import annotations

import numpy as np

from touch_gestures.skin.clouds import CloudRecogniser


def test_the_margin_is_the_runner_up_less_the_nearest_as_numpy_partitions_them():
    rec = CloudRecogniser(max_distance=None, min_margin=0.0)
    rng = np.random.default_rng(0)
    rec.set_codebook(rng.normal(0, 0.3, (5, 64)), ['a', 'b', 'c', 'd', 'e'])
    cases = [rng.uniform(0, 1, 5) for _ in range(50)]
    cases += [np.array([0.2, 0.2, 0.5, 0.9, 1.0]), np.array([0.3, np.inf, 0.1, np.inf, 0.1]),
              np.array([0.3, np.nan, 0.1, 0.2, 0.4]), np.array([np.nan] * 5), np.array([np.inf] * 5)]
    for per_class in cases:
        match = rec.decide(per_class)
        best = int(np.argmin(per_class))
        margin = float(np.partition(per_class, 1)[1]) - float(per_class[best])
        assert match.nearest == rec.classes_[best]
        np.testing.assert_equal([match.distance, match.margin], [per_class[best], margin])
    one = CloudRecogniser(max_distance=None)
    one.set_codebook(rng.normal(0, 0.3, (2, 64)), ['a', 'a'])
    assert one.decide(np.array([0.4])).margin == np.inf
