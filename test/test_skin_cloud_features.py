"""The cloud's features against their definition, bit for bit (they are what every cloud decision reads)."""

from __future__ import annotations

import numpy as np
import pytest

from touch_gestures.skin.clouds import cloud_features
from touch_gestures.skin.features import arc_length_resample


def definition(points: np.ndarray, stroke: np.ndarray | None, n: int) -> np.ndarray:
    """Resampled along the ink, centred on the mean, divided by the larger side of the (n, 2) box."""
    cloud = arc_length_resample(points, n, stroke).view(np.complex128).reshape(-1).copy()
    cloud -= cloud.sum() / n
    xy = cloud.view(np.float64).reshape(n, 2)
    size = float((xy.max(axis=0) - xy.min(axis=0)).max())
    if size > 1e-9:
        xy = xy / size
    return xy.reshape(-1).astype(np.float32)


@pytest.mark.parametrize('seed', range(5))
def test_the_cloud_is_its_definition_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    for i in range(400):
        m = int(rng.integers(1, 60))
        pts = rng.normal(20, rng.choice([1e-12, 1.0, 15.0]), (m, 2)).astype(np.float32)
        if i % 7 == 0:
            pts[:] = pts[0]                                   # a dab: never moves
        if i % 11 == 0:
            pts[int(rng.integers(m)), int(rng.integers(2))] = np.nan   # bad input: NaN where numpy puts it
        stroke = np.sort(rng.integers(0, 3, m)).astype(np.int16) if i % 2 else None
        np.testing.assert_array_equal(cloud_features(pts, stroke, 32), definition(pts, stroke, 32))
