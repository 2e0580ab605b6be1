"""The patch_gestures node: parameters, the model file, bad frames, and events equal to the offline recogniser.

Frames are simulated (SYNTHETIC): rendered by the patch_driver node on a virtual patch and published on
/patch/frame in a simulated-time graph.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from touch_driver.patch.calibration import load_outline
from touch_gestures.patch.classifier import EventDetector
from touch_gestures.patch.model_io import PatchModel, load_model, save_model
from touch_gestures.patch.node import PatchGesturesNode, default_model_path
from touch_graph.errors import ParameterError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.patch.training import PatchGestureClassifier
from touch_sim.patch.people import make_people, simulate_session
from touch_sim.patch.render import render_scene

PatchFrame = get_message('social_touch_msgs/msg/PatchFrame')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
GesturePosteriors = get_message('social_touch_msgs/msg/GesturePosteriors')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
NS = 1_000_000_000
T0_NS = 1_700_000_000 * NS
IDLE = np.full(256, 0.08, dtype=np.float32)


class Harness:
    """A PatchGesturesNode in a simulated-time graph, fed PatchFrames, collecting /touch/gesture."""

    def __init__(self, **params):
        self.ctx = Context('sim')
        self.ctx.init()
        self.node = PatchGesturesNode(context=self.ctx, namespace='patch',
                                      parameter_overrides=[Parameter(k, value=v) for k, v in params.items()],
                                      cli_args=['--ros-args', '--log-level', 'error'])
        io = Node('test_io', context=self.ctx)
        self.pub = io.create_publisher(PatchFrame, '/patch/frame', 10)
        self.events = []
        io.create_subscription(GestureEvent, '/touch/gesture', self.events.append, 100)
        self.posteriors = []
        io.create_subscription(GesturePosteriors, '/patch/posteriors', self.posteriors.append, 100)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.executor.add_node(io)
        self.io = io

    def update(self, activations, t0_ns=T0_NS, period_ns=NS // 20):
        for i, act in enumerate(activations):
            sec, nanosec = divmod(t0_ns + i * period_ns, NS)
            header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id='patch_link')
            self.pub.publish(PatchFrame(header=header, sequence=i & 0xFFFF,
                                        activation=np.asarray(act, np.float32).reshape(-1)))
            for _ in range(4):  # the node's callback, then the listeners'
                self.executor.spin_once(0)

    def close(self):
        self.node.destroy_node()
        self.io.destroy_node()
        self.ctx.shutdown()


@pytest.fixture(scope='module')
def session_frames():
    """A simulated person's slaps then a stroke session, through the patch_driver node (SYNTHETIC)."""
    person = make_people(3, seed=77)[2]
    slaps = simulate_session(person, 'slap', n_events=2, seed=5, lead_s=(2.0, 2.0), pause_s=(4.0, 4.5))
    strokes = simulate_session(person, 'stroke', n_events=2, seed=6, lead_s=(2.0, 2.0), pause_s=(4.0, 4.5))
    return (np.concatenate([render_scene(slaps, seed=1).activations,
                            render_scene(strokes, seed=2).activations]), slaps, strokes)


def small_model(tmp_path, name='m.npz', grid=(16, 16), window=60, **model_kwargs):
    rng = np.random.default_rng(0)
    X = np.concatenate([rng.normal(0, 1, (60, 12)), rng.normal(4, 1, (60, 12))])
    clf = PatchGestureClassifier(n_components=1).fit(X, ['push'] * 60 + ['stroke'] * 60)
    path = tmp_path / name
    save_model(path, PatchModel(clf, window=window, grid=grid, **model_kwargs))
    return path


def offline_events(model: PatchModel, activations, threshold=None, dwell=None):
    """What the recogniser does without the graph: features, direct posterior, event rule."""
    features, classifier = model.features(), model.classifier
    det = model.detector()
    if threshold is not None:
        det = EventDetector(model.classes, threshold=threshold, release=min(det.release, threshold),
                            rate_hz=model.rate_hz, dwell=dwell or det.dwell)
    out = []
    for act in activations:
        hit = det.update(classifier.log_posterior(features.update(act)), features.onset_age)
        if hit is not None:
            out.append((hit.frame, hit.gesture, hit.latency_s))
    return out


def test_events_are_the_offline_recognisers_with_the_frames_stamps(session_frames):
    frames, _slaps, _strokes = session_frames
    h = Harness()
    try:
        h.update(frames)
        node = h.node
        assert node.model_path == default_model_path()
        expected = offline_events(load_model(default_model_path()), frames)
        got = [((e.header.stamp.sec * NS + e.header.stamp.nanosec - T0_NS) // (NS // 20), e.gesture, e.latency_s)
               for e in h.events]
        assert [g[:2] for g in got] == [e[:2] for e in expected]
        np.testing.assert_allclose([g[2] for g in got], [e[2] for e in expected], atol=1e-6)  # 20 Hz stamps
        assert {e.gesture for e in h.events} >= {'slap', 'stroke'}
        e = h.events[0]
        assert e.header.frame_id == 'patch_link' and list(e.classes) == ['push', 'slap', 'stroke', 'tickle']
        assert sum(e.posteriors) == pytest.approx(1.0) and e.probability == max(e.posteriors) >= 0.99
        assert node.frames == len(frames) and node.events == len(h.events) and not node.skipped
        assert node.callback_errors == 0
    finally:
        h.close()


def test_every_frame_publishes_the_posteriors_the_events_come_from(session_frames):
    frames, _, _ = session_frames
    h = Harness()
    try:
        h.update(frames[:300])
        model = h.node.model
        features, classifier = model.features(), model.classifier
        expected = np.exp([classifier.log_posterior(features.update(a)) for a in frames[:300]])
        assert len(h.posteriors) == 300
        assert all(list(m.classes) == list(model.classes) for m in h.posteriors)
        got = np.array([m.posteriors for m in h.posteriors])
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-300)  # the same float64 computation
        np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-12)
        stamps = [m.header.stamp for m in h.posteriors]
        assert [(s.sec * NS + s.nanosec - T0_NS) // (NS // 20) for s in stamps] == list(range(300))
        assert h.events
        for event in h.events:  # an event carries the posteriors of its frame
            frame = next(m for m in h.posteriors if m.header.stamp == event.header.stamp)
            np.testing.assert_array_equal(event.posteriors, frame.posteriors)
    finally:
        h.close()


def test_latency_comes_from_the_stamps_not_the_nominal_rate(session_frames):
    frames, _, _ = session_frames
    h = Harness()
    try:
        h.update(frames[:400], period_ns=NS // 10)  # frames stamped at 10 Hz: the same frames, twice the time
        expected = offline_events(h.node.model, frames[:400])
        assert expected
        assert [e.latency_s for e in h.events] == pytest.approx([2 * x[2] for x in expected], abs=1e-6)
    finally:
        h.close()


def test_parameters_default_to_the_model_and_can_be_overridden(session_frames):
    h = Harness()
    try:
        model = h.node.model
        assert h.node.get_parameter('threshold').value == model.classifier.threshold
        assert h.node.get_parameter('dwell_s').value == pytest.approx(model.dwell / model.rate_hz)
        assert h.node.get_parameter('window').value == model.window
        assert h.node.detector.dwell == model.dwell
    finally:
        h.close()
    frames = session_frames[0]
    h = Harness(threshold=0.9, dwell_s=0.0, window=60)
    try:
        assert (h.node.detector.threshold, h.node.detector.dwell, h.node.detector.release) == (0.9, 1, 0.9)
        h.update(frames[:300])
        assert [(round((e.header.stamp.sec * NS + e.header.stamp.nanosec - T0_NS) / (NS / 20)), e.gesture)
                for e in h.events] == [x[:2] for x in offline_events(h.node.model, frames[:300], 0.9, 1)]
    finally:
        h.close()


def _node_from_params_file(tmp_path, ctx, params: dict):
    path = tmp_path / 'patch_gestures.yaml'
    body = ''.join(f'      {k}: {v}\n' for k, v in params.items())
    path.write_text(f'/patch/patch_gestures:\n  ros__parameters:\n{body}')
    return PatchGesturesNode(context=ctx, namespace='patch', cli_args=['--ros-args', '--params-file', str(path)])


def test_old_parameter_name_hold_s_still_works_with_a_warning(tmp_path, capfd):
    ctx = Context('sim')
    ctx.init()
    try:
        node = _node_from_params_file(tmp_path, ctx, {'hold_s': 0.25})
        assert node.detector.dwell == 5 and node.get_parameter('dwell_s').value == 0.25
        err = capfd.readouterr().err
        assert err.count("parameter 'hold_s' is deprecated: rename it 'dwell_s'") == 1
        node = _node_from_params_file(tmp_path, ctx, {'dwell_s': 0.25})
        assert node.detector.dwell == 5 and 'deprecated' not in capfd.readouterr().err
        node = _node_from_params_file(tmp_path, ctx, {'dwell_s': 0.1, 'hold_s': 0.25})
        assert node.detector.dwell == 2
        assert "parameter 'hold_s' is deprecated and ignored, since 'dwell_s' is given" in capfd.readouterr().err
    finally:
        ctx.shutdown()


def test_old_parameter_name_hold_s_is_checked_like_the_new_one(tmp_path):
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError, match="'dwell_s'"):
            _node_from_params_file(tmp_path, ctx, {'hold_s': -1.0})
    finally:
        ctx.shutdown()


@pytest.mark.parametrize('params, fragment', [
    ({'window': 40}, "'window' of /patch/patch_gestures is 40 frames, but"),
    ({'threshold': 1.5}, "'threshold' of /patch/patch_gestures must be in [0.5, 1.0]"),
    ({'threshold': 0.2}, 'Parameter threshold out of range Min: 0.5, Max: 1.0, value: 0.2'),
    ({'dwell_s': 60.0}, 'Parameter dwell_s out of range Min: 0.0, Max: 3.0'),
    ({'dwell_s': -1.0}, "'dwell_s'"),
    ({'release': 0.995}, "'release' of /patch/patch_gestures must be in [0, threshold = 0.99]"),
    ({'max_gap_s': 0.0}, "'max_gap_s'"),
])
def test_bad_parameters_are_one_clear_error(params, fragment):
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError) as info:
            PatchGesturesNode(context=ctx, namespace='patch', parameter_overrides=[
                Parameter(k, value=v) for k, v in params.items()])
        assert fragment in str(info.value)
    finally:
        ctx.shutdown()


def test_a_missing_or_incompatible_model_is_one_error_naming_the_file(tmp_path):
    (tmp_path / 'junk.npz').write_bytes(b'not a zip file')
    np.savez(tmp_path / 'other.npz', format=np.array('something_else'))
    cases = {str(tmp_path / 'nope.npz'): 'model file not found',
             str(tmp_path / 'junk.npz'): 'not a readable .npz model file',
             str(tmp_path / 'other.npz'): "expected a 'social_touch.patch_gmm' model file",
             str(small_model(tmp_path, grid=(8, 8))): 'trained on 8x8 maps; the sensor gives 16x16'}
    ctx = Context('sim')
    ctx.init()
    try:
        for path, fragment in cases.items():
            with pytest.raises(ParameterError) as info:
                PatchGesturesNode(context=ctx, parameter_overrides=[Parameter('model', value=path)])
            text = str(info.value)
            assert text.startswith("parameter 'model' of /patch_gestures: " + path) and fragment in text, text
    finally:
        ctx.shutdown()


def test_the_window_parameter_follows_another_model(tmp_path):
    path = small_model(tmp_path, window=40)
    h = Harness(model=str(path), window=40)
    try:
        assert h.node.features.window == 40 and h.node.get_parameter('max_gap_s').value == 2.0
    finally:
        h.close()


def test_nan_cells_are_read_as_no_contact_and_counted(session_frames):
    frames = session_frames[0][:300]
    clean = Harness()
    try:
        clean.update(frames)
    finally:
        clean.close()
    assert clean.events
    outside = np.flatnonzero(~load_outline().ravel())     # cells without fabric: never touched
    bad = frames.copy().reshape(len(frames), -1)
    bad[::7, outside[0]] = np.nan
    bad[::11, outside[-1]] = np.inf
    h = Harness()
    try:
        h.update(bad)
        assert h.node.nonfinite_cells == len(range(0, 300, 7)) + len(range(0, 300, 11))
        assert [e.gesture for e in h.events] == [e.gesture for e in clean.events]   # no reading = no contact
        touched = bad.copy()
        touched[:, 7 * 16 + 8] = np.nan                    # a cell in the middle of the touches reads nothing
        h.update(touched, t0_ns=T0_NS + 300 * NS // 20)
        h.update(np.full((40, 256), np.nan, np.float32), t0_ns=T0_NS + 600 * NS // 20)
        assert h.node.frames == 640 and h.node.callback_errors == 0 and not h.node.skipped
        assert all(np.isfinite(e.posteriors).all() for e in h.events)
    finally:
        h.close()


def test_frames_of_another_size_are_counted_and_skipped():
    h = Harness()
    try:
        header = Header(stamp=Time(sec=1_700_000_000, nanosec=0))
        for cells in (64, 0, 257):
            h.node._on_frame(SimpleNamespace(header=header, activation=np.full(cells, 0.5, np.float32)))
        assert h.node.skipped == {'wrong_size': 3} and h.node.frames == 0
        h.update([IDLE] * 5)
        assert h.node.frames == 5
    finally:
        h.close()


def test_time_going_back_or_a_gap_starts_a_new_window(session_frames):
    frames = session_frames[0]
    h = Harness()
    try:
        h.update(frames[:200])
        first = [e.gesture for e in h.events]
        assert first
        h.update(frames[:200])                           # the same stamps again: a looped bag
        assert h.node.resets == 1
        assert [e.gesture for e in h.events] == first * 2  # the loop gives the same events again
        h.update(frames[:200], t0_ns=T0_NS + 100 * NS)   # 90 s later: the old window is out of date
        assert h.node.resets == 2 and [e.gesture for e in h.events] == first * 3
        assert h.node.features.filled == 60
    finally:
        h.close()


def test_the_shipped_model_is_synthetic_small_and_documented():
    path = default_model_path()
    assert path.stat().st_size < 100_000
    model = load_model(path)
    assert model.synthetic and 'SYNTHETIC' in model.metadata['data']
    assert model.metadata['command'].startswith('social-touch train patch --simulate 8 --seed 2026')
    assert model.classes == ('push', 'slap', 'stroke', 'tickle') and model.window == 60 and model.grid == (16, 16)
    note = path.with_suffix('.md').read_text()
    assert 'SYNTHETIC' in note and 'social-touch train patch --simulate 8 --seed 2026 --components 3' in note


def test_a_missing_default_model_says_how_it_is_made(tmp_path, monkeypatch):
    import touch_gestures.patch.node as node_module
    monkeypatch.setattr(node_module, 'default_model_path', lambda: tmp_path / 'patch_gestures.npz')
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError) as info:
            PatchGesturesNode(context=ctx)
        assert 'model file not found' in str(info.value) and node_module.TRAIN_COMMAND in str(info.value)
    finally:
        ctx.shutdown()


CELL = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                 st.floats(0.0625, 1.0, width=32))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(frames=hnp.arrays(np.float32, st.tuples(st.integers(1, 80), st.just(256)), elements=CELL),
       steps=st.lists(st.integers(-NS, NS), min_size=1, max_size=80))
def test_any_frames_and_stamps_never_break_the_node(frames, steps):
    """Garbage activations (NaN, inf, negative, huge) and stamps jumping back and forth: counted, never a crash."""
    h = Harness()
    try:
        t = T0_NS
        for i, act in enumerate(frames):
            t = max(t + steps[i % len(steps)], 0)
            sec, nanosec = divmod(t, NS)
            h.node._on_frame(SimpleNamespace(header=Header(stamp=Time(sec=sec, nanosec=nanosec)), activation=act))
        # Frames stamped before the one in use are screened out (a stray publisher) until they form a run
        # of their own (a looped bag); every frame is either used or counted as screened.
        screened = sum(h.node.screen.screened.values())
        assert h.node.frames == h.node.screen.admitted and h.node.frames + screened == len(frames)
        nonfinite = int((~np.isfinite(frames)).sum())
        assert h.node.nonfinite_cells == nonfinite if not screened else h.node.nonfinite_cells <= nonfinite
        assert h.node.features.filled <= 60 and len(h.node._stamps) <= 60
        for _ in range(3 * len(frames)):
            h.executor.spin_once(0)
        for e in h.events:
            assert np.isfinite(e.posteriors).all() and 0 <= e.probability <= 1 and np.isfinite(e.latency_s)
    finally:
        h.close()
