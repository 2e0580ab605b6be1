"""The three driver nodes on their virtual devices, in simulated time (synthetic data)."""

import math

import numpy as np
import pytest

from touch_driver.bear.node import BearDriverNode
from touch_driver.patch.node import PatchDriverNode
from touch_driver.skin.node import SkinDriverNode
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
from touch_sim.scenes import BearScript, BearTouch, PanelTouch, PatchScript, PatchTouch, register_stimulus
from touch_sim.skin.device import register_stimulus as register_skin_stimulus
from touch_sim.skin.stimuli import StaticPress
from touch_sim.virtual_port import forget_devices


@pytest.fixture(autouse=True)
def fresh_devices():
    forget_devices()
    yield
    forget_devices()


def spin_driver(node_class, seconds, topics, **params):
    ctx = Context('sim')
    ctx.init()
    node = node_class(context=ctx, namespace=node_class.sensor,
                      parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    listener = Node('listener', context=ctx)
    got = {topic: [] for topic in topics}
    for topic, type_name in topics.items():
        best_effort = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)  # hears any publisher
        listener.create_subscription(get_message(type_name), topic, got[topic].append, best_effort)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    executor.add_node(listener)
    executor.spin_for(seconds)
    node.destroy_node()
    ctx.shutdown()
    return node, got


def test_bear_driver_publishes_calibrated_frames_at_the_scan_rate():
    touch = BearTouch(channels=(1,), start=5.0, duration=4.0, level=1.0)
    register_stimulus('bear-node-test', BearScript([touch]))
    topics = {'/bear/frame': 'BearFrame', '/bear/bear_driver/status': 'DriverStatus'}
    _node, got = spin_driver(BearDriverNode, 10.0, topics, port='bearsim://t?scene=bear-node-test&seed=1')
    frames = got['/bear/frame']
    assert 32 <= len(frames) <= 36  # 3.4 Hz for 10 s
    assert frames[0].header.frame_id == 'bear_link'
    assert sum(frames[0].fitted) == 56  # bool[64]: a list of bools, as rclpy gives it
    touched = [f for f in frames if f.active[1]]
    assert touched and all(f.level[1] > 0.9 for f in touched)
    assert not any(f.active[0] for f in frames)
    status = got['/bear/bear_driver/status'][-1]
    assert status.connected and status.checksum_errors == 0 and status.rate_hz == pytest.approx(3.4, abs=1.1)


def test_bear_driver_flags_a_dead_sensor():
    node, got = spin_driver(BearDriverNode, 70.0, {'/bear/frame': 'BearFrame'},
                            port='bearsim://dead?dead=head2&seed=2', fault_after_s=30.0)
    channel = node.body_map.by_name('head2').channel
    last = got['/bear/frame'][-1]
    assert last.faults[channel] & 1 and not last.active[channel]
    assert not last.faults[node.body_map.by_name('head1').channel]


def test_skin_driver_keeps_a_sustained_press_and_reports_the_contact_point():
    register_skin_stimulus('skin-node-test', StaticPress(x_mm=20.0, y_mm=30.0, force_n=2.0, at_s=1.0, for_s=20.0))
    _node, got = spin_driver(SkinDriverNode, 22.0, {'/skin/frame': 'SkinFrame'}, port='skinsim://t?scene=skin-node-test')
    frames = got['/skin/frame']
    assert len(frames) == pytest.approx(22 * 150, abs=3)
    pressed = [f for f in frames[200:3000] if f.contact]
    assert len(pressed) > 0.95 * 2800
    assert abs(pressed[-1].total_force - pressed[0].total_force) < 0.1 * pressed[0].total_force
    assert pressed[-1].contact_x == pytest.approx(20.0, abs=2.0)
    assert pressed[-1].contact_y == pytest.approx(30.0, abs=2.0)
    assert math.isnan(frames[50].contact_x) and not frames[50].contact


def test_patch_driver_publishes_20hz_frames_and_fast_panel_contact():
    script = PatchScript([PatchTouch(at=(8.0, 8.0), radius=2.0, pressure=3.0, start=2.0, duration=2.0)],
                         [PanelTouch(panels=(3,), start=5.0, duration=1.0, level=1.0)])
    register_stimulus('patch-node-test', script)
    _node, got = spin_driver(PatchDriverNode, 8.0, {'/patch/frame': 'PatchFrame', '/patch/panels': 'PanelContact'},
                            port='patchsim://t?scene=patch-node-test&seed=3')
    frames = got['/patch/frame']
    assert len(frames) == pytest.approx(160, abs=2)
    peak = max(frames, key=lambda f: float(f.activation.max()))
    assert peak.activation.max() > 0.5 and np.all(peak.activation[~np.array(peak.in_outline)] == 0)
    quiet = frames[10]
    assert np.all(quiet.activation[quiet.in_outline] == pytest.approx(0.08))
    panels = got['/patch/panels']
    onsets = [p for p in panels if p.contact[3]]
    assert onsets and onsets[0].any_contact
    onset_s = onsets[0].header.stamp.sec + onsets[0].header.stamp.nanosec * 1e-9 - 1_700_000_000
    assert 5.0 <= onset_s < 5.15  # within a few 10 ms scans of the touch


def test_frames_read_in_one_poll_get_their_own_increasing_stamps():
    # Poll at 15 Hz a 150 Hz skin: about ten frames per poll, each stamped a nominal period apart.
    register_skin_stimulus('skin-stamps', StaticPress(x_mm=20.0, y_mm=30.0, force_n=2.0, at_s=0.5, for_s=1.0))
    _node, got = spin_driver(SkinDriverNode, 2.0, {'/skin/frame': 'SkinFrame'},
                             port='skinsim://t?scene=skin-stamps&seed=1', poll_rate_hz=15.0)
    stamps = np.array([f.header.stamp.sec * 10**9 + f.header.stamp.nanosec for f in got['/skin/frame']])
    assert len(stamps) > 200
    steps = np.diff(stamps)
    assert (steps > 0).all()
    period_ns = round(1e9 / 150.0)
    # Within a poll the step is the nominal period; between polls the rest of the poll's time.
    assert np.mean(steps == period_ns) > 0.8
