"""Early candidates (PrefixMatcher) and collisions (CollisionDetector, the synthetic evaluation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from touch_gestures.skin.collisions import CollisionDetector
from touch_gestures.skin.early import PrefixMatcher, stable_fraction
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.collision_eval import evaluate_collisions, make_contact
from touch_lab.skin.early_eval import prefix
from touch_lab.skin.recognisers import make_recogniser

RATE = 150.0


def line(start, end, n=60):
    pts = np.linspace(start, end, n)
    return TouchGesture.from_trajectory(pts, np.arange(n) / RATE)


def lines_codebook():
    shapes = {'right': ((6, 23), (41, 23)), 'left': ((41, 23), (6, 23)), 'down': ((23, 6), (23, 41)),
              'corner': ((6, 6), (41, 6))}
    gestures, labels = [], []
    for name, (a, b) in shapes.items():
        for k in range(4):
            off = np.array([0.0, 2.0 * k])
            if name == 'corner':   # right, then down: an L whose first half is a line right
                pts = np.r_[np.linspace((6, 6), (41, 6), 40), np.linspace((41, 6), (41, 41), 40)[1:]] + off
                g = TouchGesture.from_trajectory(pts, np.arange(len(pts)) / RATE)
            else:
                g = line(np.add(a, off), np.add(b, off))
            gestures.append(g)
            labels.append(name)
    return gestures, labels


@pytest.mark.parametrize('name', ['trace', 'cloud', 'auto'])
def test_the_candidate_of_a_prefix_settles_on_the_gesture(name):
    gestures, labels = lines_codebook()
    rec = make_recogniser(name).fit(gestures, labels)
    matcher = PrefixMatcher(rec)
    whole = line((6, 24), (41, 24))
    c = matcher.candidate(prefix(whole, 1.0))
    assert c.label == rec.predict(whole).nearest and 0 <= c.confidence <= 1 and c.progress == 1.0
    half = matcher.candidate(prefix(whole, 0.5))
    assert 0 < half.progress <= 1 and math.isfinite(half.distance)


@pytest.mark.parametrize('name', ['trace', 'cloud'])
def test_the_candidate_is_the_nearest_prefix_of_every_matchers_own_answer(name):
    # Features are computed once for all matchers: the answer must be each matcher's class_distances' best.
    gestures, labels = lines_codebook()
    matcher = PrefixMatcher(make_recogniser(name).fit(gestures, labels))
    for f in (0.3, 0.6, 1.0):
        c = matcher.candidate(prefix(line((6, 25), (41, 25)), f))
        per_matcher = [m.class_distances(prefix(line((6, 25), (41, 25)), f)) for m in matcher._matchers]
        k = int(np.argmin([d.min() for d in per_matcher]))
        assert c.distance == per_matcher[k].min() and c.progress == matcher.fractions[k]
        assert c.label == matcher._matchers[k].classes_[int(np.argmin(per_matcher[k]))]


def test_a_prefix_of_the_l_matches_the_ls_prefix_with_its_progress():
    gestures, labels = lines_codebook()
    matcher = PrefixMatcher(make_recogniser('trace').fit(gestures, labels))
    pts = np.r_[np.linspace((6, 7), (41, 7), 40), np.linspace((41, 7), (41, 42), 40)[1:]]
    l_shape = TouchGesture.from_trajectory(pts, np.arange(len(pts)) / RATE)
    three_quarters = matcher.candidate(prefix(l_shape, 0.75))
    assert three_quarters.label == 'corner' and three_quarters.progress == 0.75


def test_one_point_and_an_unordered_recogniser():
    gestures, labels = lines_codebook()
    matcher = PrefixMatcher(make_recogniser('cloud').fit(gestures, labels))
    c = matcher.candidate(TouchGesture.from_trajectory(np.array([[20.0, 20.0]])))
    assert c.label is not None and 0 <= c.confidence <= 1
    assert matcher.candidate(TouchGesture.from_trajectory(np.zeros((0, 2)))).label is None
    with pytest.raises(ValueError, match='ordered points'):
        PrefixMatcher(make_recogniser('map').fit(gestures, labels))
    with pytest.raises(ValueError, match='fractions'):
        PrefixMatcher(make_recogniser('trace').fit(gestures, labels), fractions=(0.0, 1.0))


def test_stable_fraction_edges():
    assert stable_fraction([], 'a') is None
    assert stable_fraction(['a'], 'a') == 1.0
    assert stable_fraction(['a', 'a', 'a', 'a'], 'a') == 0.25


def forces(fz):
    f = np.zeros((36, 3))
    f[10, 2] = fz
    return f


def test_a_collision_fires_once_per_contact_from_the_crossing_frame():
    det = CollisionDetector(force_n=5.0, rate_n_s=1000.0)
    out = [det.update(True, (10.0, 10.0), forces(fz), k / RATE) for k, fz in enumerate([1, 2, 3, 4, 5, 6, 7])]
    assert [s.collision for s in out] == [None, None, None, None, 'force', None, None]
    assert out[4].frames == 4 and det.in_collision and det.collisions == 1
    end = det.update(False, None, forces(0), 7 / RATE)
    assert end.end and not det.in_collision and end.force_n[2] == 7.0   # the last contact's force
    assert det.update(False, None, forces(0), 8 / RATE) is None
    again = det.update(True, (10.0, 10.0), forces(6), 9 / RATE)
    assert again.start and again.collision == 'force' and det.collisions == 2


def test_rate_nan_forces_and_bad_parameters():
    det = CollisionDetector(force_n=math.inf, rate_n_s=100.0, rate_frames=3)
    slow = [det.update(True, None, forces(0.1 * k), k / RATE) for k in range(1, 30)]   # 15 N/s
    assert all(s.collision is None for s in slow) and all(math.isnan(s.x_m) for s in slow)
    assert slow[-1].force_rate_n_s == pytest.approx(15.0, rel=1e-6)
    bad = forces(np.nan)
    assert det.update(True, None, bad, 1.0).force_n[2] == 0.0       # NaN counts as 0
    for kwargs in ({'force_n': 0.0}, {'rate_n_s': float('nan')}, {'rate_frames': 0}, {'frame_rate_hz': 0.0}):
        with pytest.raises(ValueError):
            CollisionDetector(**kwargs)


def test_the_rate_counts_frames_not_stamps():
    """Frames read in one poll carry nearly equal stamps: the rate must not explode."""
    det = CollisionDetector(force_n=math.inf, rate_n_s=120.0)
    states = [det.update(True, None, forces(0.2 * k), 1.0 + 1e-6 * k) for k in range(1, 6)]
    assert all(s.collision is None for s in states) and states[-1].force_rate_n_s == pytest.approx(30.0)


def test_bumps_presses_and_traces_through_the_virtual_skin():
    r = evaluate_collisions(per_kind=3, seed=1)
    c = r['confusion']
    assert c['bump']['collision'] == 3 and c['bump']['gesture'] == 0
    assert c['press']['collision'] == 0 and c['trace']['collision'] == 0 and c['trace']['gesture'] == 3
    assert r['bump_latency_frames']['max'] <= 3
    with pytest.raises(ValueError, match='unknown contact kind'):
        make_contact('slap', np.random.default_rng(0))


def test_the_early_summary_says_the_figures():
    from touch_lab.skin.early_eval import summary
    text = summary({'gestures': 8, 'final_right': 0.875, 'right_by_half': 0.5,
                    'stable_fraction': {'p50': 0.4, 'p75': 0.6, 'p90': 0.8}})
    assert '8 gestures' in text and '87.50 %' in text and 'median 0.40' in text and '90th 0.80' in text
    assert 'median' not in summary({'gestures': 1, 'final_right': 0.0, 'right_by_half': 0.0, 'stable_fraction': {}})
