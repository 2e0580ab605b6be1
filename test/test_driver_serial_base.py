"""The shared driver layers on a toy virtual sensor: SerialDriver and SerialDriverNode.

The toy sensor sends a 4-byte counter at 50 Hz through the real framing, a real pyserial
URL handler (``toysim://``) and the real virtual-port plumbing (clock, faults, unplug).
"""

import itertools
import struct
import sys
import types

import pytest
import serial
from hypothesis import given
from hypothesis import strategies as st

from touch_driver.driver_node import SerialDriverNode, frame_stamps_ns
from touch_driver.framing import SensorStreamDecoder, encode_frame
from touch_driver.serial_driver import DriverError, PortDisconnected, SerialDriver
from touch_graph.messages import get_message
from touch_graph.node_health import level_number
from touch_graph.runtime import Context, SingleThreadedExecutor
from touch_sim.virtual_port import VirtualSerial, device_state, forget_devices

TOY_ID = 0x7F
Status = get_message('DriverStatus')
Diagnostics = get_message('diagnostic_msgs/msg/DiagnosticArray')


class ToyModel:
    frame_period = 0.02

    def frame_bytes(self, index, t):
        return encode_frame(TOY_ID, index, struct.pack('<I', index))


class ToySerial(VirtualSerial):
    scheme = 'toysim'

    def make_model(self, name, options, seed=0):
        if options:
            raise ValueError(f'unknown options {sorted(options)}')
        return ToyModel()


@pytest.fixture(autouse=True)
def toy_handler():
    package = types.ModuleType('toy_handlers')
    package.__path__ = []
    module = types.ModuleType('toy_handlers.protocol_toysim')
    module.Serial = ToySerial
    sys.modules['toy_handlers'] = package
    sys.modules['toy_handlers.protocol_toysim'] = module
    serial.protocol_handler_packages.append('toy_handlers')
    forget_devices()
    yield
    serial.protocol_handler_packages.remove('toy_handlers')
    forget_devices()


class ToyDecoder(SensorStreamDecoder[int]):
    """The toy's stream decoder: a checked frame -> its counter; an implausible one is corrupt."""

    def __init__(self):
        super().__init__({TOY_ID: 4})

    def decode(self, frame):
        (value,) = struct.unpack('<I', frame.payload)
        return None if value > 10**6 else value


def make_driver(url, clock=None):
    return SerialDriver(url, ToyDecoder(), clock=clock)


def drain(driver):
    """Every frame that has arrived, read as the driver node's poll timer reads them."""
    frames = []
    while (frame := driver.read_frame(0)) is not None:
        frames.append(frame)
    return frames


def test_driver_reads_frames_on_an_attached_clock_and_close_is_idempotent():
    now = [0.0]
    with make_driver('toysim://a', clock=lambda: now[0]) as driver:
        assert [f.scan for f in drain(driver)] == [0]  # device time starts at attach; frame 0 is at t=0
        now[0] = 0.1
        frames = drain(driver)
        assert [f.scan for f in frames] == [1, 2, 3, 4, 5]
        assert frames[-1].received_s == 0.1
        driver.close()
        driver.close()
    assert not driver.is_open


def test_read_frame_waits_on_the_wall_clock():
    with make_driver('toysim://b') as driver:
        frame = driver.read_frame(timeout=1.0)
    assert frame is not None and frame.scan == 0


def test_bad_urls_and_options_give_clear_errors():
    with pytest.raises(DriverError, match='cannot open toysim://c'):
        make_driver('toysim://c?colour=red').open()
    with pytest.raises(DriverError, match='cannot open /dev/does-not-exist'):
        make_driver('/dev/does-not-exist').open()
    with pytest.raises(ValueError):
        make_driver('')


def test_a_reader_that_falls_behind_loses_old_frames_not_memory():
    now = [0.0]
    driver = make_driver('toysim://slow', clock=lambda: now[0])
    driver.open()
    assert len(drain(driver)) == 1
    now[0] = 3600.0  # an hour without reading
    frames = drain(driver)
    assert 50 < len(frames) <= 101 and frames[-1].scan == 180000  # about the last 2 s (buffer_s)
    # 179,9xx frames lost: more than half the 16-bit counter's range, which no counter can tell from a jump
    # back, so it is a restart of the count (reported), never a made-up number of frames lost.
    assert (driver.stats.sequence_resets, driver.stats.sequence_gaps, driver.stats.frames_missed) == (1, 0, 0)


def test_unplug_raises_port_disconnected_and_reopen_recovers():
    now = [0.0]
    driver = make_driver('toysim://d', clock=lambda: now[0])
    driver.open()
    now[0] = 0.05
    assert len(drain(driver)) == 3
    device_state('d').unplug()
    with pytest.raises(PortDisconnected):
        drain(driver)
    assert not driver.is_open
    with pytest.raises(DriverError):
        driver.open()
    device_state('d').replug()
    driver.open()
    now[0] = 0.2
    assert drain(driver)  # frames flow again, and the sequence gap is counted
    assert driver.stats.sequence_gaps == 0  # the decoder was reset on reopen: no false gap


def test_garbage_and_corruption_are_counted_not_raised():
    now = [0.0]
    driver = make_driver('toysim://e?garbage=0.3&corrupt=0.2&seed=4', clock=lambda: now[0])
    driver.open()
    frames = []
    for step in range(1, 101):
        now[0] = step * 0.1
        frames += drain(driver)
    assert 300 < len(frames) < 500  # 501 sent; about 20 % corrupted
    stats = driver.stats
    assert stats.checksum_errors > 0 and stats.dropped_bytes > 0
    assert stats.frames == len(frames) + driver.decoder.corrupt_frames


class ToyDriverNode(SerialDriverNode):
    sensor = 'toy'
    default_port = 'toysim://node'
    frame_rate_hz = 50.0

    def __init__(self, **kwargs):
        super().__init__('toy_driver', **kwargs)
        self.values = []

    def make_decoder(self):
        return ToyDecoder()

    def handle_frame(self, frame):
        self.values.append(frame.scan)


def run_node(**overrides):
    ctx = Context('sim')
    ctx.init()
    from touch_graph.runtime import Parameter
    node = ToyDriverNode(context=ctx, parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    statuses, diagnostics = [], []
    node.create_subscription(Status, '~/status', statuses.append, 10)
    node.create_subscription(Diagnostics, '/diagnostics', diagnostics.append, 10)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    return ctx, node, executor, statuses, diagnostics


def test_driver_node_publishes_status_and_survives_unplug_replug():
    ctx, node, executor, statuses, diagnostics = run_node(port='toysim://unplug?unplug_at=2.0&replug_at=3.5')
    executor.spin_for(6.0)
    assert statuses and statuses[0].connected and statuses[0].rate_hz == pytest.approx(50, abs=2)
    assert any(not s.connected for s in statuses)
    assert statuses[-1].connected and statuses[-1].reconnects == 1
    levels = [level_number(d.status[0]) for d in diagnostics]
    assert 2 in levels and levels[-1] == 0
    # Frames resume after the replug; those sent while unplugged are lost, as on hardware.
    assert node.values[0] == 0 and max(node.values) >= 290
    node.destroy_node()
    node.destroy_node()
    ctx.shutdown()


def test_driver_node_starts_without_its_device_and_connects_when_it_appears():
    ctx, node, executor, statuses, _ = run_node(port='toysim://late')
    device_state('late').unplug()
    node.driver.close()
    executor.spin_for(2.0)
    assert not node.values and not statuses[-1].connected
    device_state('late').replug()
    executor.spin_for(2.0)
    assert node.values and statuses[-1].connected
    ctx.shutdown()


def test_a_simulator_url_without_the_simulator_is_a_clear_error_at_once(monkeypatch):
    """A robot installed without touch_sim: a bearsim:// port says what is missing, the node does not start."""
    from touch_driver.bear.node import BearDriverNode
    from touch_driver.serial_driver import PortURLError, url_handler_packages
    from touch_graph.runtime import Parameter
    assert url_handler_packages()['bearsim'] == 'touch_sim.urlhandlers'
    for name in [m for m in sys.modules if m == 'touch_sim' or m.startswith('touch_sim.')]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, 'touch_sim', None)  # import touch_sim raises ImportError
    monkeypatch.setattr(serial, 'protocol_handler_packages',
                        [p for p in serial.protocol_handler_packages if not p.startswith('touch_sim')])
    with pytest.raises(PortURLError, match=r"'bearsim://' is a virtual device of the 'touch_sim' package"):
        SerialDriver('bearsim://x', ToyDecoder())
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(PortURLError, match='pip install social_touch'):
            BearDriverNode(context=ctx, parameter_overrides=[Parameter('port', value='bearsim://x')])
    finally:
        ctx.shutdown()
    SerialDriver('loop://', ToyDecoder())  # pyserial's own: no lookup


def test_importing_touch_sim_makes_its_urls_open_with_serial_for_url():
    import touch_sim  # noqa: F401
    port = serial.serial_for_url('skinsim://url-check', do_not_open=True)
    assert type(port).__module__ == 'touch_sim.urlhandlers.protocol_skinsim'


@given(count=st.integers(1, 50), now_ns=st.integers(0, 10**12), period_ns=st.integers(1, 10**9),
       last_ns=st.none() | st.integers(0, 2 * 10**12))
def test_frame_stamps_increase_and_never_pass_now(count, now_ns, period_ns, last_ns):
    stamps = frame_stamps_ns(count, now_ns, period_ns, last_ns)
    assert len(stamps) == count and stamps[-1] <= now_ns and min(stamps) >= 0
    if now_ns >= count - 1:                 # room for count distinct stamps in [0, now]
        assert all(b > a for a, b in itertools.pairwise(stamps))
    if last_ns is not None and last_ns + count <= now_ns:   # room after the previous frame: all after it
        assert stamps[0] > last_ns
    if (last_ns is None or last_ns < now_ns - (count - 1) * period_ns) and now_ns >= (count - 1) * period_ns:
        assert stamps == [now_ns - (count - 1 - i) * period_ns for i in range(count)]
