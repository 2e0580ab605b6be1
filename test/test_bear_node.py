"""The bear_gestures node on its own: frames in (written by the test, synthetic), messages out."""

from __future__ import annotations

import doctest
from pathlib import Path

import numpy as np
import pytest

import touch_gestures.bear.gate
import touch_gestures.bear.node as node_module
from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.features import FEATURE_NAMES
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.bear.symbolic import CANDIDATE, END, START, WITHDRAWN, SymbolicRecogniser
from touch_graph.errors import ParameterError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.bear.subtype_training import SubtypeClassifier

BearFrame = get_message('BearFrame')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
BODY = BodyMap.default()
FITTED = BODY.fitted_mask().tolist()  # bool[64]: Python bools, as rclpy needs
EPOCH_S = 1_700_000_000
RATE = 3.4


def ch(*names: str) -> list[int]:
    return [BODY.by_name(n).channel for n in names]


def frame(i: int, on: dict[int, float] | None = None, faults: dict[int, int] | None = None, rate: float = RATE):
    """Scan ``i`` at ``i / rate`` s after the epoch, levels ``on`` (channel -> level), the rest 0."""
    level = np.zeros(64, np.float32)
    for c, v in (on or {}).items():
        level[c] = v
    fault = np.zeros(64, np.uint8)
    for c, v in (faults or {}).items():
        fault[c] = v
        level[c] = 0.0                     # a calibrator reads faulty channels as 0
    ns = round(i / rate * 1e9)
    header = Header(stamp=Time(sec=EPOCH_S + ns // 10**9, nanosec=ns % 10**9), frame_id='bear_link')
    return BearFrame(header=header, sequence=i & 0xFFFF, level=level, active=(level >= 0.3).tolist(), fitted=FITTED,
                     faults=fault)


class Graph:
    """A simulated-time graph: a feeder publishing on /bear/frame, the node, a listener of /touch/*."""

    def __init__(self, **params):
        self.ctx = Context('sim')
        self.ctx.init()
        self.node = BearGesturesNode(context=self.ctx, namespace='bear',
                                     parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        self.feeder = Node('feeder', context=self.ctx)
        self.pub = self.feeder.create_publisher(BearFrame, '/bear/frame', 100)
        self.got = {'sensor_level': [], 'subtype': [], 'symbolic': []}
        for topic, kind in (('sensor_level', 'SensorLevel'), ('subtype', 'TouchSubtype'),
                            ('symbolic', 'SymbolicGesture')):
            self.feeder.create_subscription(get_message(kind), f'/touch/{topic}', self.got[topic].append, 1000)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.executor.add_node(self.feeder)

    def update(self, frames) -> None:
        for msg in frames:
            self.pub.publish(msg)
            self.executor.spin_for(0.0)      # deliver now: every ready callback runs

    def decided(self) -> list:
        """The decisions (START, END) of /touch/symbolic, what code that waits for them reads."""
        return [m for m in self.got['symbolic'] if m.state in (START, END)]

    def symbolic(self) -> list[tuple[str, int, float]]:
        """(gesture, state, stamp s since the epoch) of the decisions on /touch/symbolic."""
        return [(m.gesture, m.state, m.header.stamp.sec - EPOCH_S + m.header.stamp.nanosec * 1e-9)
                for m in self.decided()]

    def close(self) -> None:
        self.node.destroy_node()
        self.ctx.shutdown()


@pytest.fixture
def graph():
    made = []

    def make(**params):
        made.append(Graph(**params))
        return made[-1]
    yield make
    for g in made:
        g.close()


def test_head_hold_gives_sensor_level_every_cycle_subtypes_and_a_head_pat_start_and_end(graph) -> None:
    g = graph(subtype_classifier='rule')
    head2 = ch('head2')[0]
    touch = range(10, 27)                                        # 17 scans = 5 s of hold at 3.4 Hz
    g.update(frame(i, {head2: 0.9} if i in touch else None) for i in range(50))
    levels = g.got['sensor_level']
    assert len(levels) == 50 and g.node.frames == 50 and not g.node.skipped
    assert [s.name for s in levels[12].sensors] == ['head2'] and levels[12].sensors[0].level == pytest.approx(0.9)
    assert levels[12].sensors[0].region == 'head' and levels[5].sensors == [] and levels[40].sensors == []
    assert levels[12].header.stamp == frame(12).header.stamp and levels[12].header.frame_id == 'bear_link'

    subtypes = [(m.sensor, m.previous, m.subtype) for m in g.got['subtype']]
    # After the release the buffer still holds the touch (20 cycles): the rule reads the step as a pet.
    assert subtypes == [('head2', 'none', 'poke'), ('head2', 'poke', 'hold'), ('head2', 'hold', 'pet'),
                        ('head2', 'pet', 'none')]
    assert g.got['subtype'][-1].header.stamp == frame(46).header.stamp      # the touch has left the buffer
    hold = g.got['subtype'][1]
    assert hold.channel == head2 and hold.peak_amplitude == pytest.approx(0.9) and hold.confidence == 1.0
    assert hold.duration_s >= 3.0 and hold.base_frequency_hz == 0.0        # the rule's 3 s poke limit

    events = g.symbolic()
    assert [(name, state) for name, state, _ in events] == [('head_pat', START), ('head_pat', END)]
    candidate, start, end = g.got['symbolic']
    onset_s = start.onset.sec - EPOCH_S + start.onset.nanosec * 1e-9
    # The first word: on the first touched scan, with the shipped table's confidence; START confirms it.
    assert candidate.state == CANDIDATE and candidate.gesture == 'head_pat' and candidate.onset == start.onset
    assert candidate.header.stamp == frame(10).header.stamp and candidate.duration_s == 0.0
    assert 0.0 < candidate.confidence < 1.0 and start.confidence == 1.0 and end.confidence == 1.0
    assert onset_s == pytest.approx(10 / RATE, abs=1e-6)                   # the first touched scan
    assert events[0][2] == pytest.approx(17 / RATE, abs=1e-6)              # first scan >= 2 s of dwell later
    assert start.duration_s == pytest.approx(7 / RATE, abs=1e-5) and start.sensors == ['head2']
    assert end.onset == start.onset and events[1][2] > 26 / RATE           # released, after the gap
    assert end.duration_s == pytest.approx(events[1][2] - onset_s, abs=1e-5)


def test_the_shipped_model_classifies_and_startup_gives_no_false_subtypes(graph) -> None:
    g = graph()
    assert g.node.classifier_kind == 'model'
    g.update(frame(i) for i in range(25))                         # nobody touches the bear while its buffer fills
    assert g.got['subtype'] == [] and g.got['symbolic'] == [] and len(g.got['sensor_level']) == 25
    paw = ch('paw_left_palm')[0]
    g.update(frame(i, {paw: 1.0} if i < 40 else None) for i in range(25, 60))
    named = [(m.sensor, m.subtype) for m in g.got['subtype']]
    assert named and {s for s, _ in named} == {'paw_left_palm'} and named[-1] == ('paw_left_palm', 'none')
    assert all(0.0 < m.confidence <= 1.0 for m in g.got['subtype'])


def test_bad_frames_are_counted_and_skipped_and_the_node_goes_on(graph) -> None:
    g = graph(subtype_classifier='rule')
    nan = frame(1)
    nan.level[3] = np.nan
    short = frame(2)
    short._f_level = np.zeros(10, np.float32)                  # its slot, past the checking property: malformed
    no_faults = frame(3)
    no_faults._f_faults = np.zeros(0, np.uint8)
    g.update([frame(0), nan, short, no_faults, frame(0), frame(4)])
    assert g.node.skipped == {'non_finite': 1, 'wrong_size': 2, 'repeated_stamp': 1}
    assert g.node.frames == 2 and len(g.got['sensor_level']) == 2 and g.ctx.callback_errors == 0


def test_faulty_and_unfitted_channels_read_as_untouched(graph) -> None:
    g = graph(subtype_classifier='rule')
    head1, head2, head3 = ch('head1', 'head2', 'head3')
    frames = []
    for i in range(20):
        msg = frame(i, {head1: 1.0, head2: 1.0, head3: 1.0}, faults={head1: 4})
        msg.level[head1] = 1.0                                   # flagged saturated: excluded whatever it reads
        msg.fitted = msg.fitted.copy()
        msg.fitted[head3] = False                                 # the driver says nothing is fitted there
        frames.append(msg)
    g.update(frames)
    assert {s.name for m in g.got['sensor_level'] for s in m.sensors} == {'head2'}
    assert {m.sensor for m in g.got['subtype']} == {'head2'}
    assert all(m.sensors == ['head2'] for m in g.got['symbolic'])


def test_time_going_back_ends_what_is_under_way_and_starts_afresh(graph) -> None:
    g = graph(subtype_classifier='rule')
    hug = ch('chest_left', 'back_upper', 'side_left_upper', 'side_right_upper', 'back_middle')
    g.update(frame(i, dict.fromkeys(hug, 1.0)) for i in range(12))
    assert [(n, s) for n, s, _ in g.symbolic()] == [('hug', START)]
    before = len(g.got['subtype'])
    g.update([frame(3)])                                            # one stale frame: screened out, nothing ends
    assert [(n, s) for n, s, _ in g.symbolic()] == [('hug', START)] and g.node.screen.screened == {'stamp_back': 1}
    g.update([frame(4), frame(5)])                                  # a looped bag: time jumps back 2.6 s and goes on
    assert [(n, s) for n, s, _ in g.symbolic()] == [('hug', START), ('hug', END)]
    assert g.node.screen.source_changes == 1 and not g.node.screen.screened
    end = g.decided()[-1]
    assert end.header.stamp == frame(11).header.stamp and end.duration_s == pytest.approx(11 / RATE, abs=1e-5)
    released = g.got['subtype'][before:]
    assert {m.sensor for m in released} == {BODY.by_channel(c).name for c in hug}
    assert all(m.subtype == 'none' for m in released) and g.node.resets == 1


def test_frames_that_stop_end_gestures_after_max_gap(graph) -> None:
    g = graph(subtype_classifier='rule', max_gap_s=2.0)
    head2 = ch('head2')[0]
    g.update(frame(i, {head2: 1.0}) for i in range(12))
    assert [(n, s) for n, s, _ in g.symbolic()] == [('head_pat', START)]
    g.executor.spin_for(3.0)                                     # no frame for 3 s of graph time
    assert [(n, s) for n, s, _ in g.symbolic()] == [('head_pat', START), ('head_pat', END)]
    assert g.got['subtype'][-1].subtype == 'none' and g.node.resets == 1
    g.executor.spin_for(3.0)
    assert len(g.got['symbolic']) == 3 and g.node.resets == 1     # CANDIDATE, START, END: nothing left to end


def test_frames_that_stop_withdraw_a_candidate_out(graph) -> None:
    g = graph(subtype_classifier='rule', max_gap_s=2.0)
    g.update(frame(i, {ch('head2')[0]: 1.0}) for i in range(3))           # under the 2 s dwell
    g.executor.spin_for(3.0)
    assert [(m.gesture, m.state, m.confidence) for m in g.got['symbolic']] == [
        ('head_pat', CANDIDATE, g.got['symbolic'][0].confidence), ('head_pat', WITHDRAWN, 0.0)]
    assert g.got['symbolic'][1].onset == g.got['symbolic'][0].onset


def test_dwell_and_gap_parameters_override_the_files_defaults(graph) -> None:
    head2 = ch('head2')[0]
    quick = graph(subtype_classifier='rule', dwell_s=0.5)
    quick.update(frame(i, {head2: 1.0}) for i in range(12))
    assert quick.symbolic()[0][:2] == ('head_pat', START)
    assert quick.symbolic()[0][2] == pytest.approx(2 / RATE, abs=1e-6)   # 0.59 s >= 0.5 s after the onset


def test_symbolic_off_does_no_symbolic_work_and_both_off_computes_no_features(graph, monkeypatch) -> None:
    def refuse(*args, **kwargs):
        raise AssertionError('symbolic work done although publish_symbolic is false')
    monkeypatch.setattr(SymbolicRecogniser, 'update', refuse)
    head2 = ch('head2')[0]
    g = graph(subtype_classifier='rule', publish_symbolic=False)
    assert g.node.symbolic_pub is None and g.node.count_publishers('/touch/symbolic') == 0
    assert len(g.node.recogniser.symbolic.library) == 0
    g.update(frame(i, {head2: 1.0}) for i in range(12))
    assert g.got['subtype'] and g.ctx.callback_errors == 0

    levels_only = graph(publish_symbolic=False, publish_subtypes=False)
    assert levels_only.node.classifier_kind is None and levels_only.node.subtype_pub is None
    monkeypatch.setattr(levels_only.node.recogniser.extractor, 'update', refuse)
    levels_only.update(frame(i, {head2: 1.0}) for i in range(12))
    assert len(levels_only.got['sensor_level']) == 12 and levels_only.ctx.callback_errors == 0
    assert levels_only.got['sensor_level'][-1].sensors[0].name == 'head2'


def test_subtypes_off_still_classifies_for_gestures_that_need_a_subtype(graph, tmp_path: Path) -> None:
    gestures = tmp_path / 'g.yaml'
    gestures.write_text('format: 1\ngestures:\n  belly_tickle:\n    sensors: [belly_middle]\n    subtype: tickle\n')
    g = graph(publish_subtypes=False, gestures=str(gestures))
    assert g.node.subtype_pub is None and g.node.classifier_kind == 'model'
    plain = tmp_path / 'plain.yaml'
    plain.write_text('format: 1\ngestures:\n  head_pat:\n    sensors: [head1]\n')
    assert graph(publish_subtypes=False, gestures=str(plain)).node.classifier_kind is None


@pytest.mark.parametrize('name, value, expected', [
    ('rate_hz', 0.0, 'positive number of scans'),
    ('buffer_len', 1, 'integer >= 2'),
    ('threshold', 1.5, 'in (0, 1]'),
    ('detrend', 'cubic', "'constant' or 'linear'"),
    ('subtype_classifier', 'modle', "did you mean 'model'"),
    ('subtype_model', '/no/such/model.npz', 'no such file'),
    ('gestures', 'config/bear_gesturs.yaml', 'no such file'),
    ('max_gap_s', -1.0, 'positive number of seconds'),
    ('rule.tickle_cutoff', -3.0, 'finite number >= 0'),
    ('rate_hz', 'fast', 'must be a double'),
])
def test_bad_parameters_give_one_clear_error(name, value, expected) -> None:
    ctx = Context('sim')
    ctx.init()
    with pytest.raises(ParameterError) as err:
        BearGesturesNode(context=ctx, parameter_overrides=[Parameter(name, value=value)])
    assert f"'{name}'" in str(err.value) and expected in str(err.value)
    ctx.shutdown()


def _tiny_model(path: Path, rate_hz: float) -> None:
    rng = np.random.default_rng(0)
    X = rng.random((40, len(FEATURE_NAMES)), dtype=np.float32)
    SubtypeClassifier().fit(X, np.where(X[:, 0] < 0.5, 'none', 'hold')).save(path, rate_hz=rate_hz, buffer_len=20)


def test_a_model_for_another_rate_is_refused_when_given_and_replaced_by_the_rule_when_default(
        tmp_path: Path, monkeypatch, capfd) -> None:
    other = tmp_path / 'm25.npz'
    _tiny_model(other, 25.0)
    ctx = Context('sim')
    ctx.init()
    with pytest.raises(ParameterError, match=r'trained at 25\.0 Hz.*--rate 3\.4'):
        BearGesturesNode(context=ctx, parameter_overrides=[Parameter('subtype_model', value=str(other))])
    assert BearGesturesNode(context=ctx, parameter_overrides=[
        Parameter('subtype_model', value=str(other)), Parameter('rate_hz', value=25.0)]).classifier_kind == 'model'
    monkeypatch.setattr(node_module, 'default_model_path', lambda: other)
    assert BearGesturesNode(context=ctx).classifier_kind == 'rule'
    assert capfd.readouterr().err.count('using the paper rule') == 1
    monkeypatch.setattr(node_module, 'default_model_path', lambda: tmp_path / 'missing.npz')
    assert BearGesturesNode(context=ctx).classifier_kind == 'rule'
    assert capfd.readouterr().err.count('no trained subtype model') == 1
    ctx.shutdown()


def test_the_shipped_model_file_is_small_pickle_free_and_trained_at_the_real_rate() -> None:
    path = node_module.default_model_path()
    assert path.stat().st_size < 100_000
    with np.load(path, allow_pickle=False) as data:
        assert {'format', 'classes', 'coef', 'trained_at'} <= set(data.files)
    model = SubtypeClassifier.load(path)
    assert (model.trained_rate_hz_, model.trained_buffer_len_) == (3.4, 20) and len(model.classes_) == 9
    notes = path.with_suffix('.md').read_text()
    assert 'synthetic' in notes.lower() and 'social-touch train bear' in notes


def test_gate_doctest() -> None:
    result = doctest.testmod(touch_gestures.bear.gate)
    assert result.failed == 0 and result.attempted > 0


def test_frames_at_another_rate_than_rate_hz_give_one_warning(graph, capfd) -> None:
    g = graph(subtype_classifier='rule')
    g.update(frame(i, rate=25.0) for i in range(60))
    assert capfd.readouterr().err.count('frames arrive at 25.00 Hz but rate_hz is 3.4') == 1
    right = graph(subtype_classifier='rule', rate_hz=25.0)
    right.update(frame(i, rate=25.0) for i in range(60))
    assert 'frames arrive at' not in capfd.readouterr().err


def test_a_ros_parameter_file_sets_nested_rule_constants(tmp_path: Path) -> None:
    params = tmp_path / 'bear.yaml'
    params.write_text('/bear/bear_gestures:\n  ros__parameters:\n    subtype_classifier: rule\n    buffer_len: 30\n'
                      '    rule:\n      tickle_cutoff: 2.0\n      poke_max_s: 2\n')
    ctx = Context('sim')
    ctx.init()
    node = BearGesturesNode(context=ctx, namespace='bear', cli_args=['--ros-args', '--params-file', str(params)])
    rule = node.recogniser.classifier
    assert (rule.tickle_cutoff, rule.poke_max_s, rule.pet_cutoff) == (2.0, 2.0, 0.25)
    assert node.recogniser.buffer.buffer_len == 30 and node.classifier_kind == 'rule'
    ctx.shutdown()
