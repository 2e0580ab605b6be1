"""Virtual devices on a common wall-clock time zero (``SOCIAL_TOUCH_SIM_EPOCH``), so that devices opened in
several processes at different moments play their scenes in step (test/ros2_scene.py compares the events of
two runs of the demo topic by topic on it)."""
import time

import pytest
import serial

from touch_sim.virtual_port import EPOCH_ENV, PortOptionError, forget_device


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
    epoch = time.time() + 1.0
    monkeypatch.setenv(EPOCH_ENV, repr(epoch))
    port = ports('epoch_early')
    assert port.read(100000) == b'' and time.time() < epoch
    time.sleep(epoch + 0.1 - time.time())
    assert port.read(100000) != b''
    # Frames 0.. of the scene, from the first, as many as are due at 150 Hz since the epoch (one either side).
    assert abs(port.device.next_index - (time.time() - epoch) * 150) <= 2


def test_devices_opened_apart_are_in_step(ports, monkeypatch):
    epoch = time.time() - 2.0
    monkeypatch.setenv(EPOCH_ENV, repr(epoch))
    first = ports('epoch_a')
    first.read(100000)
    time.sleep(0.3)
    second = ports('epoch_b')
    second.read(100000)
    first.read(100000)
    # Both at the frame due now since the epoch (one frame apart at most: the two reads' moments).
    assert abs(first.device.next_index - second.device.next_index) <= 1
    assert abs(second.device.next_index - (time.time() - epoch) * 150) <= 2


def test_a_bad_epoch_is_a_clear_error(monkeypatch):
    monkeypatch.setenv(EPOCH_ENV, 'soon')
    with pytest.raises(PortOptionError, match=f'{EPOCH_ENV}=.soon. must be a Unix time'):
        serial.serial_for_url('skinsim://epoch_bad', timeout=0)
    forget_device('epoch_bad')
