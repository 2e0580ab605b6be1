"""Benchmark of the skin driver's per-frame work: stream decode + calibration.

Goal (issue 3): at most 1 % of the frame period on one core, i.e. 66.7 us per frame at 150 Hz.
``social-touch bench drivers --json`` reports :func:`bench_decode_calibrate`.

The input is synthetic: frames rendered by the simulator for a scene with a press, a traced line and
untouched skin, pre-encoded to wire bytes, so the timing covers the decoder (resync, CRC, reorder)
and every calibration branch (tare, contact, centroid, forces, drift tracking with frozen taxels).
The dictionary has the same keys as the bear and patch benchmarks.
"""

from __future__ import annotations

import statistics
import time

from touch_driver.skin.calibration import SkinCalibrationConfig, SkinCalibrator
from touch_driver.skin.protocol import FRAME_PERIOD_S, SkinStreamDecoder, encode_skin_frame
from touch_lab.bench.timing import gc_paused
from touch_sim.skin.device import render_frames
from touch_sim.skin.stimuli import LineStroke, StaticPress, Timeline

__all__ = ['bench_decode_calibrate']

GOAL_RATIO = 0.01  # issue 3: at most 1 % of the frame period


def _wire_frames(n_frames: int, seed: int) -> list[bytes]:
    scene = Timeline([StaticPress(12.0, 30.0, 2.0, at_s=0.6, for_s=2.0),
                      LineStroke((5.0, 5.0), (42.0, 20.0), 1.5, at_s=1.2, for_s=1.5)])
    frames = render_frames(scene, duration_s=(n_frames - 1) * FRAME_PERIOD_S, seed=seed)
    return [encode_skin_frame(i, raw) for i, raw in enumerate(frames)]


def _seconds(wires: list[bytes], decode: bool, calibrate: bool, config: SkinCalibrationConfig | None) -> float:
    """One pass with a fresh decoder and calibrator: wall time of the selected parts, s."""
    dec, cal = SkinStreamDecoder(), SkinCalibrator(config)
    raws = [] if decode else [f.raw for w in wires for f in dec.feed(w)]
    start = time.perf_counter()
    if decode and calibrate:
        for wire in wires:                      # one frame per feed, as a port read delivers it
            for frame in dec.feed(wire):
                cal.update(frame.raw)
    elif decode:
        for wire in wires:
            dec.feed(wire)
    else:
        for raw in raws:
            cal.update(raw)
    return time.perf_counter() - start


def bench_decode_calibrate(repeats: int = 7, frames: int = 600, seed: int = 0,
                           config: SkinCalibrationConfig | None = None) -> dict:
    """Median per-frame cost of decoding wire bytes and calibrating, over ``repeats`` passes of ``frames``.

    Returns:
        dict with ``us_per_frame`` (decode + calibrate), ``decode_us``, ``calibrate_us`` (each the
        median of its own passes, microseconds per frame), ``frame_period_us``, ``ratio``
        (us_per_frame / frame_period_us), ``goal_ratio`` (0.01), ``meets_goal``, ``repeats``,
        ``frames``, ``sensor`` ('skin') and ``synthetic_data`` (True).
    """
    if repeats < 1 or frames < 10:
        raise ValueError(f'repeats >= 1 and frames >= 10 are required; got {repeats}, {frames}')
    wires = _wire_frames(frames, seed)
    decoded = sum(len(SkinStreamDecoder().feed(w)) for w in wires)
    if decoded != frames:
        raise RuntimeError(f'decoder returned {decoded} of {frames} frames; the benchmark input is broken')
    results = {}
    with gc_paused():
        for key, decode, calibrate in (('us_per_frame', True, True), ('decode_us', True, False),
                                       ('calibrate_us', False, True)):
            results[key] = 1e6 / frames * statistics.median(
                _seconds(wires, decode, calibrate, config) for _ in range(repeats))
    period_us = FRAME_PERIOD_S * 1e6
    return {
        'sensor': 'skin', 'synthetic_data': True, **results,
        'frame_period_us': period_us, 'ratio': results['us_per_frame'] / period_us,
        'goal_ratio': GOAL_RATIO, 'meets_goal': results['us_per_frame'] <= GOAL_RATIO * period_us,
        'repeats': repeats, 'frames': frames,
    }

