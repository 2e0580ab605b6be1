"""Tracing trajectories across the virtual skin, and the calibrated contact point that comes back (synthetic)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.skin.calibration import calibrate_frames
from touch_sim.skin.device import render_frames
from touch_sim.skin.traces import TraceStimulus, clock_tick, spread_stamps, traced_strokes

PITCH = 47 / 12


def test_bounding_box_fills_the_area_keeping_aspect_and_margin():
    # A tall shape: 20 px wide, 100 px high, y growing downward on the screen.
    stim = TraceStimulus.from_points([100, 120, 120], [300, 300, 400], [0, 100, 200])
    xy = stim.strokes[0][:, 1:]
    assert xy[:, 1].min() == pytest.approx(PITCH) and xy[:, 1].max() == pytest.approx(47 - PITCH)
    assert np.ptp(xy[:, 0]) == pytest.approx(np.ptp(xy[:, 1]) / 5)        # aspect ratio kept
    assert (xy[:, 0].min() + xy[:, 0].max()) / 2 == pytest.approx(23.5)                # centred
    assert xy[2, 1] > xy[1, 1]                                              # screen down = more rows


def test_degenerate_shapes():
    tap = TraceStimulus.from_points([5], [5], [0])
    (c,) = tap.contacts(0.55)
    assert (c.x_mm, c.y_mm, c.vx_mm_s) == (23.5, 23.5, 0.0)
    line = TraceStimulus.from_points([0, 50, 100], [7, 7, 7], [0, 100, 200], margin_mm=0)
    assert line.strokes[0][:, 1].tolist() == pytest.approx([0, 23.5, 47])
    assert line.strokes[0][:, 2].tolist() == pytest.approx([23.5] * 3)
    dup = TraceStimulus.from_points([0, 1, 2], [0, 1, 2], [0, 0, 10])     # one time: spread over its tick
    assert dup.strokes[0][:, 0].tolist() == pytest.approx([0.55, 0.555, 0.56])
    # A dot whose pen-down was logged twice in the tick the first one ended is one touch, not an overlap;
    # its three points keep their order in time within that millisecond.
    bang = TraceStimulus.from_points([0, 0, 0, 0, 0], [0, 90, 100, 100, 100], [0, 100, 300, 301, 300],
                                     stroke=[0, 0, 1, 1, 2])
    assert [len(s) for s in bang.strokes] == [2, 3]
    assert bang.strokes[1][:, 0].tolist() == pytest.approx([0.85, 0.8505, 0.851])


def test_a_stroke_logged_in_one_tick_passes_every_point():
    """A bar of an X whose points the logger stamped at one time (Mixed Multistroke sample 2946): the finger
    moves along it within the tick instead of dabbing its last point."""
    stim = TraceStimulus.from_points([78, 75, 76, 166, 166, 84, 90, 99], [127, 130, 130, 16, 16, 21, 33, 46],
                                     [0, 0, 0, 0, 31, 609, 624, 640], stroke=[0, 0, 0, 0, 0, 1, 1, 1])
    bar = stim.strokes[0]
    assert len(bar) == 5 and np.all(np.diff(bar[:, 0]) > 0)
    assert bar[-2, 0] - bar[0, 0] == pytest.approx(3 * 0.016 / 4)      # the run of 4 spread over a 16 ms tick
    xy, down = stim.truth(np.array([bar[0, 0], bar[-2, 0]]))
    assert down.all() and np.hypot(*(xy[1] - xy[0])) > 30             # the finger crossed the skin


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(0, 6), min_size=1, max_size=30), st.floats(0.5, 40), st.sampled_from([math.inf, 5.0]))
def test_spread_stamps_keeps_every_point_it_can_in_order_within_its_tick(steps, tick, end_after):
    t = np.cumsum(np.asarray(steps, dtype=np.float64) * 8.0)          # runs of equal times, steps of 8 units
    end = t[-1] + end_after
    times, keep = spread_stamps(t, tick, end)
    kept = times[keep]
    assert keep[-1] and np.all(np.diff(kept) > 0) and kept[-1] < end
    assert np.all(times >= t) and np.all(times[keep] - t[keep] < tick)  # within the tick that stamped it
    assert np.array_equal(np.unique(t), np.unique(t[keep]))            # every time still has a point
    assert keep.all()                                                  # a finite tick and room: nothing dropped


def test_spread_stamps_without_a_tick_keeps_the_last_point_of_a_run():
    times, keep = spread_stamps(np.array([0.0, 0.0, 5.0, 5.0]), math.nan)
    assert times[keep].tolist() == [0.0, 5.0] and keep.tolist() == [False, True, False, True]
    assert math.isnan(clock_tick(np.array([3.0, 3.0]), np.array([0, 0])))   # no two distinct times: no tick
    times, keep = spread_stamps(np.array([]), 16.0)
    assert times.size == 0 and keep.size == 0


@pytest.mark.parametrize(('args', 'kwargs', 'message'), [
    (([0, 1], [0, 1], [0, np.nan]), {}, 'finite'),
    (([0, 1], [0, 1], [10, 0]), {}, 'must not decrease'),
    (([0, 1], [0], [0, 1]), {}, 'same length'),
    (([], [], []), {}, 'at least one point'),
    (([0, 1], [0, 1], [0, 1]), {'stroke': [0]}, 'one id per point'),
    (([0, 1, 2, 3], [0, 1, 2, 3], [0, 100, 50, 150]), {'stroke': [0, 0, 1, 1]}, 'overlaps'),
    (([0, 1], [0, 1], [0, 1]), {'margin_mm': 30}, 'area_mm > 2'),
])
def test_bad_input_is_rejected_with_a_clear_error(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        TraceStimulus.from_points(*args, **kwargs)


def test_timing_ramps_and_lift_between_strokes():
    # Two strokes of an "x", 300 ms apart; t in ms.
    x = [0, 100, 100, 0]
    y = [0, 100, 0, 100]
    t = [0, 400, 700, 1100]
    stim = TraceStimulus.from_points(x, y, t, stroke=[0, 0, 1, 1], lead_in_s=0.5, ramp_s=0.05, force_n=2.0)
    assert stim.contacts(0.49) == []                                    # lead-in: untouched
    assert stim.contacts(0.525)[0].force_n == pytest.approx(1.0)        # touch-down ramp at the first point
    (c,) = stim.contacts(0.75)                                          # halfway along stroke 0
    assert c.force_n == 2.0 and (c.x_mm, c.y_mm) == pytest.approx((23.5, 23.5))
    assert c.vx_mm_s > 0 and c.vy_mm_s > 0
    assert stim.contacts(1.1) == []                                     # lifted between strokes
    assert stim.contacts(1.25)[0].x_mm == pytest.approx(47 - PITCH)     # stroke 1 starts top right
    assert stim.duration_s == pytest.approx(0.55 + 1.1 + 0.05 + 0.5)
    short = TraceStimulus.from_points(x, y, [0, 400, 420, 800], stroke=[0, 0, 1, 1], ramp_s=0.05)
    assert short.contacts(0.55 + 0.41) == []                            # ramps shrink to fit a 20 ms gap
    xy, down = stim.truth(np.array([0.2, 0.75, 1.1]))
    assert down.tolist() == [False, True, False] and np.isnan(xy[0]).all()


def circle(n: int = 60, period_ms: float = 1500.0):
    a = np.linspace(0, 2 * np.pi, n)
    return 200 + 80 * np.cos(a), 200 + 80 * np.sin(a), np.linspace(0, period_ms, n)


def test_traced_circle_comes_back_as_the_contact_point():
    x, y, t = circle()
    stim = TraceStimulus.from_points(x, y, t, force_n=1.5)
    frames = render_frames(stim, seed=3)
    out = calibrate_frames(frames)
    times = np.arange(len(frames)) / 150
    truth, down = stim.truth(times)
    full = np.array([bool(c) and c[0].force_n == 1.5 for c in map(stim.contacts, times)])
    assert out.contact[full].all()                                       # every full-force frame is a contact
    assert not out.contact[~down].any()                                 # and never without a finger
    err = np.linalg.norm(out.contact_xy_mm[full] - truth[full], axis=1)
    assert np.median(err) < 1.0 and err.max() < PITCH
    # Shear: the module x force summed over the skin follows the finger's x velocity.
    vx = np.array([c[0].vx_mm_s if c else 0.0 for c in map(stim.contacts, times)])
    fx = out.force[:, :, 0].sum(axis=1)
    fast = full & (np.abs(vx) > 40)
    assert np.mean(np.sign(fx[fast]) == np.sign(vx[fast])) > 0.9
    assert out.total_force[full].mean() == pytest.approx(1.5, rel=0.25)


def test_multistroke_contact_lifts_between_strokes():
    stim = TraceStimulus.from_points([0, 100, 100, 0], [0, 100, 0, 100], [0, 400, 900, 1300], stroke=[0, 0, 1, 1])
    out = calibrate_frames(render_frames(stim, seed=1))
    times = np.arange(len(out.contact)) / 150
    between = (times > 0.55 + 0.4 + 0.1) & (times < 0.55 + 0.9 - 0.1)
    assert not out.contact[between].any()
    runs = np.flatnonzero(np.diff(out.contact.astype(int)) == 1)
    assert len(runs) == 2                                                # two touch-downs


def test_traced_strokes_orders_strokes_in_time_and_spreads_their_runs():
    t = np.array([100.0, 100.0, 116.0, 0.0, 0.0, 16.0])
    strokes = traced_strokes(t, np.arange(6.0), np.zeros(6), np.array([0, 0, 0, 1, 1, 1]), 16.0)
    assert [s[0, 1] for s in strokes] == [3.0, 0.0]                      # stroke 1 came first
    assert strokes[0][:, 0].tolist() == [0.0, 8.0, 16.0] and strokes[1][:, 0].tolist() == [100.0, 108.0, 116.0]
