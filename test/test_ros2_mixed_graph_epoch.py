"""Virtual devices on a common wall-clock time zero (``SOCIAL_TOUCH_SIM_EPOCH``), so that devices opened in
several processes at different moments play their scenes in step (test/ros2_scene.py compares the events of
two runs of the demo topic by topic on it)."""
import time

import pytest
import serial

from touch_sim.virtual_port import EPOCH_ENV, PortOptionError, forget_device


def due_at_read(port, epoch):
    """(frames due by the moment before reading ``port``, its device's next frame after, frames due after)."""
    before = (time.time() - epoch) * 150
    port.read(100000)
    return before, port.device.next_index, (time.time() - epoch) * 150


def in_step(port, epoch):
    """Whether the device sent every frame due since ``epoch`` at 150 Hz, and none ahead (to a frame)."""
    before, sent, after = due_at_read(port, epoch)
    return before - 1 <= sent <= after + 2


@pytest.fixture
def ports():
    opened = []

    def open_port(name):
        port = serial.serial_for_url(f'skinsim://{name}', timeout=0)
        opened.append((name, port))
        return port
    yield open_port
    for name, port in opened:
        port.close()
        forget_device(name)


def test_a_device_opened_before_the_epoch_sends_nothing_until_then(ports, monkeypatch):
    epoch = time.time() + 2.0
    monkeypatch.setenv(EPOCH_ENV, repr(epoch))
    port = ports('epoch_early')
    reads = 0
    while time.time() < epoch - 0.1:
        data = port.read(100000)
        if time.time() < epoch:  # the whole read before the epoch
            assert data == b''
            reads += 1
        time.sleep(0.05)
    assert reads > 0
    time.sleep(max(0.0, epoch + 0.1 - time.time()))
    # Frames 0.. of the scene, from the first, as many as are due at 150 Hz since the epoch.
    assert in_step(port, epoch) and port.device.next_index > 0


def test_devices_opened_apart_are_in_step(ports, monkeypatch):
    epoch = time.time() - 2.0
    monkeypatch.setenv(EPOCH_ENV, repr(epoch))
    first = ports('epoch_a')
    first.read(100000)
    time.sleep(0.3)
    second = ports('epoch_b')
    # Both at the frame due since the epoch, though opened 0.3 s apart.
    assert in_step(second, epoch) and in_step(first, epoch)


def test_a_bad_epoch_is_a_clear_error(monkeypatch):
    monkeypatch.setenv(EPOCH_ENV, 'soon')
    with pytest.raises(PortOptionError, match=f'{EPOCH_ENV}=.soon. must be a Unix time'):
        serial.serial_for_url('skinsim://epoch_bad', timeout=0)
    forget_device('epoch_bad')


def test_set_wall_epoch_starts_held_devices_together(ports, monkeypatch):
    from touch_sim.virtual_port import set_wall_epoch
    monkeypatch.setenv(EPOCH_ENV, repr(time.time() + 1e6))  # held back
    port = ports('epoch_held')
    assert port.read(100000) == b''
    epoch = time.time() + 1.0
    set_wall_epoch(epoch)
    assert port.read(100000) == b''
    later = ports('epoch_later')
    time.sleep(max(0.0, epoch + 0.3 - time.time()))
    assert in_step(port, epoch) and in_step(later, epoch)


def test_set_wall_end_stops_every_device_at_one_moment_with_its_port_open(ports, monkeypatch):
    from touch_sim.virtual_port import set_wall_end
    epoch = time.time() - 1.0
    monkeypatch.setenv(EPOCH_ENV, repr(epoch))
    port = ports('end_a')
    port.read(100000)
    end = time.time() + 0.2
    set_wall_end(end)
    try:
        time.sleep(0.5)
        port.read(100000)
        later = ports('end_b')                   # opened after the end: nothing of the scene past it either
        # Frames 0 .. the last due at the end, at 150 Hz; none after, though the devices' clocks run on.
        last = int((end - epoch) * 150) + 1
        assert port.device.next_index == last and port.read(100000) == b'' and port.is_open
        assert later.read(100000) == b''
    finally:
        set_wall_end(None)
    time.sleep(0.05)
    assert port.read(100000) != b''              # None plays on


class NodeClock:
    """A driver node's clock as the driver attaches it (seconds of ROS time): here the Unix time, or a simulated
    clock from ``start``."""

    def __init__(self, start=None):
        self.offset = 0.0 if start is None else start - time.time()

    def now_s(self):
        return time.time() + self.offset


def test_devices_on_a_node_clock_that_reads_the_unix_time_keep_the_common_epoch(ports, monkeypatch):
    # The drivers attach their node's clock to the device (touch_driver/serial_driver.py); without sim time it
    # reads the Unix time, and the scene's common time zero must hold there too.
    from touch_sim.virtual_port import set_wall_epoch
    monkeypatch.setenv(EPOCH_ENV, repr(time.time() + 1e6))  # held back, as test/ros2_scene.py starts node processes
    early = serial.serial_for_url('skinsim://epoch_node_a', timeout=0, do_not_open=True)
    early.attach_clock(NodeClock().now_s)
    early.open()
    try:
        assert early.read(100000) == b''
        epoch = time.time() + 0.5
        set_wall_epoch(epoch)
        time.sleep(0.3)
        later = ports('epoch_node_b')
        time.sleep(max(0.0, epoch + 0.3 - time.time()))
        assert in_step(early, epoch) and in_step(later, epoch)
    finally:
        early.close()
        forget_device('epoch_node_a')


def test_a_device_on_a_simulated_clock_starts_when_opened_whatever_the_epoch(monkeypatch):
    monkeypatch.setenv(EPOCH_ENV, repr(time.time() - 100.0))
    port = serial.serial_for_url('skinsim://epoch_sim', timeout=0, do_not_open=True)
    port.attach_clock(NodeClock(start=5.0).now_s)
    port.open()
    try:
        time.sleep(0.2)
        port.read(100000)
        assert 0 < port.device.next_index <= 0.4 * 150  # frames since opening, not the 100 s since the epoch
    finally:
        port.close()
        forget_device('epoch_sim')
