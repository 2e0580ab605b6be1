"""Benchmark: decode + calibrate cost per patch frame (for ``social-touch bench drivers``).

Frames are pre-encoded by the virtual patch (synthetic strokes and a panel touch) and fed
one at a time through :class:`~touch_driver.patch.protocol.PatchDecoder`, the calibration
and the panel contact detector. Two firmware modes:

- raw 100 Hz scans (the virtual patch's default): per scan, decode + moving average +
  panel contact, and eq. (1)-(2) on every 5th scan; goal 1 % of 10 ms = 100 us per scan;
- 20 Hz averaged frames (the paper's firmware): per frame, decode + eq. (1)-(2) + panel
  contact; goal 1 % of 50 ms = 500 us per frame.

Each repeat times the whole set; figures are medians over repeats of the time per frame.

"""

from __future__ import annotations

import statistics
import time

from touch_driver.patch.calibration import PanelCalibrator, PatchCalibrator
from touch_driver.patch.protocol import PatchDecoder
from touch_lab.bench.timing import gc_paused
from touch_sim.patch.device import PatchDevice
from touch_sim.scenes import PanelTouch, PatchScript, PatchTouch

__all__ = ['bench_decode_calibrate']

GOAL_FRACTION = 0.01


def _frames(n: int, mode: str, seed: int) -> tuple[list[bytes], float]:
    script = PatchScript([PatchTouch(at=(8, 2), to=(8, 13), radius=1.3, pressure=2.5, start=0.2, duration=1.0),
                          PatchTouch(at=(5, 6), radius=1.8, pressure=4.0, start=1.5, duration=2.0)],
                         [PanelTouch(panels=(3,), start=0.5, duration=1.5, level=1.0)])
    device = PatchDevice(script, mode=mode, seed=seed)
    return [device.frame_bytes(i, i * device.frame_period) for i in range(n)], device.frame_period


def _time_per_frame(frames: list[bytes], rate_hz: float) -> float:
    decoder, calibrator, panels = PatchDecoder(), PatchCalibrator(), PanelCalibrator(rate_hz=rate_hz)
    start = time.perf_counter()
    for frame in frames:
        for scan in decoder.feed(frame):
            panels.update(scan.panels)
            if scan.raw_scan:
                calibrator.update_scan(scan.cells)
            else:
                calibrator.update(scan.cells)
    return (time.perf_counter() - start) / len(frames)


def bench_decode_calibrate(repeats: int = 7, frames: int = 500, seed: int = 0) -> dict:
    """Median cost per frame of decode + calibrate (matrix and panels), in microseconds.

    Returns:
        dict with ``us_per_frame`` / ``frame_period_us`` / ``ratio`` for raw 100 Hz scans (the
        virtual patch's default stream), the same keys suffixed ``_averaged`` for 20 Hz averaged
        frames, ``goal_ratio`` (0.01), ``meets_goal``, ``repeats``, ``frames``.
    """
    if repeats < 1 or frames < 10:
        raise ValueError(f'repeats >= 1 and frames >= 10 are required; got {repeats}, {frames}')
    out: dict = {'sensor': 'patch', 'synthetic_data': True}
    with gc_paused():
        for mode, suffix in (('raw', ''), ('averaged', '_averaged')):
            data, period = _frames(frames, mode, seed)
            us = 1e6 * statistics.median(_time_per_frame(data, 1.0 / period) for _ in range(repeats))
            out[f'us_per_frame{suffix}'] = us
            out[f'frame_period_us{suffix}'] = 1e6 * period
            out[f'ratio{suffix}'] = us / (1e6 * period)
    out.update(goal_ratio=GOAL_FRACTION, meets_goal=max(out['ratio'], out['ratio_averaged']) <= GOAL_FRACTION,
               repeats=repeats, frames=frames)
    return out

