"""ViewState: what the page is sent, from messages; silence by the wall clock; bounded on long runs."""

from __future__ import annotations

import base64
import json
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.bear.body_map import BodyMap
from touch_graph.messages import get_message
from touch_view.body_layout import sensor_layout
from touch_view.state import LOG_SENT, POSTERIOR_WINDOW_S, TRAJECTORY_SENT, ViewState, encode_map

Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
BearFrame = get_message('social_touch_msgs/msg/BearFrame')
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
GesturePosteriors = get_message('social_touch_msgs/msg/GesturePosteriors')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
PanelContact = get_message('social_touch_msgs/msg/PanelContact')
DiagnosticArray = get_message('diagnostic_msgs/msg/DiagnosticArray')
DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')
KeyValue = get_message('diagnostic_msgs/msg/KeyValue')
T0 = 1_700_000_000.0
BODY = BodyMap.default()
LAYOUT = sensor_layout(BODY)


class FakeWall:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def header(t_s: float) -> Header:
    ns = round((T0 + t_s) * 1e9)
    return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id='x')


def make_state(**kw) -> tuple[ViewState, FakeWall]:
    wall = FakeWall()
    names = [f'panel{i}' for i in range(11)]
    return ViewState(LAYOUT, names, start_s=T0, wall_clock=wall, **kw), wall


def as_json(state: ViewState) -> dict:
    return json.loads(json.dumps(state.snapshot(), allow_nan=False))  # what the server sends, strictly JSON


def skin(t_s: float, x: float = math.nan, y: float = math.nan) -> SkinFrame:
    contact = not math.isnan(x)
    force = np.zeros(108, np.float32)
    if contact:
        force[0::3], force[2::3] = 0.01, 0.05
    return SkinFrame(header=header(t_s), pressure=np.full(144, 0.5 if contact else 0.0, np.float32), contact=contact,
                     contact_x=x, contact_y=y, force=force, total_force=1.8 if contact else 0.0)


def test_a_bear_hug_shows_its_regions_levels_and_subtypes():
    state, _ = make_state()
    level = np.zeros(64, np.float32)
    names = ['chest_left', 'back_upper', 'side_left_upper', 'side_right_lower']
    channels = BODY.channels(names)
    level[channels] = 0.9
    state.on_bear_frame(BearFrame(header=header(1.0), level=level, active=(level > 0.3).tolist(),
                                  fitted=BODY.fitted_mask().tolist(),
                                  faults=np.where(np.arange(64) == 3, 1, 0).astype(np.uint8)))
    state.on_symbolic(SymbolicGesture(header=header(3.0), gesture='hug', state=1, sensors=names), 1)
    state.on_subtype(TouchSubtype(header=header(3.0), sensor='chest_left', subtype='hold'))
    bear = as_json(state)['bear']
    assert [g['gesture'] for g in bear['gestures']] == ['hug'] and bear['gestures'][0]['since'] == 3.0
    assert bear['regions'] == ['side_left', 'side_right', 'torso_back', 'torso_front']
    assert bear['active'] == sorted(channels.tolist()) and bear['faults'] == [[3, 1]]
    levels = np.frombuffer(base64.b64decode(bear['levels']), np.uint8)
    assert levels[channels].tolist() == [230] * 4 and levels.sum() == 230 * 4  # round(255 * 0.9)
    assert bear['subtypes'] == {'chest_left': 'hold'}
    state.on_subtype(TouchSubtype(header=header(4.0), sensor='chest_left', subtype='none'))
    state.on_symbolic(SymbolicGesture(header=header(5.0), gesture='hug', state=2, duration_s=2.0), 1)
    snap = as_json(state)
    assert snap['bear']['gestures'] == [] and snap['bear']['regions'] == [] and snap['bear']['subtypes'] == {}
    assert [e['text'] for e in snap['log']] == ['hug started (chest_left, back_upper, side_left_upper, '
                                                'side_right_lower)', 'hug ended after 2.0 s']
    assert snap['graph_time'] == 5.0


def test_the_skin_trace_of_the_current_and_the_last_gesture_and_the_force():
    state, _ = make_state()
    for i in range(5):
        state.on_skin_frame(skin(0.1 * i, 10.0 + i, 20.0))
    part = as_json(state)['skin']
    assert part['current'] == [[10.0 + i, 20.0] for i in range(5)] and part['last'] == []
    assert part['point'] == [14.0, 20.0] and part['force'] == [0.36, 0.0, 1.8] and part['contact']
    state.on_skin_frame(skin(0.6))      # the finger lifts
    part = as_json(state)['skin']
    assert part['current'] == [] and len(part['last']) == 5 and part['point'] is None and not part['contact']
    state.on_command(HapticCommand(header=header(0.7), gesture='line_right', command='move_right',
                                   recogniser='trace', distance=0.03, margin=0.2, duration_s=0.5, frames=5))
    assert as_json(state)['skin']['command']['command'] == 'move_right'
    for i in range(3000):   # a long touch: bounded, and sent decimated with its last point
        state.on_skin_frame(skin(1.0 + i / 150, 1.0 + i * 0.01, 2.0))
    current = as_json(state)['skin']['current']
    assert len(current) <= TRAJECTORY_SENT + 1 and current[-1] == [round(1.0 + 2999 * 0.01, 2), 2.0]


def test_posteriors_keep_the_last_10_seconds_and_mark_events_in_them():
    state, _ = make_state()
    classes = ['push', 'slap', 'stroke', 'tickle']
    for i in range(400):   # 20 s at 20 Hz
        p = np.full(4, 0.25)
        state.on_posteriors(GesturePosteriors(header=header(i / 20), classes=classes, posteriors=p))
    state.on_gesture(GestureEvent(header=header(5.0), gesture='slap', probability=0.995))    # older than 10 s
    state.on_gesture(GestureEvent(header=header(15.0), gesture='stroke', probability=0.999))
    post = as_json(state)['patch']
    t = post['posteriors']['t']
    assert post['posteriors']['classes'] == classes and t[-1] == 0.0 and t[0] >= -POSTERIOR_WINDOW_S
    assert len(t) == 201 and post['posteriors']['p'][0] == [0.25] * 4
    assert post['events'] == [{'t': -4.95, 'gesture': 'stroke', 'p': 0.999}]
    assert post['last_event']['gesture'] == 'stroke'
    # Time going back (a looped bag) starts the history afresh instead of mixing two runs.
    state.on_posteriors(GesturePosteriors(header=header(1.0), classes=classes, posteriors=np.full(4, 0.25)))
    assert len(as_json(state)['patch']['posteriors']['t']) == 1


def test_a_sensor_is_shown_only_when_the_scene_runs_it_and_silent_after_stale_after_s():
    state, wall = make_state(stale_after_s=1.0)
    snap = as_json(state)
    assert not any(s['present'] for s in snap['sensors'].values())
    state.set_publishers('skin', 1)        # the driver exists, no frame yet: a grace period, then silent
    state.check_silence()
    assert as_json(state)['sensors']['skin'] == {'present': True, 'silent': False, 'frames': 0, 'age_s': None}
    wall.t += 1.01
    state.check_silence()
    assert as_json(state)['sensors']['skin']['silent']
    state.on_skin_frame(skin(0.0))
    state.check_silence()
    assert not as_json(state)['sensors']['skin']['silent']
    wall.t += 0.99
    state.check_silence()
    assert not as_json(state)['sensors']['skin']['silent']      # within a second: still live
    wall.t += 0.02
    state.check_silence()
    snap = as_json(state)
    assert snap['sensors']['skin']['silent'] and snap['sensors']['skin']['age_s'] == 1.01
    assert [e['text'] for e in snap['log']][-3:] == ['SILENT: no frame for over 1 s', 'frames again',
                                                      'SILENT: no frame for over 1 s']
    assert not snap['sensors']['bear']['present'] and not snap['sensors']['patch']['present']


def test_diagnostics_and_panels_and_the_log_stay_bounded():
    state, _ = make_state()
    for i in range(100):
        level = DiagnosticStatus.ERROR if i == 99 else DiagnosticStatus.OK
        status = DiagnosticStatus(level=level, name=f'driver{i % 40}', message='m', hardware_id='p',
                                  values=[KeyValue(key='rate_hz', value='20.0')])
        state.on_diagnostics(DiagnosticArray(header=header(i), status=[status]))
    snap = as_json(state)
    assert len(snap['drivers']) == 32 and snap['drivers'][0]['values'] == {'rate_hz': '20.0'}
    assert snap['log'][-1]['text'] == 'driver19: m'    # a driver that turns to ERROR is logged
    for i in range(500):
        contact = np.zeros(11, bool)
        contact[i % 11] = i % 2 == 0
        state.on_panels(PanelContact(header=header(i), contact=contact.tolist(), any_contact=bool(contact.any())))
    snap = as_json(state)
    assert len(snap['log']) == LOG_SENT and snap['patch']['panels'].count(True) <= 1
    assert [e['text'] for e in snap['log'][-2:]] == ['someone is handling the robot (panel3)', 'hands off']


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=144, max_size=144),
       st.floats(allow_nan=True, allow_infinity=True, width=32), st.floats(allow_nan=True, width=32))
def test_any_float_in_a_frame_gives_strict_json(pressure, x, force):
    """NaN and infinities never reach the page as invalid JSON (the server encodes with allow_nan=False)."""
    state, _ = make_state()
    msg = SkinFrame(header=header(0.0), pressure=np.array(pressure, np.float32), contact=True, contact_x=x,
                    contact_y=x, force=np.full(108, force, np.float32), total_force=force)
    state.on_skin_frame(msg)
    state.on_skin_frame(skin(0.1))
    part = as_json(state)['skin']
    cells = np.frombuffer(base64.b64decode(part['pressure']), np.uint8)
    assert cells.shape == (144,)


def test_encode_map_clips_and_reads_nan_as_zero():
    cells = np.frombuffer(base64.b64decode(encode_map(np.array([-1, 0, 0.5, 1, 7, np.nan, np.inf]))), np.uint8)
    assert cells.tolist() == [0, 0, 128, 255, 255, 0, 255]
