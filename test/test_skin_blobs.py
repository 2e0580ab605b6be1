"""The skin's numpy blob count equals scipy.ndimage's dilation and labelling, which it replaces in the node."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from touch_gestures.skin.blobs import count_blobs, grown
from touch_gestures.skin.gesture import GRID

EIGHT = np.ones((3, 3), dtype=bool)


def reference(mask: np.ndarray, grow: int) -> int:
    image = ndimage.binary_dilation(mask, structure=EIGHT, iterations=grow) if grow else mask
    return int(ndimage.label(image, structure=EIGHT)[1])


@pytest.mark.parametrize('grow', [0, 1, 2, 3])
def test_count_equals_scipy_on_random_maps(grow):
    rng = np.random.default_rng(grow)
    for _ in range(3000):
        rows, cols = rng.integers(1, 2 * GRID, size=2)
        mask = rng.random((rows, cols)) < rng.random()   # from empty to full, every density between
        assert count_blobs(mask, grow) == reference(mask, grow)
        if grow:
            np.testing.assert_array_equal(grown(mask, grow), ndimage.binary_dilation(mask, EIGHT, iterations=grow))


def test_shapes_that_join_only_through_corners_or_late_rows():
    u_shape = np.zeros((5, 5), dtype=bool)
    u_shape[:, 0] = u_shape[:, 4] = u_shape[4] = True          # two arms joined by the last row
    diagonal = np.eye(6, dtype=bool)                           # corners only
    gap_rows = np.zeros((6, 3), dtype=bool)
    gap_rows[0] = gap_rows[3] = True                           # two empty rows between
    for mask in (u_shape, diagonal, gap_rows, np.zeros((GRID, GRID), dtype=bool), np.ones((GRID, GRID), dtype=bool)):
        for grow in (0, 1):
            assert count_blobs(mask, grow) == reference(mask, grow)
