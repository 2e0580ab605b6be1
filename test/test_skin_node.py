"""The haptic_commands node fed SkinFrame messages: commands, stamps, bad frames, parameters.

Frames are synthetic: perfect pressure maps (``ideal_frame``) under a finger moving along a
path, published on /skin/frame in a simulated-time graph. The driver + node graph on the
virtual skin is test/test_skin_node_graph.py.
"""

from pathlib import Path

import numpy as np
import pytest
from skin_testing import command_node_parameters

from touch_gestures.skin.codebook import load_codebook, save_codebook
from touch_gestures.skin.commands import load_command_map
from touch_gestures.skin.gesture import TouchGesture, ideal_frame
from touch_gestures.skin.node import HapticCommandsNode, default_codebook_path, default_commands_path
from touch_graph.errors import ParameterError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.skin.recognisers import make_recogniser

SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')
NS = 1_000_000_000
T0_NS = 1_700_000_000 * NS
PERIOD_NS = round(NS / 150)
EMPTY = np.zeros(144, np.float32)


def path(start, end, seconds):
    """(n, 2) finger positions, mm, at 150 Hz from ``start`` to ``end`` in ``seconds``."""
    n = round(seconds * 150) + 1
    return np.linspace(start, end, n)


class Harness:
    """A HapticCommandsNode in a simulated-time graph, fed SkinFrames, collecting /touch/haptic_command."""

    def __init__(self, **params):
        self.ctx = Context('sim')
        self.ctx.init()
        self.node = HapticCommandsNode(context=self.ctx, namespace='skin',
                                       parameter_overrides=[Parameter(k, value=v) for k, v in params.items()],
                                       cli_args=['--ros-args', '--log-level', 'error'])
        self.io = Node('test_io', context=self.ctx)
        self.pub = self.io.create_publisher(SkinFrame, '/skin/frame', 10)
        self.commands = []
        self.io.create_subscription(HapticCommand, '/touch/haptic_command', self.commands.append, 100)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.executor.add_node(self.io)
        self.i = 0

    def frame(self, point=None, stamp_ns=None, pressure=None, fz_n=None):
        """Publish one frame: a finger at ``point`` (mm) or an untouched skin; returns its stamp."""
        stamp_ns = T0_NS + self.i * PERIOD_NS if stamp_ns is None else stamp_ns
        sec, nanosec = divmod(stamp_ns, NS)
        touched = point is not None
        msg = SkinFrame(header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id='skin_link'),
                        sequence=self.i & 0xFFFF, contact=touched,
                        pressure=ideal_frame(point).reshape(-1) if touched else EMPTY,
                        contact_x=float(point[0]) if touched else float('nan'),
                        contact_y=float(point[1]) if touched else float('nan'))
        if pressure is not None:
            msg._f_pressure = pressure   # its slot, past the property that would refuse it: a malformed frame
        if fz_n is not None:          # a normal force on module 14 (near the centre), N
            force = np.zeros(108, np.float32)
            force[14 * 3 + 2] = fz_n
            msg.force = force
        self.pub.publish(msg)
        for _ in range(3):
            self.executor.spin_once(0)
        self.i += 1
        return stamp_ns

    def touch(self, points, lift_s=0.3):
        """A touch along ``points`` then an untouched skin for ``lift_s``; returns the last contact's stamp."""
        last = None
        for p in points:
            last = self.frame(p)
        for _ in range(round(lift_s * 150)):
            self.frame()
        return last

    def close(self):
        self.node.destroy_node()
        self.io.destroy_node()
        self.ctx.shutdown()


@pytest.fixture
def harness():
    made = []

    def make(**params):
        h = Harness(**params)
        made.append(h)
        return h
    yield make
    for h in made:
        h.close()


def test_a_traced_line_becomes_its_command_stamped_at_the_lift(harness):
    h = harness()
    for _ in range(30):
        h.frame()
    end = h.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    (cmd,) = h.commands
    assert (cmd.gesture, cmd.command, cmd.recogniser) == ('line_right', 'move_right', 'trace')
    assert cmd.header.stamp.sec * NS + cmd.header.stamp.nanosec == end and cmd.header.frame_id == 'skin'
    assert cmd.frames == 121 and cmd.duration_s == pytest.approx(120 * PERIOD_NS / NS, abs=1e-6)
    match = h.node.last_match
    assert cmd.distance == pytest.approx(match.distance) and cmd.margin == pytest.approx(match.margin)
    assert 0 < cmd.distance < h.node.recogniser.class_thresholds_[list(h.node.recogniser.classes_).index(
        'line_right')]
    h.touch(path([20.0, 5.0], [22.0, 42.0], 0.6))            # top to bottom: line_down -> stop
    h.touch(path([41.0, 41.0], [6.0, 6.0], 0.7))             # bottom-right to upper-left: diagonal_up
    assert [c.command for c in h.commands] == ['move_right', 'stop', 'previous_task']
    assert h.node.outcomes == {'published': 3} and h.node.callback_errors == 0


def test_presses_and_tiny_touches_fire_nothing_and_are_counted(harness):
    h = harness()
    h.touch([np.array([20.0, 20.0])] * 200)                   # a finger resting still for 1.3 s
    h.touch(path([20.0, 20.0], [23.0, 21.0], 0.3))            # a brush of 3 mm
    h.touch([np.array([30.0, 10.0])] * 2)                     # a tap of 2 frames: below min_frames
    assert h.commands == []
    assert h.node.outcomes == {'too_small': 2} and h.node.stream.segmenter.stats.too_short == 1


def test_a_touch_that_never_ends_is_cut_and_does_not_block_the_next(harness):
    h = harness(max_duration_s=1.0)
    h.touch(list(path([10.0, 10.0], [40.0, 30.0], 0.5)) + [np.array([40.0, 30.0])] * 300)  # then rests 2 s
    assert h.node.outcomes == {'truncated': 1} and h.commands == []
    h.touch(path([41.0, 23.0], [6.0, 23.0], 0.8))
    assert [c.command for c in h.commands] == ['move_left']


def test_bad_frames_are_counted_and_skipped(harness):
    h = harness()
    nan = np.full(144, np.nan, np.float32)
    for p in path([6.0, 23.0], [20.0, 23.0], 0.3):
        h.frame(p)
    h.frame(pressure=nan)                 # NaN in the middle of a trace: skipped, the trace goes on
    h.frame(pressure=np.zeros(100, np.float32))
    for p in path([20.0, 23.0], [41.0, 23.0], 0.4):
        h.frame(p)
    for _ in range(40):
        h.frame()
    assert dict(h.node.stream.skipped) == {'non_finite': 1, 'wrong_size': 1}
    assert [c.command for c in h.commands] == ['move_right'] and h.node.callback_errors == 0


def test_time_going_back_drops_the_touch_under_way_and_starts_afresh(harness):
    h = harness()
    for p in path([6.0, 23.0], [30.0, 23.0], 0.4):
        h.frame(p)
    h.i = 0                                # a looped bag: stamps start again
    h.touch(path([6.0, 6.0], [41.0, 41.0], 0.7))
    assert h.node.stream.restarts == 1 and not h.node.stream.skipped
    assert [c.command for c in h.commands] == ['next_task']


def test_a_gap_in_the_frames_drops_the_touch_under_way(harness):
    h = harness(max_gap_s=0.2)
    for p in path([6.0, 23.0], [20.0, 23.0], 0.3):
        h.frame(p)
    h.i += 150                             # the driver stalled for a second mid-trace
    h.touch(path([20.0, 5.0], [22.0, 42.0], 0.6))
    assert h.node.stream.interrupted == 1 and [c.command for c in h.commands] == ['stop']


def test_rejected_and_unmapped_gestures_publish_nothing(harness, tmp_path):
    strict = harness(max_distance=0.0)
    strict.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    assert strict.commands == [] and strict.node.outcomes == {'rejected_distance': 1}
    commands = tmp_path / 'commands.yaml'
    commands.write_text('format_version: 1\ncommands:\n  line_left: move_left\n')
    few = harness(commands=str(commands))
    few.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    assert few.commands == [] and few.node.outcomes == {'unmapped': 1}


def float32_distance_disagreement(model) -> np.ndarray:
    """(n_classes,) the most two correct float32 evaluations of a trace distance within a class may differ.

    ``TraceRecogniser`` computes d = sqrt(max(|t|^2 - 2 t.q + |q|^2, 0) / n) in float32. For a dot
    product of length m, |fl(x.y) - x.y| <= gamma_m |x||y| with gamma_m = m u / (1 - m u), u = 2^-24
    (Higham, Accuracy and Stability of Numerical Algorithms, eq. 3.5), whatever order the BLAS sums
    in; the two additions add at most 2u of their operands. So each evaluation of d2 is within
    e = (gamma_m + 2u) (|t| + |q|)^2 <= (gamma_m + 2u) 4 R^2 of the exact value (R the largest
    template norm) and two evaluations within 2e of each other. Through the square root that is at
    most 2e / (n d) (|sqrt a - sqrt b| = |a - b| / (sqrt a + sqrt b)), and never more than
    sqrt(2e / n); largest for the smallest distance d between two templates of the class. A
    rejection threshold is auto_scale times a quantile of per-template minima of such distances;
    minimum and (interpolated) quantile move no more than the largest move of their inputs.
    """
    templates = model.templates_.astype(np.float64)
    u = 2.0 ** -24
    m = templates.shape[1]
    gamma = m * u / (1 - m * u)
    radius = np.linalg.norm(templates, axis=1).max()
    two_e = 2 * (gamma + 2 * u) * 4 * radius ** 2
    n = model.n_points
    out = np.empty(len(model.classes_))
    for c in range(len(model.classes_)):
        own = templates[model.template_labels_ == c]
        pair = np.sqrt(((own[:, None, :] - own[None, :, :]) ** 2).sum(-1) / n)
        smallest = pair[~np.eye(len(own), dtype=bool)].min()
        out[c] = min(two_e / (n * smallest), np.sqrt(two_e / n)) if smallest > 0 else np.sqrt(two_e / n)
    return out


def test_rejection_parameters_default_to_the_codebook_and_recompute_its_thresholds(harness):
    h = harness()
    stored = load_codebook(default_codebook_path())
    assert h.node.get_parameter('max_distance').value == -1.0          # 'auto' in the file
    assert h.node.get_parameter('auto_scale').value == stored.auto_scale
    np.testing.assert_array_equal(h.node.recogniser.class_thresholds_, stored.class_thresholds_)
    wider = harness(auto_scale=2 * stored.auto_scale)
    # The thresholds were computed on another machine, whose BLAS may sum the float32 dot products in
    # another order: equal only within float32 rounding, bounded below (not a tuned tolerance).
    tolerance = 2 * stored.auto_scale * float32_distance_disagreement(stored)
    disagreement = np.abs(wider.node.recogniser.class_thresholds_ - 2 * stored.class_thresholds_)
    assert (disagreement <= tolerance).all(), (disagreement, tolerance)
    for off in (float('inf'), 1e6):   # no rejection at all: refused, naming the bound
        with pytest.raises(ParameterError, match=r'max_distance out of range Min: -1.0, Max: 0\.\d+, value'):
            harness(max_distance=off)


def test_the_shipped_codebook_knows_every_command_and_says_it_is_synthetic():
    model = load_codebook(default_codebook_path())
    commands = load_command_map(default_commands_path(), gestures=model.classes_)
    assert set(commands.commands) <= set(model.classes_)
    assert model.name == 'trace' and model.description_.startswith('SYNTHETIC')
    assert np.bincount(model.template_labels_).tolist() == [30] * len(model.classes_)
    assert default_codebook_path().stat().st_size < 100_000


def small_codebook(tmp_path, recogniser='trace'):
    lines = [TouchGesture.from_trajectory(path([6.0, y], [41.0, y], 0.5)) for y in (10.0, 20.0, 30.0)]
    model = make_recogniser(recogniser).fit(lines, ['line_right'] * 3)
    return save_codebook(tmp_path / f'{recogniser}.npz', model)


@pytest.mark.parametrize('params, fragments', [
    ({'codebook': 'nowhere.npz'}, ["parameter 'codebook' of /skin/haptic_commands", 'not found',
                                   'relative paths start at']),
    ({'recogniser': 'centroid'}, ["made for recogniser 'trace', not 'centroid'"]),
    ({'max_duration_s': -1.0}, ['segmentation parameters of /skin/haptic_commands', 'max_duration_s must be > 0']),
    ({'max_distance': -0.5}, ["parameter 'max_distance'", '-1 (per-class, from the codebook)']),
    ({'max_distance': -2.0}, ['Parameter max_distance out of range Min: -1.0']),
    ({'auto_quantile': 1.5}, ["parameter 'auto_quantile' of /skin/haptic_commands must be in [0.5, 1.0]"]),
    ({'min_margin': 0.0}, ['Parameter min_margin out of range Min: 0.02, Max: 2.0, value: 0.0']),
    ({'min_extent_mm': -1.0}, ["parameter 'min_extent_mm' of /skin/haptic_commands must be in [0.0, 47.0]"]),
    ({'collision_force_n': float('inf')}, ['Parameter collision_force_n out of range']),
    ({'max_gap_s': 0.0}, ['max_gap_s must be a positive number']),
])
def test_parameter_errors_say_what_and_how(params, fragments):
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError) as info:
            HapticCommandsNode(context=ctx, namespace='skin', parameter_overrides=[
                Parameter(k, value=v) for k, v in params.items()], cli_args=['--ros-args', '--log-level', 'error'])
        for fragment in fragments:
            assert fragment in str(info.value)
    finally:
        ctx.shutdown()


def test_a_mapped_gesture_missing_from_the_codebook_stops_the_node_at_its_line(tmp_path):
    codebook = small_codebook(tmp_path)
    commands = tmp_path / 'commands.yaml'
    commands.write_text('format_version: 1\ncommands:\n  line_right: move_right\n  line_lefft: move_left\n')
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError) as info:
            HapticCommandsNode(context=ctx, parameter_overrides=[Parameter('codebook', value=str(codebook)),
                                                                 Parameter('commands', value=str(commands))])
        text = str(info.value)
        assert f'{commands}:4' in text and "gesture 'line_lefft' is not in the codebook" in text
        assert 'the codebook' in text and 'knows line_right' in text
    finally:
        ctx.shutdown()


def test_an_unusable_default_codebook_says_how_it_is_made(monkeypatch, tmp_path):
    import touch_gestures.skin.node as node_module
    broken = tmp_path / 'skin_codebook.npz'
    broken.write_bytes(b'not a zip')
    monkeypatch.setattr(node_module, 'default_codebook_path', lambda: Path(broken))
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError, match='social-touch codebook record --simulate 10 --seed 2026'):
            HapticCommandsNode(context=ctx)
    finally:
        ctx.shutdown()


def test_the_segmenter_takes_the_vocabularys_gap_from_the_codebook_unless_set(tmp_path):
    lines = [TouchGesture.from_trajectory(path([6.0, y], [41.0, y], 0.5)) for y in (10.0, 20.0, 30.0)]
    model = make_recogniser('trace').fit(lines, ['line_right'] * 3)
    given = command_node_parameters(tmp_path, model, {'line_right': 'move_right'}, vocabulary='symbols', gap_s=1.5)
    ctx = Context('sim')
    ctx.init()
    try:
        node = HapticCommandsNode(context=ctx, parameter_overrides=given)
        assert node.stream.segmenter.gap_s == 1.5 and node.get_parameter('gap_s').value == 1.5
        node.destroy_node()
        node = HapticCommandsNode(context=ctx, parameter_overrides=[*given, Parameter('gap_s', value=0.4)])
        assert node.stream.segmenter.gap_s == 0.4
        node.destroy_node()
    finally:
        ctx.shutdown()


def test_candidates_come_while_the_finger_moves_and_settle_on_the_gesture(harness):
    SkinCandidate = get_message('social_touch_msgs/msg/SkinCandidate')
    h = harness(candidate_period_s=0.1)
    got = []
    h.io.create_subscription(SkinCandidate, '/skin/candidate', got.append, 100)
    for _ in range(30):
        h.frame()
    h.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    assert 6 <= len(got) <= 9 and h.node.candidates_published == len(got)  # every 0.1 s of 0.8 s traced
    assert all(0 <= c.confidence <= 1 and 0 < c.progress <= 1 and c.strokes == 1 for c in got)
    assert [c.elapsed_s for c in got] == sorted(c.elapsed_s for c in got)
    assert got[-1].gesture == 'line_right' == h.commands[0].gesture
    assert all(c.header.frame_id == 'skin_link' for c in got)   # the frame's own header
    quiet = harness(candidate_period_s=0.0)
    quiet.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    assert quiet.node.candidates_published == 0 and quiet.commands[0].gesture == 'line_right'


def test_a_bump_is_a_collision_from_the_frame_that_crosses_and_never_a_gesture(harness):
    SkinContact = get_message('social_touch_msgs/msg/SkinContact')
    SkinCollision = get_message('social_touch_msgs/msg/SkinCollision')
    h = harness(collision_force_n=6.0, collision_rate_n_s=120.0)
    contacts, collisions = [], []
    h.io.create_subscription(SkinContact, '/skin/contact', contacts.append, 500)
    h.io.create_subscription(SkinCollision, '/skin/collision', collisions.append, 50)
    for _ in range(30):
        h.frame()
    # A finger traced at 1.5 N, landing over 50 ms: contacts, no collision, its command.
    line = path([6.0, 23.0], [41.0, 23.0], 0.8)
    ramp = np.minimum(np.arange(len(line)) / 7.5, 1.0) * 1.5
    for p, fz in zip(line, ramp, strict=True):
        h.frame(p, fz_n=float(fz))
    for _ in range(45):
        h.frame()
    assert collisions == [] and [c.command for c in h.commands] == ['move_right']
    assert contacts[0].start and contacts[-1].end and sum(c.start for c in contacts) == 1
    assert contacts[5].x_m == pytest.approx(line[5][0] / 1000, abs=2e-3) and contacts[-2].fz_n == pytest.approx(1.5)
    # A bump along the same path: 8 N within two frames. Collision on the frame that crosses the rate.
    first = len(contacts)
    for k, p in enumerate(line[:40]):
        h.frame(p, fz_n=[3.0, 8.0][min(k, 1)])
    for _ in range(45):
        h.frame()
    (hit,) = collisions
    assert hit.frames_since_start == 0 and 'rate' in hit.reason and hit.fz_n == pytest.approx(3.0)
    assert contacts[first].start and contacts[first].force_rate_n_s >= 120.0
    assert [c.command for c in h.commands] == ['move_right']          # the bump gave no command
    assert h.node.outcomes['collision'] == 1 and h.node.collisions.collisions == 1


def test_a_failing_recogniser_reports_error_on_diagnostics_and_the_node_goes_on(harness, monkeypatch):
    h = harness()
    got = []
    mine = 'social_touch: /skin/haptic_commands'
    h.io.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                             lambda m: got.extend(s for s in m.status if s.name == mine), 100)

    def diverge(*args, **kwargs):                  # a stand-in for a run-time fault of the recogniser
        raise FloatingPointError('distance diverged')
    monkeypatch.setattr(h.node.stream, 'update', diverge)
    for _ in range(10):
        h.frame()
    h.executor.spin_for(5.5)                       # the health period (simulated time)
    assert h.node.health.errors == 10              # every frame failed; the node caught each and went on
    assert h.node.callback_errors == 0             # none reached the executor (that would end the spin)
    assert got and got[0].level == DiagnosticStatus.ERROR and 'FloatingPointError: distance diverged' in got[0].message
    monkeypatch.undo()
    h.executor.spin_for(5.5)                       # no new failure: back to OK
    assert len(got) == 2 and got[-1].level == DiagnosticStatus.OK


def test_what_became_of_the_gestures_is_on_diagnostics(harness):
    h = harness()
    got = []
    mine = 'social_touch: /skin/haptic_commands'
    h.io.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                             lambda m: got.extend(s for s in m.status if s.name == mine), 100)
    for _ in range(30):
        h.frame()
    h.touch(path([6.0, 23.0], [41.0, 23.0], 0.8))
    h.executor.spin_for(5.5)                       # the health period (simulated time)
    values = {kv.key: kv.value for kv in got[-1].values}
    assert got[-1].level == DiagnosticStatus.OK
    assert values['outcome_published'] == '1' and values['segmenter_gestures'] == '1'
    assert values['segmenter_ended_at_bound'] == '0' and values['callback_errors'] == '0'
