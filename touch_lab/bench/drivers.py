"""``social-touch bench drivers``: decode + calibrate cost per frame of each sensor, in one run.

Each sensor's own benchmark (``touch_driver/<sensor>/bench.py``) times pre-encoded frames of
its virtual device (synthetic) through the real decoder and calibration; this gathers the
three so their ratios to the frame period come from the same machine at the same time.
"""

from __future__ import annotations

from touch_lab.bench.bear_driver import bench_decode_calibrate as bench_bear
from touch_lab.bench.patch_driver import bench_decode_calibrate as bench_patch
from touch_lab.bench.skin_driver import bench_decode_calibrate as bench_skin

__all__ = ['bench_drivers']


def bench_drivers(repeats: int = 7) -> dict:
    """``{"bear": {...}, "patch": {...}, "skin": {...}}``, each with ``us_per_frame`` (median) and its ratio."""
    return {'bear': bench_bear(repeats=repeats), 'patch': bench_patch(repeats=repeats),
            'skin': bench_skin(repeats=repeats),
            'goal': 'decode + calibrate <= 1 % of the frame period on one core'}
