"""A graph a stray process cannot silently blind: robustness cases for frame screening and bounded parameters.

- :func:`skin_flood`: the people scene (SYNTHETIC) through ``skin_driver`` + ``haptic_commands`` while a
  separate process floods ``/skin/frame`` with empty frames over Cyclone DDS; the commands must match
  an undisturbed run and ``/diagnostics`` must name the cause;
- stale, foreign or empty frames among the driver's, on the patch and bear recognisers;
- parameters that would switch a check off, refused with the reason; an accepted change logged at
  WARN and counted in the node's diagnostics.

Simulated time throughout: no case depends on the machine's speed.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import random
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any
from unittest.mock import patch

import numpy as np

from touch_driver.skin.node import SkinDriverNode
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.patch.node import PatchGesturesNode
from touch_gestures.skin.node import HapticCommandsNode
from touch_graph.messages import get_message
from touch_graph.node_health import level_number
from touch_graph.paths import share_file
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_sim.skin.device import forget_stimuli, register_stimulus
from touch_sim.skin.stimuli import load_scene
from touch_sim.virtual_port import forget_devices

__all__ = ['LOCK_DIR', 'STRAY_PUBLISHER', 'TEST_DOMAINS', 'hold_test_domain', 'skin_flood', 'stray_cases']

#: The stray process: joins the domain on our runtime (Cyclone DDS) and publishes ``SkinFrame()`` (144 zero
#: pressures, stamp 0, sequence 0, frame_id argv[3]) on /skin/frame at argv[1] Hz until killed or argv[2] s.
STRAY_PUBLISHER = textwrap.dedent('''
    import sys, time
    from touch_graph.messages import get_message
    from touch_graph.runtime import Context, Node
    from touch_graph.compat import sensor_data_qos
    SkinFrame, Header = get_message('SkinFrame'), get_message('std_msgs/msg/Header')
    ctx = Context('wall', network=True); ctx.init()
    node = Node('stray', context=ctx)
    pub = node.create_publisher(SkinFrame, '/skin/frame', sensor_data_qos(10))
    period, end = 1.0 / float(sys.argv[1]), time.monotonic() + float(sys.argv[2])
    sent, next_t = 0, time.monotonic()
    print('publishing', flush=True)
    while time.monotonic() < end:
        pub.publish(SkinFrame(header=Header(frame_id=sys.argv[3])))
        sent += 1
        next_t += period
        time.sleep(max(0.0, next_t - time.monotonic()))
    ctx.shutdown()
''')
_NODE = '/skin/haptic_commands'


def _scene_run(scene: Any, stray: subprocess.Popen | None, rate: float, network: bool,
               screening: bool = True) -> dict[str, Any]:
    """skin_driver playing ``scene`` + haptic_commands (+ a /diagnostics listener) in sim time; what came out.

    With ``stray``, the recogniser first waits (spinning, before the driver starts: at most 60 s of wall
    time) until the stray's frames arrive, so the whole scene runs under the flood. ``screening=False`` hands
    every frame to the recogniser as before screening existed (to measure what the screen buys)."""
    forget_devices()
    forget_stimuli()
    register_stimulus('skin-stray-flood', scene)
    ctx = Context('sim', rate=rate, network=network)
    ctx.init()
    quiet = ['--ros-args', '--log-level', 'error']
    try:
        node = HapticCommandsNode(context=ctx, namespace='skin', cli_args=quiet)
        if not screening:
            node.screen.admit = lambda msg: [msg]
        listener = Node('listener', context=ctx)
        commands: list[Any] = []
        statuses: list[Any] = []
        listener.create_subscription(get_message('HapticCommand'), '/touch/haptic_command', commands.append, 100)
        listener.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                                     lambda m: statuses.extend(s for s in m.status if s.name.endswith(_NODE)), 100)
        executor = SingleThreadedExecutor(context=ctx)
        for n in (node, listener):
            executor.add_node(n)
        before = 0
        if stray is not None:
            deadline = time.monotonic() + 60.0
            while (node.stream.frames + sum(node.screen.screened.values()) == 0 and stray.poll() is None
                   and time.monotonic() < deadline):
                executor.spin_for(0.05)
            before = node.stream.frames + sum(node.screen.screened.values())
        driver = SkinDriverNode(context=ctx, namespace='skin', cli_args=quiet, parameter_overrides=[
            Parameter('port', value='skinsim://flood?scene=skin-stray-flood&seed=1')])
        executor.add_node(driver)
        executor.spin_for(scene.duration_s + 6.0)   # the last /diagnostics period after the scene, too
        for n in (driver, listener, node):
            n.destroy_node()
        return {'commands': [c.command for c in commands], 'outcomes': dict(node.outcomes),
                'stray_before_scene': before, 'screened': dict(node.screen.screened),
                'malformed': dict(node.screen.malformed_), 'admitted': node.screen.admitted,
                'restarts': node.stream.restarts, 'statuses': [(level_number(s), s.message) for s in statuses],
                'callback_errors': node.callback_errors}
    finally:
        ctx.try_shutdown()
        forget_devices()
        forget_stimuli()


def skin_flood(hz: float = 300.0, rate: float = 1.0, frame_id: str = '', screening: bool = True,
               max_flood_s: float = 600.0) -> dict[str, Any]:
    """The people scene undisturbed, then under a stray process's flood of frames at ``hz`` carrying ``frame_id``
    (``''`` as ``SkinFrame()``, or the driver's ``'skin_link'``, stale by stamp only). Sim time runs at ``rate`` x
    real time (real time by default, as on a robot: a faster clock turns a busy machine's stall into a burst
    beyond the recogniser's queue). Needs a DDS domain of its own (``ROS_DOMAIN_ID``; the caller sets it).
    Returns both runs' results; ``'ok'``: the flooded run recognised within one command of the undisturbed
    one and its /diagnostics named the cause."""
    scene = load_scene(share_file('config', 'scenes', 'skin_people.yaml'))
    calm = _scene_run(scene, None, rate=float('inf'), network=False)
    env = {**os.environ}
    env.pop('SOCIAL_TOUCH_NETWORK', None)
    stray = subprocess.Popen([sys.executable, '-c', STRAY_PUBLISHER, str(hz), str(max_flood_s), frame_id], env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd='/tmp')
    try:
        flooded = _scene_run(scene, stray, rate=rate, network=True, screening=screening)
    finally:
        stray.kill()
        _, err = stray.communicate(timeout=30)
    named = [m for level, m in flooded['statuses'] if level >= 1 and ('not used' in m or 'no usable frame' in m)]
    stray_frames = sum(flooded['screened'].values())
    within_one = abs(len(flooded['commands']) - len(calm['commands'])) <= 1
    ok = (flooded['stray_before_scene'] > 0 and stray_frames > 0 and within_one and bool(named)
          and flooded['callback_errors'] == 0)
    return {'ok': ok, 'undisturbed': len(calm['commands']), 'flooded': len(flooded['commands']),
            'stray_frames_screened': stray_frames, 'stray_before_scene': flooded['stray_before_scene'],
            'diagnostics': named[:1], 'calm': calm, 'flood': flooded,
            'stray_stderr': err.decode(errors='replace').strip().splitlines()[-3:]}


# --------------------------------------------------------------------------- parameter cases

def _skin_node() -> tuple[Any, Any]:
    ctx = Context('sim', network=False)
    ctx.init()
    return ctx, HapticCommandsNode(context=ctx, namespace='skin', cli_args=['--ros-args', '--log-level', 'error'])


def _refused(name: str, value: Any, fragment: str = 'out of range') -> Callable[[], Any]:
    """``param set /skin/haptic_commands name value`` (as the parameter service does it) is refused, naming why."""
    def run() -> Any:
        ctx, node = _skin_node()
        try:
            before = node.recogniser
            [result] = node.set_parameters([Parameter(name, value=value)])
            if result.successful or fragment not in result.reason or node.recogniser is not before:
                return False
            return f'refused: {result.reason}'
        finally:
            ctx.try_shutdown()
    return run


def _change_logged_and_counted() -> Any:
    ctx, node = _skin_node()
    try:
        [result] = node.set_parameters([Parameter('min_margin', value=0.3)])
        level, text, counters = node.health.status()
        if not (result.successful and level == 1 and counters['parameter_changes'] == 1
                and 'min_margin: 0.1 -> 0.3' in text):
            return False
        return f'WARN on /diagnostics: {text}'
    finally:
        ctx.try_shutdown()


def _patch_threshold_refused() -> Any:
    ctx = Context('sim', network=False)
    ctx.init()
    try:
        node = PatchGesturesNode(context=ctx, namespace='patch', cli_args=['--ros-args', '--log-level', 'error'])
        [result] = node.set_parameters([Parameter('threshold', value=0.01)])
        return False if result.successful or 'out of range' not in result.reason else f'refused: {result.reason}'
    finally:
        ctx.try_shutdown()


# --------------------------------------------------------------------------- screening cases

def _header(t_s: float, frame_id: str) -> Any:
    sec, nanosec = divmod(round(t_s * 1e9), 1_000_000_000)
    return get_message('std_msgs/msg/Header')(stamp=get_message('builtin_interfaces/msg/Time')(
        sec=sec, nanosec=nanosec), frame_id=frame_id)


def _patch_interleaved() -> Any:
    """The patch driver's 20 Hz frames with a stray's, stamped 0, between every two: all driver frames used."""
    PatchFrame = get_message('PatchFrame')
    ctx = Context('sim', network=False)
    ctx.init()
    try:
        node = PatchGesturesNode(context=ctx, namespace='patch', cli_args=['--ros-args', '--log-level', 'error'])
        for i in range(100):
            node._on_frame(PatchFrame(header=_header(1000 + i / 20, 'patch'), sequence=i,
                                      activation=np.full(256, 0.05, np.float32)))
            node._on_frame(PatchFrame())   # the stray's: stamp 0, no frame_id
        level, text, _ = node.health.status()
        ok = node.frames == 100 and node.resets == 0 and level == 1 and 'other_frame_id' in text
        return f'{node.frames} of 100 driver frames used, no reset; WARN: {text[:120]}' if ok else False
    finally:
        ctx.try_shutdown()


def _bear_stale_same_frame_id() -> Any:
    """A stray replaying old bear frames under the driver's frame_id: screened by stamp, all driver frames used."""
    BearFrame = get_message('BearFrame')
    ctx = Context('sim', network=False)
    ctx.init()

    def frame(t: float, seq: int) -> Any:
        return BearFrame(header=_header(t, 'bear_link'), sequence=seq, level=np.zeros(64, np.float32),
                         active=[False] * 64, fitted=[True] * 64, faults=np.zeros(64, np.uint8))
    try:
        node = BearGesturesNode(context=ctx, cli_args=['--ros-args', '--log-level', 'error'],)
        for i in range(40):
            node._on_frame(frame(2000 + i / 3.4, 100 + i))
            node._on_frame(frame(5.0, 7))          # the same stale frame, over and over
        level, text, _ = node.health.status()
        ok = node.frames == 40 and node.resets == 0 and level == 1 and 'stamp_back' in text
        return f'{node.frames} of 40 driver frames used, no reset; WARN: {text[:120]}' if ok else False
    finally:
        ctx.try_shutdown()


def _skin_nothing_usable() -> Any:
    """Only NaN frames arrive: ERROR on /diagnostics naming the cause."""
    SkinFrame = get_message('SkinFrame')
    ctx, node = _skin_node()
    try:
        for i in range(30):
            node._on_frame(SkinFrame(header=_header(100 + i / 150, 'skin'), sequence=i,
                                     pressure=np.full(144, np.nan, np.float32)))
        level, text, _ = node.health.status()
        return f'ERROR: {text[:120]}' if level == 2 and 'non_finite' in text else False
    finally:
        ctx.try_shutdown()


#: Domain ids the test suite and the floods take, each held by an flock in LOCK_DIR (hold_test_domain): never 0,
#: the default a robot uses, nor the low ones people pick by hand, nor one a test is using.
TEST_DOMAINS = range(100, 233)
LOCK_DIR = Path('/tmp/social_touch_test_domains')


@contextlib.contextmanager
def hold_test_domain() -> Iterator[int]:
    """Hold a domain id no other process of the test suite or the report holds (an flock per id); yields it."""
    LOCK_DIR.mkdir(mode=0o700, exist_ok=True)
    for domain in random.sample(TEST_DOMAINS, len(TEST_DOMAINS)):
        fd = os.open(LOCK_DIR / f'{domain}.lock', os.O_CREAT | os.O_RDWR, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        try:
            yield domain
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
        return
    raise RuntimeError(f'every domain id in {TEST_DOMAINS} is held by another process (the tests or a flood)')


def _flood_case(frame_id: str) -> Callable[[], Any]:
    """:func:`skin_flood` on a domain of its own (LOCALHOST discovery), whatever ``ROS_DOMAIN_ID`` says."""
    def run() -> Any:
        with hold_test_domain() as domain, patch.dict(os.environ, ROS_DOMAIN_ID=str(domain),
                                                      ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST'):
            os.environ.pop('ROS_STATIC_PEERS', None)
            os.environ.pop('CYCLONEDDS_URI', None)
            r = skin_flood(frame_id=frame_id)
        if not r['ok']:
            return False
        return (f"{r['flooded']} commands under the flood, {r['undisturbed']} undisturbed; "
                f"{r['stray_frames_screened']} stray frames screened; {r['diagnostics'][0][:100]}")
    return run


def stray_cases() -> list[tuple[str, str, Callable[[], Any]]]:
    """``(area, case, callable)`` of this module, for :func:`~touch_lab.robustness.cases.all_cases`."""
    area = 'stray process in the domain'
    return [
        (area, 'another process floods /skin/frame with SkinFrame() (stamp 0) at 300 Hz', _flood_case('')),
        (area, "another process floods /skin/frame with frames stamped 0 as 'skin_link'", _flood_case('skin_link')),
        (area, 'param set /skin/haptic_commands max_distance 1000000.0', _refused('max_distance', 1_000_000.0)),
        (area, 'param set /skin/haptic_commands max_distance .inf', _refused('max_distance', float('inf'))),
        (area, 'param set /skin/haptic_commands min_margin 0.0', _refused('min_margin', 0.0)),
        (area, 'param set /skin/haptic_commands auto_scale 1000.0', _refused('auto_scale', 1000.0)),
        (area, 'param set /skin/haptic_commands collision_force_n .inf',
         _refused('collision_force_n', float('inf'), 'read-only')),
        (area, 'param set /skin/haptic_commands codebook other.npz', _refused('codebook', 'other.npz', 'read-only')),
        (area, 'param set /patch/patch_gestures threshold 0.01', _patch_threshold_refused),
        (area, 'param set /skin/haptic_commands min_margin 0.3: WARN and counted', _change_logged_and_counted),
        (area, 'patch frames interleaved with empty frames stamped 0', _patch_interleaved),
        (area, 'bear frames interleaved with a stale one under the same frame_id', _bear_stale_same_frame_id),
        (area, 'skin frames all NaN: ERROR on /diagnostics', _skin_nothing_usable),
    ]
