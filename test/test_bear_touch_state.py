"""touch_state: /touch/get_state and /touch/state from what the scene runs (synthetic frames and messages)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_bear_node import EPOCH_S, ch, frame

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.touch_state.node import TouchStateNode
from touch_gestures.touch_state.tracker import Running, TouchStateTracker
from touch_graph.compat import latched_qos, sensor_data_qos
from touch_graph.errors import ParameterError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_graph.srv_types import get_service

BODY = BodyMap.default()
BearFrame = get_message('BearFrame')
TouchState = get_message('TouchState')
GestureEvent = get_message('GestureEvent')
PanelContact = get_message('PanelContact')
SkinFrame = get_message('SkinFrame')
Point = get_message('geometry_msgs/msg/Point')
GetTouchState = get_service('social_touch_msgs/srv/GetTouchState')


class Scene:
    """bear_gestures + touch_state on a simulated clock; a feeder of bear frames, a client and a listener."""

    def __init__(self, with_bear: bool = True, **state_params) -> None:
        self.ctx = Context('sim')
        self.ctx.init()
        self.nodes = []
        if with_bear:
            self.nodes.append(BearGesturesNode(context=self.ctx, namespace='bear', parameter_overrides=[
                Parameter('subtype_classifier', value='rule')]))
        self.state_node = TouchStateNode(context=self.ctx, parameter_overrides=[
            Parameter(k, value=v) for k, v in state_params.items()])
        self.user = Node('user', context=self.ctx)
        self.frames = self.user.create_publisher(BearFrame, '/bear/frame', 100)
        self.client = self.user.create_client(GetTouchState, '/touch/get_state')
        self.states = []
        self.executor = SingleThreadedExecutor(context=self.ctx)
        for node in [*self.nodes, self.state_node, self.user]:
            self.executor.add_node(node)

    def feed(self, frames) -> None:
        for msg in frames:
            stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            self.executor.spin_until_time(max(stamp_ns, self.ctx.now_ns()))   # the graph's clock with the frames
            self.frames.publish(msg)
            self.executor.spin_for(0.0)

    def ask(self, region: str = '') -> object:
        future = self.client.call_async(GetTouchState.Request(region=region))
        self.executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert future.done()
        return future.result()

    def listen(self) -> list:
        self.user.create_subscription(TouchState, '/touch/state', self.states.append, latched_qos(1))
        return self.states

    def close(self) -> None:
        self.ctx.shutdown()


@pytest.fixture
def scene():
    made = []

    def make(**kwargs):
        made.append(Scene(**kwargs))
        return made[-1]
    yield make
    for s in made:
        s.close()


def hug_frames(n: int = 20):
    hug = dict.fromkeys(ch('chest_left', 'chest_right', 'back_upper', 'back_middle', 'side_left_upper',
                           'side_right_upper', 'head2'), 0.8)
    return (frame(i, hug if i >= 3 else None) for i in range(n))


def test_get_state_answers_active_sensors_with_positions_gestures_with_onset_and_subtypes(scene) -> None:
    s = scene()
    s.feed(hug_frames())
    answer = s.ask()
    assert answer.success and answer.state.bear and not answer.state.patch and not answer.state.skin
    state = answer.state
    names = {x.name for x in state.sensors}
    assert {'chest_left', 'back_upper', 'head2'} <= names
    head2 = next(x for x in state.sensors if x.name == 'head2')
    assert head2.region == 'head' and head2.level == pytest.approx(0.8)
    assert (head2.position.x, head2.position.z) == pytest.approx(BODY.by_name('head2').position[::2])
    assert state.has_centroid and state.frame_id == 'bear_link'
    gestures = {g.gesture: g for g in state.gestures}
    assert 'hug' in gestures and gestures['hug'].state == 1
    onset = gestures['hug'].onset
    assert onset.sec - EPOCH_S + onset.nanosec * 1e-9 == pytest.approx(3 / 3.4, abs=1e-6)
    assert {m.sensor for m in state.subtypes} == names and all(m.subtype != 'none' for m in state.subtypes)


def test_a_region_limits_the_bear_parts_and_an_unknown_one_is_an_empty_answer_that_says_so(scene) -> None:
    s = scene()
    s.feed(hug_frames())
    head = s.ask('head')
    assert head.success and [x.name for x in head.state.sensors] == ['head2'] and head.state.region == 'head'
    assert (head.state.centroid.x, head.state.centroid.z) == pytest.approx(BODY.by_name('head2').position[::2])
    assert [m.sensor for m in head.state.subtypes] == ['head2']
    assert all('head2' in g.sensors for g in head.state.gestures)
    feet = s.ask('left_foot')
    assert feet.success and not feet.state.sensors and not feet.state.has_centroid and not feet.state.gestures
    unknown = s.ask('hed')
    assert not unknown.success and "unknown region 'hed'" in unknown.message
    assert "did you mean 'head'" in unknown.message
    assert unknown.state.sensors == [] and unknown.state.gestures == [] and unknown.state.subtypes == []
    assert s.ask().success                                     # the node goes on


def test_touch_state_is_latched_published_on_change_and_periodically(scene) -> None:
    s = scene(rate_hz=0.5)
    s.feed(hug_frames(12))
    states = s.listen()                                         # a late subscriber
    s.executor.spin_for(0.01)
    assert len(states) == 1 and states[0].bear and states[0].sensors
    s.executor.spin_for(4.0)
    assert 2 <= len(states) <= 4                                # every 2 s with nothing changing
    s.feed([frame(30)])                                         # released: a change, published at once
    count = len(states)
    s.executor.spin_for(0.15)
    assert len(states) == count + 1 and states[-1].sensors == [] and states[-1].bear


def test_only_the_parts_that_run_appear_and_a_stopped_part_is_forgotten(scene) -> None:
    s = scene(with_bear=False)
    answer = s.ask()
    assert answer.success and not (answer.state.bear or answer.state.patch or answer.state.skin)
    patch = Node('patch_stand_in', context=s.ctx)
    gestures = patch.create_publisher(GestureEvent, '/touch/gesture', 10)
    panels = patch.create_publisher(PanelContact, '/patch/panels', sensor_data_qos())
    skin = Node('skin_stand_in', context=s.ctx)
    frames = skin.create_publisher(SkinFrame, '/skin/frame', sensor_data_qos())
    for node in (patch, skin):
        s.executor.add_node(node)
    gestures.publish(GestureEvent(gesture='stroke', probability=0.97))
    panels.publish(PanelContact(contact=np.eye(11, dtype=bool)[3].tolist(), any_contact=True))
    frames.publish(SkinFrame(contact=True, contact_point=Point(x=0.02, y=0.03, z=0.0)))
    s.executor.spin_for(0.1)
    state = s.ask().state
    assert state.patch and state.skin and not state.bear
    assert state.has_patch_gesture and state.patch_gesture.gesture == 'stroke' and bool(state.panels.contact[3])
    assert state.skin_contact and state.skin_contact_point.y == pytest.approx(0.03)
    assert not s.ask('head').state.has_patch_gesture            # a bear region leaves the patch and skin out
    skin.destroy_node()
    state = s.ask().state
    assert not state.skin and not state.skin_contact and math.isnan(state.skin_contact_point.x)
    assert state.patch


def test_the_tracker_drops_a_gesture_at_its_end_and_a_subtype_back_to_none() -> None:
    tracker = TouchStateTracker(BODY)
    Symbolic, Subtype = get_message('SymbolicGesture'), get_message('TouchSubtype')
    tracker.on_symbolic(Symbolic(gesture='hug', state=1, sensors=['chest_left']))
    tracker.on_subtype(Subtype(sensor='chest_left', subtype='hold'))
    state = tracker.state(Running(bear=True))
    assert [g.gesture for g in state.gestures] == ['hug'] and [m.subtype for m in state.subtypes] == ['hold']
    tracker.on_symbolic(Symbolic(gesture='hug', state=2, sensors=['chest_left']))
    tracker.on_subtype(Subtype(sensor='chest_left', subtype='none'))
    state = tracker.state(Running(bear=True))
    assert state.gestures == [] and state.subtypes == []
    assert tracker.state(Running(bear=False)).sensors == []


def test_the_tracker_lists_decided_gestures_only() -> None:
    """A CANDIDATE or WITHDRAWN is not a gesture under way, and changes nothing a client would be told."""
    tracker = TouchStateTracker(BODY)
    Symbolic = get_message('SymbolicGesture')
    tracker.on_symbolic(Symbolic(gesture='hug', state=Symbolic.CANDIDATE, confidence=0.8))
    assert tracker.state(Running(bear=True)).gestures == [] and tracker.version == 0
    tracker.on_symbolic(Symbolic(gesture='hug', state=Symbolic.START, confidence=1.0, sensors=['chest_left']))
    tracker.on_symbolic(Symbolic(gesture='tickle', state=Symbolic.CANDIDATE))
    tracker.on_symbolic(Symbolic(gesture='tickle', state=Symbolic.WITHDRAWN))
    assert [g.gesture for g in tracker.state(Running(bear=True)).gestures] == ['hug'] and tracker.version == 1


@pytest.mark.parametrize('name, value', [('rate_hz', 0.0), ('max_rate_hz', math.nan), ('body_map', '/no/such.yaml')])
def test_bad_parameters_give_a_clear_error(name, value) -> None:
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ParameterError, match=name):
            TouchStateNode(context=ctx, parameter_overrides=[Parameter(name, value=value)])
    finally:
        ctx.shutdown()
