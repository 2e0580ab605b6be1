"""Skin evaluation: traces -> virtual skin -> skin_driver (decode + calibration) -> segmenter -> recognisers.

Everything here is synthetic and small: a few synthetic performers, rendered through the skin
driver node in the harness (about 50 ms a sample).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from touch_gestures.skin.gesture import TouchGesture
from touch_lab.cli.main import main as social_touch
from touch_lab.skin.bench import (
    LIFT_S,
    MULTISTROKE_DEFAULT,
    STEPS,
    bench_recognition,
    in_strokes,
    predict_steps,
    synthetic_codebook,
)
from touch_lab.skin.datasets import TraceSample, write_traces
from touch_lab.skin.evaluate import RecogniserResult, choose_codebook, leave_one_subject_out
from touch_lab.skin.recognisers import make_recogniser
from touch_sim.skin.render import RenderedSample, RenderSettings, render_sample, render_samples
from touch_sim.skin.synthetic import synthetic_traces

SHAPES = ('line_right', 'line_left', 'diagonal_down')


@pytest.fixture(scope='module')
def small_set():
    return synthetic_traces(SHAPES, performers=3, repetitions=3, seed=4)


@pytest.fixture(scope='module')
def rendered(small_set):
    return render_samples(small_set, RenderSettings(mode='sensor', placement='mm'))


def test_the_sensor_path_gives_one_gesture_per_trace_close_to_the_finger(small_set, rendered):
    assert [len(r.gestures) for r in rendered] == [1] * len(small_set)
    for sample, r in zip(small_set, rendered, strict=True):
        g = r.gestures[0]
        assert not g.multi_contact and not g.truncated and g.binary_map.any()
        # The contact point follows the finger: start and end within a few mm of the true path.
        assert np.hypot(*(g.trajectory[0] - [sample.x[0], sample.y[0]])) < 4.0
        assert np.hypot(*(g.trajectory[-1] - [sample.x[-1], sample.y[-1]])) < 4.0
        assert g.duration_s == pytest.approx(sample.duration_ms / 1000, abs=0.1)


def test_direct_path_matches_the_true_trajectory(small_set):
    g = render_sample(small_set[0], RenderSettings(mode='direct', placement='mm'))[0]
    true = np.column_stack([small_set[0].x, small_set[0].y])
    assert np.abs(g.trajectory.min(axis=0) - true.min(axis=0)).max() < 0.5


def test_multi_stroke_samples_join_or_split_on_the_hysteresis():
    t = np.linspace(0, 300, 30)

    def two_strokes(gap_ms):
        x = np.r_[np.linspace(5, 40, 30), np.linspace(5, 40, 30)]
        y = np.r_[np.full(30, 10.0), np.full(30, 35.0)]
        return TraceSample('s', 'v', 'z', '0', x=x, y=y, t_ms=np.r_[t, t + 300 + gap_ms],
                           stroke=np.r_[np.zeros(30), np.ones(30)].astype(np.int32))

    settings = RenderSettings(mode='direct', placement='mm')
    (quick,) = render_sample(two_strokes(120), settings)  # ramps take 100 ms, a 20 ms lift
    assert quick.strokes == 2 and set(quick.stroke.tolist()) == {0, 1}
    assert len(render_sample(two_strokes(600), settings)) == 2


def test_leave_one_subject_out_counts_and_equations_8_9(rendered):
    results = leave_one_subject_out(rendered, {'trace': lambda: make_recogniser('trace'),
                                               'map': lambda: make_recogniser('map')})
    trace, blind = results['trace'], results['map']
    assert trace.samples == len(rendered) and sum(sum(r.values()) for r in trace.confusion.values()) == len(rendered)
    assert trace.accuracy >= 0.85
    # line_right and line_left differ only in direction: the map-based method confuses them.
    assert blind.confusion['line_right'].get('line_left', 0) + blind.confusion['line_left'].get('line_right', 0) > 0
    stats = trace.gesture_stats()
    for gesture, st in stats.items():
        rates = np.array([trace.per_performer[s][gesture] for s in trace.per_performer])
        assert st['mu'] == pytest.approx(rates.mean())                      # eq. (9)
        assert st['sigma'] == pytest.approx(np.sqrt(np.mean((rates - rates.mean()) ** 2)))  # eq. (8), 1/N
    assert trace.us_per_recognition > 0


def test_equation_8_9_on_known_rates():
    r = RecogniserResult('x', per_performer={'a': {'g': 1.0}, 'b': {'g': 0.5}, 'c': {'g': 0.0}})
    st = r.gesture_stats()['g']
    assert st['mu'] == pytest.approx(0.5) and st['sigma'] == pytest.approx(np.sqrt(1 / 6))


def test_codebook_choice_spreads_over_people_and_is_bounded(rendered):
    book = choose_codebook(rendered, 2, np.random.default_rng(0))
    assert len(book) == 2 * len(SHAPES)
    for label in SHAPES:
        assert len({r.subject for r in book if r.label == label}) == 2  # two different people
    assert len(choose_codebook(rendered, 50, np.random.default_rng(0))) == len(rendered)


def test_segmentation_failures_count_as_wrong(rendered):
    broken = [RenderedSample(r.subject, r.variant, r.label, r.sample, r.gestures * 2 if i % 3 == 0 else r.gestures)
              for i, r in enumerate(rendered)]
    res = leave_one_subject_out(broken, {'trace': lambda: make_recogniser('trace')})['trace']
    assert res.segmentation_failures == sum(1 for i in range(len(rendered)) if i % 3 == 0)
    assert res.accuracy <= 1 - res.segmentation_failures / res.samples


def test_cache_round_trip(tmp_path, small_set):
    settings = RenderSettings(mode='sensor', placement='mm', seed=3)
    first = render_samples(small_set[:3], settings, tmp_path)
    assert len(list(tmp_path.glob('sensor-*.npz'))) == 1
    again = render_samples(small_set[:3], settings, tmp_path)
    for a, b in zip(first, again, strict=True):
        assert (a.subject, a.label) == (b.subject, b.label)
        np.testing.assert_array_equal(a.gestures[0].trajectory, b.gestures[0].trajectory)
        np.testing.assert_array_equal(a.gestures[0].binary_map, b.gestures[0].binary_map)
        assert a.gestures[0].frames == b.gestures[0].frames


def test_cli_json_on_a_pixel_trace_file(tmp_path, capsys, small_set):
    # Screen-pixel coordinates, y downward, as in the $1 logs: the stimulus fits the box onto the skin.
    pixels = [TraceSample(s.subject, s.variant, s.gesture, s.sample, x=s.x * 7.0, y=s.y * 7.0 + 100, t_ms=s.t_ms,
                          stroke=s.stroke) for s in small_set]
    path = tmp_path / 'traces.csv.gz'
    write_traces(path, pixels)
    code = social_touch(['eval', 'skin', '--traces', str(path), '--json', '--recognisers', 'centroid,trace',
                         '--no-cache', '--random-touches', '6', '--templates-per-gesture', '2'])
    out = capsys.readouterr()
    assert code == 0 and '[eval skin]' in out.err
    report = json.loads(out.out)
    assert set(report['recognisers']) == {'centroid', 'trace'} and report['best'] in report['recognisers']
    for r in report['recognisers'].values():
        assert 0 <= r['accuracy'] <= 1 and r['us_per_recognition'] > 0 and r['random_touches'] == 6 * 3
    assert report['samples'] == len(small_set) and report['multi_stroke_samples'] == 0


def test_cli_errors_are_clear(tmp_path, capsys):
    assert social_touch(['eval', 'skin', '--traces', str(tmp_path / 'missing.csv')]) == 2
    assert 'file not found' in capsys.readouterr().err
    path = tmp_path / 't.csv'
    path.write_text('subject,variant,gesture,sample,stroke,x,y,t_ms\n1,a,b,0,0,0,0,0\n')
    assert social_touch(['eval', 'skin', '--traces', str(path), '--recognisers', 'centriod']) == 2
    assert "did you mean 'centroid'" in capsys.readouterr().err


def test_bench_smoke():
    result = bench_recognition(['centroid', 'trace', 'cloud'], n_gestures=3, templates_per_gesture=2, queries=3,
                               repeats=1)
    assert set(result['recognisers']) == {'centroid', 'trace', 'cloud'} and result['data'] == 'synthetic gestures'
    assert result['recognisers']['trace']['templates'] == 6
    # The steps of a recognition and the rest of predict; the cloud's raster bounds (part of its search) besides.
    assert set(result['recognisers']['trace']['steps_cpu_us']) == {*STEPS, 'other'}
    assert set(result['recognisers']['cloud']['steps_cpu_us']) == {*STEPS, 'other', 'raster'}
    assert all(np.isfinite(v) for v in result['recognisers']['cloud']['steps_cpu_us'].values())


def test_the_bench_times_the_multistroke_default_with_every_template_in_its_six_stroke_orders():
    result = bench_recognition([MULTISTROKE_DEFAULT], n_gestures=3, templates_per_gesture=2, queries=3, repeats=1)
    assert result['recognisers'][MULTISTROKE_DEFAULT]['templates'] == 6
    assert result['fused_3_strokes']['templates'] == 6 * 6 and result['fused_3_strokes']['us_per_recognition'] > 0
    g = synthetic_codebook(1, 1)[0][0]
    cut = in_strokes(g, 3)
    assert cut.strokes == 3 and sorted(set(cut.stroke.tolist())) == [0, 1, 2]
    np.testing.assert_array_equal(cut.trajectory, g.trajectory)
    lifts = np.diff(cut.times)[np.diff(cut.stroke) != 0] - np.diff(g.times)[np.diff(cut.stroke) != 0]
    np.testing.assert_allclose(lifts, LIFT_S, rtol=0, atol=1e-12)   # float64 times under 10 s


@pytest.mark.parametrize('name', ['cloud', 'trace', 'centroid', 'refereed', 'auto'])
def test_the_bench_steps_answer_as_predict(name):
    """predict_steps runs predict's steps in its order: the same answer for the touches it accepts, those it
    turns away and an unusable one."""
    gestures, labels = synthetic_codebook(4, 6)
    model = make_recogniser(name).fit(gestures, labels)
    probe, _ = synthetic_codebook(4, 3, seed=1)
    rng = np.random.default_rng(0)
    scribbles = [TouchGesture.from_trajectory(rng.uniform(5, 40, (60, 2))) for _ in range(8)]
    empty = TouchGesture(np.zeros((12, 12), bool), np.zeros((12, 12)), np.zeros((0, 2)), np.zeros(0))
    for gesture in [*probe, *scribbles, empty]:
        match, ns = predict_steps(model, gesture)
        assert match == model.predict(gesture) and set(ns) == set(STEPS) and min(ns.values()) >= 0


def test_logged_times_say_what_a_replay_of_one_point_per_time_would_lose():
    from touch_lab.skin.logged_times import ink_lost_one_point_per_time, logged_times
    # A bar whose first three points the logger stamped at one time: a replay of the last one keeps no ink of them.
    bar = TraceSample('1', 'a', 'line', '0', np.array([0.0, 10, 20, 20]), np.zeros(4), np.array([0.0, 0, 0, 16]),
                      np.zeros(4, dtype=int))
    assert ink_lost_one_point_per_time(bar) == 1.0
    clean = TraceSample('1', 'a', 'line', '1', np.array([0.0, 10, 20]), np.zeros(3), np.array([0.0, 15, 31]),
                        np.zeros(3, dtype=int))
    dab = TraceSample('1', 'a', 'dot', '2', np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, dtype=int))
    assert ink_lost_one_point_per_time(clean) == 0.0 and ink_lost_one_point_per_time(dab) == 0.0
    times = logged_times([bar, clean, dab])
    assert times['tick_ms'] == 15.75   # the median of 16 (bar) and 15.5 (clean); the dab has no tick
    assert times['points_sharing_a_time'] == pytest.approx(5 / 9)
    assert times['ink_lost_one_point_per_time']['p50'] == 0.0
    assert math.isnan(logged_times([dab])['tick_ms'])
    with pytest.raises(ValueError, match='at least one sample'):
        logged_times([])
