"""Leave-one-subject-out evaluation of the patch gestures: matching rules, metrics, streaming = batch."""

import json

import numpy as np
import pytest
from doctest_testing import check_doctests

from touch_gestures.patch.classifier import NOT_RECOGNISED, Detection
from touch_gestures.patch.features import WindowFeatures, window_features
from touch_lab.patch import evaluate as evaluate_module
from touch_lab.patch.datasets import Session, render_session
from touch_lab.patch.evaluate import (
    Metrics,
    leave_one_subject_out,
    onset_ages,
    run_detector,
    score,
    segment_events,
)
from touch_lab.patch.training import PatchGestureClassifier
from touch_sim.patch.people import simulate_people

CLASSES = ('push', 'slap', 'stroke', 'tickle')


def det(cls, frame):
    i = CLASSES.index(cls)
    return Detection(cls, i, 0.999, np.eye(4)[i], frame, frame / 20.0, 0.0)


def test_matching_counts_as_documented():
    truth = [(1.0, 2.0), (10.0, 11.0), (20.0, 21.0)]
    detections = [
        det('stroke', 30),   # 1.5 s in event 0: correct, latency 0.5
        det('tickle', 36),   # 1.8 s in event 0: wrong class -> false detection
        det('stroke', 40),   # 2.0 s again correct: event counted once
        det('slap', 150),    # 7.5 s: in silence -> false detection
        det('tickle', 215),  # 10.75 s in event 1: wrong class only
        det('stroke', 465),  # 23.25 s: 2.25 s after event 2 ended, within late_s = 3 -> correct, latency 3.25
    ]
    decisions = np.full(500, NOT_RECOGNISED)
    m = score(detections, truth, 'stroke', decisions, CLASSES, 20.0, late_s=3.0)
    assert (m.n_events, m.event_correct, m.false_detections, m.false_in_silence, m.misses) == (3, 2, 3, 1, 0)
    assert m.latencies_s == pytest.approx([0.5, 3.25])
    assert m.event_confusion[CLASSES.index('stroke')].tolist() == [0, 0, 3, 2]
    d = m.as_dict()
    assert d['event_correct_rate'] == pytest.approx(2 / 3) and d['false_detection_rate'] == pytest.approx(1.0)
    assert d['median_detection_latency_s'] == pytest.approx(1.875)
    json.dumps(d)


def test_misses_and_per_sample_confusion():
    truth = [(1.0, 1.5), (5.0, 6.0)]
    decisions = np.full(200, NOT_RECOGNISED)
    decisions[20:25] = CLASSES.index('slap')      # inside event 0, right
    decisions[100:103] = CLASSES.index('push')    # inside event 1, wrong
    decisions[150:152] = CLASSES.index('slap')    # in silence
    m = score([det('slap', 22)], truth, 'slap', decisions, CLASSES, 20.0)
    assert (m.event_correct, m.misses, m.false_detections) == (1, 1, 0)
    sc = m.sample_confusion  # rows predicted (+ not recognised), columns truth (+ silence)
    slap, push, silence, nr = 1, 0, 4, 4
    assert sc[slap, slap] == 5 and sc[push, slap] == 3 and sc[slap, silence] == 2
    assert sc.sum() == 200 and sc[nr, slap] == (11 + 21) - 8
    d = m.as_dict()
    assert d['tpr_detected_samples'] == pytest.approx(5 / 8)
    assert d['tpr_all_samples'] == pytest.approx((5 + sc[nr, silence]) / 200)


def test_empty_metrics_are_nan_not_errors():
    d = Metrics(CLASSES).as_dict()
    assert np.isnan(d['event_correct_rate']) and np.isnan(d['median_detection_latency_s'])


def test_segment_events_merges_short_gaps_and_drops_short_blips():
    a = np.full((100, 4, 4), 0.08, np.float32)
    a[10:20, 1, 1] = 0.6
    a[25:30, 1, 1] = 0.6   # 5 frames later: same event at merge_gap 0.5 s
    a[60, 2, 2] = 0.5      # a one-frame blip
    a[70, 0, 0] = np.nan
    assert segment_events(a, 20.0, merge_gap_s=0.5) == [(0.5, 1.45), (3.0, 3.0)]
    assert segment_events(a, 20.0, merge_gap_s=0.1, min_duration_s=0.3) == [(0.5, 0.95)]
    assert segment_events(np.zeros((0, 4, 4)), 20.0) == []


def test_onset_ages_without_contact():
    assert onset_ages(np.zeros((5, 2, 2)), 3).tolist() == [-1] * 5


@pytest.fixture(scope='module')
def small_sessions():
    data = simulate_people(n_people=3, events_per_session=2, seed=5)
    return [render_session(scene, person.name, gesture, seed=i)
            for i, (person, gesture, scene) in enumerate(data)]


def test_streaming_equals_the_batch_evaluation_path(small_sessions):
    train, test = small_sessions[4:], small_sessions[:4]
    X = np.concatenate([window_features(s.activations, 60) for s in train])
    y = np.concatenate([[s.gesture] * s.n_frames for s in train])
    clf = PatchGestureClassifier(n_components=2).fit(X, y)
    classes = tuple(clf.classes_)
    for s in test:
        lp = clf.predict_log_proba(window_features(s.activations, 60))
        batch = run_detector(lp, onset_ages(s.activations, 60), classes, 0.99, 0.9, 20.0, dwell=3)
        wf = WindowFeatures(60)
        from touch_gestures.patch.classifier import EventDetector
        detector = EventDetector(classes, threshold=0.99, release=0.9, dwell=3)
        stream = []
        for frame in s.activations:
            hit = detector.update(clf.log_posterior(wf.update(frame)), wf.onset_age)
            if hit is not None:
                stream.append(hit)
        assert [(d.gesture, d.frame, d.latency_s) for d in stream] == [(d.gesture, d.frame, d.latency_s)
                                                                      for d in batch]


def test_leave_one_subject_out_reports_fig6(small_sessions):
    res = leave_one_subject_out(small_sessions, n_components=(1, 2), thresholds=(0.9, 0.99), dwells_s=(0.05, 0.4))
    d = res.as_dict()
    assert d['synthetic'] and d['subjects'] == ['p1', 'p2', 'p3'] and d['window_frames'] == 60
    assert len(d['grid']) == 8 and d['n_events'] == 24
    for key in ('event_correct', 'false_detections', 'misses', 'median_detection_latency_s', 'us_per_frame',
                'event_confusion', 'sample_confusion', 'tpr_all_samples', 'tpr_detected_samples'):
        assert key in d
    assert 0 <= d['event_correct'] <= d['n_events'] and d['us_per_frame'] > 0
    assert sum(sum(r.values()) for r in d['sample_confusion'].values()) == sum(s.n_frames for s in small_sessions)
    best = max(g['event_correct_rate'] - g['false_detection_rate'] for g in d['grid'])
    assert d['event_correct_rate'] - d['false_detection_rate'] == pytest.approx(best)


def test_leave_one_subject_out_refuses_what_it_cannot_do(small_sessions):
    one = [s for s in small_sessions if s.subject == 'p1']
    with pytest.raises(ValueError, match='two subjects'):
        leave_one_subject_out(one, measure_cost=False)
    mixed = [*small_sessions[:2], Session('p9', 'push', small_sessions[2].activations, 135.0)]
    with pytest.raises(ValueError, match='frame rates'):
        leave_one_subject_out(mixed, measure_cost=False)
    lonely = [s for s in small_sessions if s.gesture != 'slap' or s.subject == 'p1']
    with pytest.raises(ValueError, match='lack some of the classes'):
        leave_one_subject_out(lonely, measure_cost=False)


def test_doctests():
    check_doctests(evaluate_module)


def test_bench_frame_reports_its_figures():
    from touch_lab.patch.bench import bench_frame
    result = bench_frame(window=20, n_components=2, repeats=1, frames=200, sklearn_frames=20, train_people=2,
                         train_events=1)
    for key in ('us_per_frame', 'us_per_frame_contact', 'us_features', 'us_posterior', 'us_sklearn_score_samples',
                'speedup', 'goal_us'):
        assert result[key] > 0
    assert result['synthetic'] and result['frames'] == 200
