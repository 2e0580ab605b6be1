"""$N (touch_lab.skin.recognisers.ndollar): the expansion, its invariance, hard cases, estimator and codebook files.

Synthetic gestures only (strokes of corners in mm with a little tremor, as test_skin_multistroke's).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from test_skin_multistroke import SYMBOLS
from test_skin_multistroke import polyline as tremor_polyline

from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.recognisers import load_codebook, make_recogniser, save_codebook
from touch_lab.skin.recognisers.ndollar import NDollarRecogniser, expansion_orders, ink_features, unistroke_vectors

# Distances are angles between unit vectors of 2 * 96 float32 numbers: each dot product carries a
# relative error up to about 192 float32 roundings (192 x 6e-8 ~ 1.2e-5), and acos(1 - e) ~ sqrt(2 e):
# an exact match reads as at most ~5e-3 rad. Different symbols lie tenths of a radian apart.
EXACT_RAD = 5e-3


def polyline(corners, n, rng=None):
    """(n, 2) points along the corners; with ``rng``, a little hand tremor."""
    return tremor_polyline(corners, n, np.random.default_rng(0) if rng is None else rng, jitter=0.0 if rng is None
                           else 0.6)


def gesture(strokes):
    """A TouchGesture from a list of (m_i, 2) strokes, in that order."""
    g = TouchGesture.from_trajectory(np.concatenate(strokes))
    g.stroke = np.concatenate([np.full(len(s), k) for k, s in enumerate(strokes)]).astype(np.int16)
    g.strokes = len(strokes)
    return g


def symbol(name, rng, shuffle=True, points=40):
    strokes = [list(s) for s in SYMBOLS[name]]
    if shuffle:
        strokes = [s[::-1] if rng.random() < 0.5 else s for s in strokes]
        strokes = [strokes[i] for i in rng.permutation(len(strokes))]
    return gesture([polyline(s, int(points * rng.uniform(0.7, 1.4)), rng) for s in strokes])


def codebook(rng, per_class=4, shuffle=False):
    pairs = [(symbol(name, rng, shuffle), name) for name in SYMBOLS for _ in range(per_class)]
    return [g for g, _ in pairs], [y for _, y in pairs]


# ----------------------------------------------------------------------------- the expansion
@pytest.mark.parametrize('k', [1, 2, 3, 4])
def test_a_template_of_k_strokes_becomes_k_factorial_times_two_to_the_k_unistrokes(k):
    orders = expansion_orders(k, permuted_strokes=4)
    assert len(orders) == math.factorial(k) * 2 ** k == len(set(orders))
    # Every order of the strokes with every choice of directions, each stroke once.
    assert {tuple(s for s, _ in o) for o in orders} == set(itertools.permutations(range(k)))
    assert {tuple(r for _, r in o) for o in orders} == set(itertools.product([False, True], repeat=k))


def test_beyond_the_bound_the_recorded_order_keeps_a_bounded_set_of_directions():
    budget = math.factorial(3) * 2 ** 3     # 48: what a template of permuted_strokes = 3 strokes gets
    for k in (4, 5):                         # 2^k <= 48: the recorded order, every direction of each stroke
        orders = expansion_orders(k, 3)
        assert len(orders) == 2 ** k <= budget
        assert all(tuple(s for s, _ in o) == tuple(range(k)) for o in orders)
    many = expansion_orders(12, 3)          # 2^12 > 48: the recorded order and the whole trace backwards
    assert many == (tuple((s, False) for s in range(12)), tuple((s, True) for s in reversed(range(12))))
    assert len(expansion_orders(3, 3, reverse_strokes=False)) == 6


def test_each_unistroke_is_the_template_strokes_joined_in_its_order_and_directions():
    rec = NDollarRecogniser(permuted_strokes=3, start_angle_deg=None)
    strokes = [polyline(s, 20) for s in SYMBOLS['H']]
    rec.fit([gesture(strokes)], ['H'])
    assert len(rec._vectors) == 48 and (rec.unistroke_owner_ == 0).all()
    # Re-trace the H in every order and direction: each is one of the stored unistrokes, exactly.
    stored = rec._vectors.astype(np.float64)
    ids = np.repeat(np.arange(3), 20)
    for order in expansion_orders(3, 3):
        retraced = np.concatenate([strokes[s][::-1] if rev else strokes[s] for s, rev in order])
        vec, _, k = rec._expand(ink_features(retraced, ids, rec.ink_points), as_traced=True)
        assert k == 3
        assert np.abs(stored - vec[0]).max(axis=1).min() < 1e-5   # float32 storage of numbers <= 1


# ----------------------------------------------------------------------------- invariance
@settings(max_examples=40, deadline=None)
@given(order=st.permutations([0, 1]), flips=st.tuples(st.booleans(), st.booleans()))
def test_an_x_in_any_stroke_order_and_direction_is_at_distance_zero_from_its_template(order, flips):
    strokes = [polyline(s, 25) for s in SYMBOLS['X']]
    rec = NDollarRecogniser(max_distance=None).fit([gesture(strokes), gesture([polyline(s, 25) for s in
                                                                                SYMBOLS['plus']])], ['X', 'plus'])
    query = gesture([strokes[i][::-1] if flip else strokes[i] for i, flip in zip(order, flips, strict=True)])
    per_class = rec.class_distances(query)
    assert per_class[list(rec.classes_).index('X')] < EXACT_RAD
    assert per_class[list(rec.classes_).index('plus')] > 100 * EXACT_RAD
    assert rec.predict(query).label == 'X'


def test_symbols_are_read_whatever_the_order_from_templates_in_one_order():
    rng = np.random.default_rng(2)
    rec = NDollarRecogniser().fit(*codebook(rng, shuffle=False))
    tests = [(name, symbol(name, rng)) for name in SYMBOLS for _ in range(5)]
    assert sum(rec.predict(g).nearest == name for name, g in tests) == len(tests)


def test_without_reversed_strokes_a_line_keeps_its_direction():
    right, left = polyline([(5, 20), (40, 20)], 30), polyline([(40, 20), (5, 20)], 30)
    blind = NDollarRecogniser(max_distance=None).fit([gesture([right]), gesture([left])], ['right', 'left'])
    aware = clone(blind).set_params(reverse_strokes=False).fit([gesture([right]), gesture([left])],
                                                               ['right', 'left'])
    assert not blind.direction_aware and aware.direction_aware
    assert blind.class_distances(gesture([right])).max() < EXACT_RAD      # both classes hold both ways
    assert aware.predict(gesture([right])).label == 'right' and aware.predict(gesture([left])).label == 'left'


def test_rotation_is_bounded_on_the_skin_frame():
    """A line turned by 30 degrees matches within a 45-degree range, not with rotation off; 90 degrees never."""
    line = polyline([(5, 20), (40, 20)], 30)

    def turned(deg):
        a = math.radians(deg)
        return gesture([(line - 22.5) @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])
                        + 22.5])

    for rotation, deg, near in ((45, 30, True), (0, 30, False), (45, 90, False), (180, 90, True)):
        rec = NDollarRecogniser(max_rotation_deg=rotation, start_angle_deg=None).fit([gesture([line])], ['line'])
        assert bool(rec.class_distances(turned(deg))[0] < EXACT_RAD) == near, (rotation, deg)


def test_start_angle_pruning_and_same_strokes_only_leave_templates_out():
    rng = np.random.default_rng(5)
    train, labels = codebook(rng, per_class=3, shuffle=True)
    # No rotation: within 45 degrees a plus is an X turned (the pruning is what is tested here).
    pruned = NDollarRecogniser(max_distance=None, max_rotation_deg=0, same_strokes=False).fit(train, labels)
    full = clone(pruned).set_params(start_angle_deg=None).fit(train, labels)
    counted = clone(pruned).set_params(same_strokes=True).fit(train, labels)
    limit = math.radians(pruned.start_angle_deg)
    for name in SYMBOLS:
        q = symbol(name, rng)
        features = pruned.features(q)
        d_full = full.distances(features)
        d_pruned = pruned.distances(features)
        # By brute force: the unistrokes that start within 30 degrees of the query (across +-pi too).
        vec, angles, _ = pruned._expand(features, as_traced=True)
        turn = np.abs(np.angle(np.exp(1j * (pruned._angles - angles[0]))))
        d_each = full.distances(features)   # per template with all compared: the lower bound
        expected = np.full(len(d_full), np.inf)
        queries = np.stack([vec[0], _perp(vec[0])]).astype(np.float32)
        unistroke_d = np.arccos(np.clip(pruned._similarities(slice(0, len(turn)), queries), -1, 1))
        near = turn <= limit
        np.minimum.at(expected, pruned.unistroke_owner_[near], unistroke_d[near])
        np.testing.assert_allclose(d_pruned, expected, atol=1e-12)
        assert np.isfinite(d_pruned).any() and (d_pruned >= d_each - 1e-12).all()
        assert pruned.predict(q).nearest == full.predict(q).nearest == name
        d_counted = counted.distances(features)
        assert np.isinf(d_counted[counted._template_counts != q.strokes]).all()
        assert counted.predict(q).nearest == name


@pytest.mark.parametrize('params', [{}, {'start_angle_deg': None}, {'same_strokes': True}, {'start_angle_deg': 0.5},
                                    {'start_angle_deg': 0.5, 'same_strokes': True}, {'max_rotation_deg': 45}])
def test_the_distances_among_some_classes_are_those_of_the_whole_search(params):
    # What the referee asks (two classes) is the whole search's answer for them, bit for bit where the
    # same rows are compared: the start-angle window, the stroke counts and the fall-back to comparing all
    # when pruning leaves nothing in the whole codebook (a 0.5 degree window usually does) are the same.
    rng = np.random.default_rng(11)
    train, labels = codebook(rng, per_class=3, shuffle=True)
    rec = NDollarRecogniser(max_distance=None, **params).fit(train, labels)
    n = len(rec.classes_)
    queries = [symbol(name, rng) for name in SYMBOLS]
    queries.append(gesture([polyline([(5, 5), (30, 30)], 20, rng)] * 7))   # a stroke count no class has
    fell_back = 0
    for q in queries:
        whole = rec.class_distances(q)
        _, angle, k = rec._query(rec.features(q))
        fell_back += not rec._compares_any(rec._windows(angle), k)
        for pair in [(0, 1), (n - 1, 0), (2, 2), tuple(np.argsort(whole)[:2])]:
            np.testing.assert_allclose(rec.class_distances_among(q, pair), whole[list(pair)], rtol=0, atol=1e-12)
    assert rec.class_distances_among(TouchGesture.from_trajectory(np.empty((0, 2))), (0, 1)) is None
    if params.get('same_strokes'):
        assert fell_back   # the seven strokes: nothing of that count anywhere


def _perp(q):
    out = np.empty_like(q)
    out[0::2], out[1::2] = q[1::2], -q[0::2]
    return out


# ----------------------------------------------------------------------------- hard cases
def test_a_gesture_of_one_point_is_finite_and_unusable_only_when_empty():
    rng = np.random.default_rng(6)
    rec = NDollarRecogniser().fit(*codebook(rng))
    dot = gesture([np.array([[20.0, 20.0]])])
    m = rec.predict(dot)
    assert np.isfinite(m.distance) and m.distance <= math.pi
    assert rec.predict(TouchGesture.from_trajectory(np.empty((0, 2)))).rejected == 'unusable'
    # A one-point template in the codebook does not break the fit or the others.
    train, labels = codebook(rng, per_class=2)
    rec = NDollarRecogniser().fit([*train, dot], [*labels, 'dot'])
    assert np.isfinite(rec._vectors).all() and rec.predict(symbol('H', rng)).nearest == 'H'


def test_one_template_per_class_and_a_trace_ten_times_longer():
    rng = np.random.default_rng(4)
    rec = NDollarRecogniser().fit(*codebook(rng, per_class=1))
    assert np.isfinite(rec.class_thresholds_).all()
    for name in SYMBOLS:
        assert rec.predict(symbol(name, rng, points=400)).nearest == name   # 10x the templates' points


def test_a_template_of_many_strokes_beyond_the_bound_stays_bounded():
    rng = np.random.default_rng(7)
    dashes = [polyline([(5 + 3 * i, 10), (6 + 3 * i, 30)], 8, rng) for i in range(12)]   # 12 strokes
    train, labels = codebook(rng, per_class=2)
    rec = NDollarRecogniser(permuted_strokes=3).fit([*train, gesture(dashes)], [*labels, 'comb'])
    comb = rec.class_starts_[list(rec.classes_).index('comb')]   # the comb's one template
    assert (rec.unistroke_owner_ == comb).sum() == 2
    backwards = gesture([d[::-1] for d in dashes[::-1]])   # the whole trace backwards: the second unistroke
    assert rec.class_distances(backwards)[list(rec.classes_).index('comb')] < EXACT_RAD
    # More strokes than ink points: no usable feature vector, a clear rejection.
    assert NDollarRecogniser(ink_points=8).fit(train, labels).predict(gesture(dashes)).rejected == 'unusable'


def test_bad_parameters_are_refused():
    rng = np.random.default_rng(8)
    train, labels = codebook(rng, per_class=1)
    for bad in ({'permuted_strokes': 7}, {'max_rotation_deg': 200}, {'start_angle_deg': -1}, {'n_points': 4},
                {'one_d_ratio': 2}):
        with pytest.raises(ValueError):
            NDollarRecogniser(**bad).fit(train, labels)


# ----------------------------------------------------------------------------- estimator and files
def test_sklearn_clone_and_get_params():
    rec = make_recogniser('ndollar', permuted_strokes=2, same_strokes=True)
    copy = clone(rec)
    assert copy.get_params() == rec.get_params() and copy is not rec
    assert set(rec.get_params()) >= {'n_points', 'permuted_strokes', 'reverse_strokes', 'max_rotation_deg',
                                     'start_angle_deg', 'same_strokes', 'max_distance', 'min_margin'}


def test_a_saved_codebook_loads_expanded_and_answers_the_same(tmp_path):
    rng = np.random.default_rng(9)
    rec = NDollarRecogniser(permuted_strokes=2).fit(*codebook(rng, per_class=3))
    path = save_codebook(tmp_path / 'symbols', rec, vocabulary='symbols')
    back = load_codebook(path, recogniser='ndollar')
    assert type(back) is NDollarRecogniser and back.get_params() == rec.get_params()
    assert back.max_strokes_ == 3 and back.vocabulary_ == 'symbols'
    np.testing.assert_array_equal(back._vectors, rec._vectors)
    np.testing.assert_array_equal(back.unistroke_owner_, rec.unistroke_owner_)
    for name in SYMBOLS:
        q = symbol(name, rng)
        assert back.predict(q) == rec.predict(q)


def test_unit_vectors_and_start_angles_are_finite_for_degenerate_paths():
    paths = np.stack([np.zeros((10, 2)), np.column_stack([np.arange(10.0), np.zeros(10)])])
    vec, angles = unistroke_vectors(paths, 96, 0.25)
    assert np.isfinite(vec).all() and np.isnan(angles[0]) and angles[1] == pytest.approx(0.0)
    assert np.linalg.norm(vec[1]) == pytest.approx(1.0)


@pytest.mark.parametrize('bound_deg', [0.0, 30.0, 45.0, 90.0, 135.0, 180.0])
def test_the_closed_form_is_the_best_rotation_within_the_bound(bound_deg):
    """Against a brute-force search over 20,001 angles: the maximum over the grid lies within
    (grid step)^2 / 8 ~ 1e-9 of the true one, float32 inputs are summed in float32 (~1e-7 relative)."""
    rng = np.random.default_rng(10)
    rec = NDollarRecogniser(max_rotation_deg=bound_deg)
    rec._vectors = rng.normal(size=(400, 8)).astype(np.float32)
    queries = rng.normal(size=(2, 8)).astype(np.float32)
    a = (rec._vectors @ queries[0]).astype(np.float64)
    b = (rec._vectors @ queries[1]).astype(np.float64)
    t = np.linspace(-math.radians(bound_deg), math.radians(bound_deg), 20_001)
    brute = (a[:, None] * np.cos(t) + b[:, None] * np.sin(t)).max(axis=1)
    np.testing.assert_allclose(rec._similarities(slice(0, 400), queries), brute, atol=1e-6)
