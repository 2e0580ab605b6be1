"""Window features of the textile patch (sympartner2018 6.2): incremental, batch and from scratch agree."""

import itertools
import math

import numpy as np
import pytest
from doctest_testing import check_doctests
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_gestures.patch import features as features_module
from touch_gestures.patch.features import FEATURE_NAMES, WindowFeatures, basic_features, window_features
from touch_lab.patch.evaluate import onset_ages

K = 0.08


def naive_window_features(frames: np.ndarray, window: int, k: float = K) -> np.ndarray:
    """The twelve features recomputed from scratch for every window, plain loops (the reference)."""
    frames = np.where(np.isfinite(frames), frames, 0.0).astype(np.float64)
    out = []
    for t in range(len(frames)):
        win = frames[max(0, t - window + 1):t + 1]
        f1 = [f.max() for f in win]
        f2 = [f.sum() for f in win]
        f3 = [(f > k + 1e-6).sum() for f in win]
        centres = []
        for f in win:
            act = f > k + 1e-6
            if act.any():
                w = np.where(act, f, 0.0)
                r, c = np.indices(f.shape)
                centres.append(((r * w).sum() / w.sum(), (c * w).sum() / w.sum()))
            else:
                centres.append(None)
        path = sum(math.dist(a, b) for a, b in itertools.pairwise(centres)
                   if a is not None and b is not None)
        valid = np.array([c for c in centres if c is not None])
        spread = float(valid[:, 0].var() + valid[:, 1].var()) if len(valid) > 1 else 0.0
        row = []
        for q in (f1, f2, f3):
            row += [max(q), float(np.mean(q)), float(np.var(q))]
        out.append([*row, len(valid), path, spread])
    return np.array(out)


def random_frames(rng: np.random.Generator, n: int, grid=(6, 5), p_touch=0.5) -> np.ndarray:
    frames = np.full((n, *grid), K, dtype=np.float32)
    for t in range(n):
        if rng.random() < p_touch:
            r, c = rng.integers(0, grid[0]), rng.integers(0, grid[1])
            frames[t, max(r - 1, 0):r + 2, max(c - 1, 0):c + 2] = rng.uniform(K, 1.0)
    return frames


frame_stacks = st.integers(1, 40).flatmap(lambda n: arrays(
    np.float32, (n, 4, 3),
    elements=st.one_of(st.just(np.float32(K)), st.floats(0.0, 1.0, width=32), st.just(np.float32(0.0)))))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(frames=frame_stacks, window=st.integers(1, 12))
def test_incremental_and_batch_equal_from_scratch(frames, window):
    expected = naive_window_features(frames, window)
    wf = WindowFeatures(window, grid=(4, 3), recompute_every=7)
    incremental = np.array([wf.update(f) for f in frames])
    batch = window_features(frames, window, chunk=5)
    np.testing.assert_allclose(incremental, expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(batch, expected, rtol=1e-9, atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(level=st.floats(0.0, 1.0), n=st.integers(1, 80))
def test_constant_frames_have_zero_variance_never_negative(level, n):
    frames = np.full((n, 16, 16), level, dtype=np.float32)
    wf = WindowFeatures(60)
    for f in frames:
        x = wf.update(f)
        assert np.all(np.isfinite(x))
        assert x[2] == 0.0 and x[5] == 0.0 and x[8] == 0.0 and x[11] == 0.0


def test_all_zero_and_idle_windows():
    wf = WindowFeatures(60)
    for f in (np.zeros((16, 16)), np.full((16, 16), K, np.float32)):
        x = wf.update(f)
        assert x[FEATURE_NAMES.index('active_frames')] == 0
        assert x[FEATURE_NAMES.index('centre_path')] == 0
        assert x[FEATURE_NAMES.index('centre_var')] == 0
    assert wf.onset_age is None
    out = window_features(np.zeros((5, 16, 16)), 60)
    assert out.shape == (5, 12) and np.all(np.isfinite(out))


def test_float32_floor_is_not_active():
    # float32(0.1) rounds above the float64 0.1: the floor itself must never count as contact
    frame = np.full((4, 4), np.float32(0.1))
    assert float(np.float32(0.1)) > 0.1
    x = WindowFeatures(5, k=0.1, grid=(4, 4)).update(frame)
    assert x[FEATURE_NAMES.index('active_cells_max')] == 0


def test_nan_cells_are_inactive_and_counted():
    frame = np.full((16, 16), K, np.float32)
    frame[3, 4] = 0.9
    frame[0, 0] = np.nan
    frame[1, 1] = np.inf
    wf = WindowFeatures(60)
    x = wf.update(frame)
    assert np.all(np.isfinite(x))
    assert wf.nonfinite_cells == 2
    assert x[FEATURE_NAMES.index('active_cells_max')] == 1
    basic, bad = basic_features(frame[None])
    assert bad.tolist() == [2] and basic[0, 3:].tolist() == [3.0, 4.0]
    np.testing.assert_allclose(window_features(frame[None], 60), x[None])


def test_centre_is_active_weighted_and_undefined_without_contact():
    frame = np.full((16, 16), K, np.float32)
    frame[2, 2], frame[2, 6] = 1.0, 0.5
    basic, _ = basic_features(np.stack([frame, np.full((16, 16), K, np.float32)]))
    assert basic[0, 3] == pytest.approx(2.0)
    assert basic[0, 4] == pytest.approx((2 * 1.0 + 6 * 0.5) / 1.5)
    assert np.isnan(basic[1, 3:]).all()


def test_path_counts_moves_but_not_jumps_across_lifts():
    def touch(r, c):
        f = np.full((8, 8), K, np.float32)
        f[r, c] = 1.0
        return f
    idle = np.full((8, 8), K, np.float32)
    wf = WindowFeatures(10, grid=(8, 8))
    for f in (touch(1, 1), touch(1, 4), idle, touch(5, 4)):  # moved 3, lifted, landed elsewhere
        x = wf.update(f)
    assert x[FEATURE_NAMES.index('centre_path')] == pytest.approx(3.0)
    assert x[FEATURE_NAMES.index('active_frames')] == 3


def test_window_slides_and_forgets():
    hit = np.full((16, 16), K, np.float32)
    hit[5, 5] = 1.0
    wf = WindowFeatures(3)
    wf.update(hit)
    for _ in range(3):
        x = wf.update(np.full((16, 16), K, np.float32))
    assert x[FEATURE_NAMES.index('max_activation_max')] == pytest.approx(K, abs=1e-7)
    assert x[FEATURE_NAMES.index('active_frames')] == 0
    assert wf.filled == 3


def test_long_run_stays_exact_and_bounded():
    rng = np.random.default_rng(3)
    frames = random_frames(rng, 3000, grid=(16, 16), p_touch=0.3)
    frames[:, 0, 0] += 50.0  # a large, nearly constant f2 invites cancellation
    wf = WindowFeatures(60)
    for f in frames:
        x = wf.update(f)
    expected = naive_window_features(frames[-60:], 60)[-1]
    np.testing.assert_allclose(x, expected, rtol=1e-9, atol=1e-9)
    assert len(wf._ring_q) == 60 and len(wf._active_t) <= 60 and all(len(d) <= 60 for d in wf._maxq)


def test_onset_age_matches_batch():
    rng = np.random.default_rng(5)
    frames = random_frames(rng, 200, grid=(16, 16), p_touch=0.1)
    wf = WindowFeatures(20)
    ages = []
    for f in frames:
        wf.update(f)
        ages.append(-1 if wf.onset_age is None else wf.onset_age)
    assert ages == onset_ages(frames, 20).tolist()


def test_bad_input_gives_clear_errors():
    with pytest.raises(ValueError, match='window'):
        WindowFeatures(0)
    with pytest.raises(ValueError, match='grid'):
        WindowFeatures(60, grid=(0, 16))
    with pytest.raises(ValueError, match='256'):
        WindowFeatures(60).update(np.zeros((8, 8)))
    with pytest.raises(ValueError, match='T, R, C'):
        window_features(np.zeros((16, 16)), 60)
    assert WindowFeatures(60).update(np.zeros(256)).shape == (12,)  # flat message arrays are fine


def test_reset_starts_a_new_window():
    hit = np.full((16, 16), K, np.float32)
    hit[1, 1] = 1.0
    wf = WindowFeatures(60)
    wf.update(hit)
    wf.reset()
    x = wf.update(np.full((16, 16), K, np.float32))
    assert x[FEATURE_NAMES.index('active_frames')] == 0 and wf.frames == 2


def test_doctests():
    check_doctests(features_module)
