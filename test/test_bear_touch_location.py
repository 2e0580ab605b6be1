"""Where the touch is: body-map positions, the touch centroid in SensorLevel / SymbolicGesture, sensor frames
on /tf_static (synthetic frames written by the test)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_bear_node import RATE, ch, frame
from test_bear_node import graph as graph

from touch_driver.bear.body_map import REGIONS, BodyMap
from touch_gestures.bear.sensor_frames import BearSensorFramesNode, quaternion_from_rpy
from touch_graph.compat import latched_qos
from touch_graph.errors import ConfigError
from touch_graph.messages import deserialize, get_message, serialize
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor

BODY = BodyMap.default()
TFMessage = get_message('tf2_msgs/msg/TFMessage')


def test_every_shipped_sensor_has_a_position_on_a_bear_sized_body_in_rep103_axes() -> None:
    assert BODY.frame_id == 'bear_link'
    positions = {s.name: np.array(s.position) for s in BODY.sensors}
    assert len(positions) == 56 and all(p is not None for p in positions.values())
    assert all(np.linalg.norm(p) < 0.6 for p in positions.values())               # a teddy bear, metres
    # REP 103: x forward (belly ahead of back), y left (the bear's left is +y), z up (head above feet).
    assert positions['belly_middle'][0] > 0 > positions['back_middle'][0]
    left = [s for s in BODY.sensors if s.side == 'left']
    assert all(positions[s.name][1] > 0 for s in left)
    assert all(positions[s.name][1] == -positions[s.name.replace('left', 'right')][1] for s in left)
    assert positions['head2'][2] > positions['belly_middle'][2] > positions['foot_left_sole'][2]


def test_a_body_map_position_in_millimetres_or_malformed_names_file_and_line(tmp_path: Path) -> None:
    base = "format: 1\nsensors:\n  - {channel: 0, name: a, location: x, region: head, side: center, size: small,\n"
    for bad, expected in (('position: [40, 0, 400]', 'millimetres by mistake'),
                          ('position: [0.1, 0.2]', 'three finite numbers'),
                          ('position: [.nan, 0, 0]', 'three finite numbers'),
                          ('position: [0, a, 0]', 'three finite numbers')):
        path = tmp_path / 'body.yaml'
        path.write_text(base + f'     {bad}}}\n')
        with pytest.raises(ConfigError, match=expected) as info:
            BodyMap.load(path)
        assert f'{path}:4' in str(info.value)
    path.write_text('format: 1\nframe_id: /bear\nsensors:\n  - {channel: 0, name: a, location: x, region: head, '
                    'side: center, size: small}\n')
    with pytest.raises(ConfigError, match='leading slash'):
        BodyMap.load(path)


def test_a_body_map_without_positions_still_loads_and_has_no_centroid(tmp_path: Path) -> None:
    path = tmp_path / 'old.yaml'
    path.write_text('format: 1\nsensors:\n  - {channel: 3, name: a, location: x, region: head, side: center, '
                    'size: small}\n')
    body = BodyMap.load(path)
    assert body.by_channel(3).position is None and body.frame_id == 'bear_link'
    assert body.centroid([3], [1.0]) is None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([s.channel for s in BODY.sensors]),
                          st.floats(0.0, 1.0, allow_nan=False)), max_size=12))
def test_the_centroid_is_a_weighted_mean_inside_the_touched_sensors_box(pairs) -> None:
    channels = [c for c, _ in pairs]
    levels = [v for _, v in pairs]
    point = BODY.centroid(channels, levels)
    weights = np.array(levels, dtype=np.float64)
    if not pairs or not weights.sum() > 0:
        assert point is None
        return
    touched = np.array([BODY.by_channel(c).position for c, v in pairs if v > 0])
    lo, hi = touched.min(axis=0), touched.max(axis=0)
    eps = 1e-12 * max(1.0, float(np.abs(touched).max()))    # float64 rounding of a convex combination
    assert np.all(lo - eps <= point) and np.all(np.array(point) <= hi + eps)


def test_non_finite_or_negative_levels_weigh_nothing() -> None:
    head2 = BODY.by_name('head2')
    assert BODY.centroid([head2.channel, 0], [0.5, math.nan]) == pytest.approx(head2.position)
    assert BODY.centroid([head2.channel, 0], [0.5, -1.0]) == pytest.approx(head2.position)
    assert BODY.centroid([0], [math.inf]) is None


def test_sensor_level_and_symbolic_carry_positions_and_the_touch_centroid(graph) -> None:
    g = graph(subtype_classifier='rule')
    (left,) = ch('side_left_upper')
    hug = dict.fromkeys(ch('chest_left', 'chest_right', 'back_upper', 'back_middle', 'side_left_upper',
                           'side_right_upper'), 0.8)
    hug[left] = 1.0                                                           # squeezed harder on the left
    g.update(frame(i, hug if 5 <= i < 20 else None) for i in range(40))
    level = g.got['sensor_level'][10]
    assert level.has_centroid and level.frame_id == 'bear_link'
    by_name = {s.name: s for s in level.sensors}
    assert by_name['chest_left'].position.x == pytest.approx(BODY.by_name('chest_left').position[0], abs=1e-12)
    expected = BODY.centroid(list(hug), list(hug.values()))
    got = (level.centroid.x, level.centroid.y, level.centroid.z)
    assert got == pytest.approx(expected, abs=1e-6)                          # float32 levels as weights
    assert level.centroid.y > 0                                               # towards the harder squeeze
    quiet = g.got['sensor_level'][2]
    assert not quiet.has_centroid and quiet.frame_id == 'bear_link' and quiet.centroid.x == 0.0
    events = {(m.gesture, m.state): m for m in g.got['symbolic']}
    start = next(m for (name, state), m in events.items() if name == 'hug' and state == 1)
    assert start.has_centroid and start.frame_id == 'bear_link'
    chosen = [BODY.by_name(n).channel for n in start.sensors]
    assert (start.centroid.x, start.centroid.y, start.centroid.z) == pytest.approx(
        BODY.centroid(chosen, [hug[c] for c in chosen]), abs=1e-6)
    end = next(m for (name, state), m in events.items() if name == 'hug' and state == 2)
    assert end.has_centroid                                                   # released: where the hug was
    assert end.header.stamp.sec * 1e9 + end.header.stamp.nanosec > start.header.stamp.sec * 1e9 + 19 / RATE


def test_the_centroid_fields_survive_cdr() -> None:
    SensorLevel = get_message('social_touch_msgs/msg/SensorLevel')
    Point = get_message('geometry_msgs/msg/Point')
    msg = SensorLevel(has_centroid=True, centroid=Point(x=0.1, y=-0.02, z=0.3), frame_id='bear_link')
    assert deserialize(serialize(msg), 'social_touch_msgs/msg/SensorLevel') == msg


def test_sensor_frames_are_latched_on_tf_static_for_a_late_subscriber() -> None:
    ctx = Context('sim')
    ctx.init()
    try:
        node = BearSensorFramesNode(context=ctx, namespace='bear', parameter_overrides=[
            Parameter('parent_frame', value='base_link'), Parameter('z', value=0.5), Parameter('yaw', value=math.pi)])
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.spin_for(1.0)
        late = Node('late', context=ctx)                     # joins after the one publication
        got = []
        late.create_subscription(TFMessage, '/tf_static', got.append, latched_qos(1))
        executor.add_node(late)
        executor.spin_for(0.5)
        assert len(got) == 1
        transforms = {t.child_frame_id: t for t in got[0].transforms}
        assert len(transforms) == 57
        body = transforms['bear_link']
        assert body.header.frame_id == 'base_link' and body.transform.translation.z == 0.5
        q = body.transform.rotation
        assert (q.x, q.y, q.z, q.w) == pytest.approx(quaternion_from_rpy(0, 0, math.pi), abs=1e-12)
        head2 = transforms['bear_head2']
        assert head2.header.frame_id == 'bear_link'
        assert (head2.transform.translation.x, head2.transform.translation.z) == (0.0, 0.415)
        assert {s.region for s in BODY.sensors} <= set(REGIONS)
    finally:
        ctx.shutdown()


def test_a_quaternion_from_rpy_is_unit_and_matches_tf2_for_a_pure_roll() -> None:
    q = quaternion_from_rpy(0.3, -1.1, 2.5)
    assert math.fsum(v * v for v in q) == pytest.approx(1.0, abs=1e-15)
    assert quaternion_from_rpy(math.pi / 2, 0, 0) == pytest.approx((math.sqrt(0.5), 0, 0, math.sqrt(0.5)))


def test_the_skin_frame_gives_the_contact_point_in_metres_and_the_net_force_in_newtons() -> None:
    from test_driver_nodes import spin_driver

    from touch_driver.skin.node import SkinDriverNode
    from touch_sim.skin.device import register_stimulus
    from touch_sim.skin.stimuli import StaticPress
    from touch_sim.virtual_port import forget_devices
    forget_devices()
    register_stimulus('skin-metres', StaticPress(x_mm=20.0, y_mm=30.0, force_n=2.0, at_s=1.0, for_s=3.0))
    try:
        _node, got = spin_driver(SkinDriverNode, 3.0, {'/skin/frame': 'SkinFrame'}, port='skinsim://t?scene=skin-metres')
    finally:
        forget_devices()
    frames = got['/skin/frame']
    pressed = [f for f in frames if f.contact][-1]
    point, force = pressed.contact_point, pressed.net_force
    # float32 mm -> float64 m: the same point to float32's precision.
    assert (point.x, point.y, point.z) == pytest.approx((pressed.contact_x * 1e-3, pressed.contact_y * 1e-3, 0.0),
                                                        rel=1e-6)
    assert force.z == pytest.approx(pressed.total_force, rel=1e-5) and force.z > 0.5
    module_forces = np.asarray(pressed.force, dtype=np.float64).reshape(36, 3).sum(axis=0)
    assert (force.x, force.y) == pytest.approx(tuple(module_forces[:2]), abs=1e-5)
    untouched = frames[10]
    assert not untouched.contact and math.isnan(untouched.contact_point.x) and math.isnan(untouched.contact_point.z)


def test_extreme_weights_keep_the_centroid_on_the_touched_sensor() -> None:
    # A subnormal weight alone (hypothesis found 5e-324) and weights whose sum overflows float64.
    head2 = BODY.by_name('head2')
    assert BODY.centroid([head2.channel], [5e-324]) == pytest.approx(head2.position, abs=1e-15)
    assert BODY.centroid([head2.channel, head2.channel], [1e308, 1e308]) == pytest.approx(head2.position, abs=1e-15)
