"""The skin driver on the wall clock with a real pty: it reads when bytes arrive (no poll timer), publishes
every frame once, and survives the port going away and coming back."""

from __future__ import annotations

import os
import tempfile
import time

from touch_driver.skin.node import SkinDriverNode
from touch_graph.compat import sensor_data_qos
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.bench.replay import PtyPort
from touch_lab.robustness.pty_run import skin_frames


def _driver(port: str, **params):
    ctx = Context('wall', network=False)
    ctx.init()
    node = SkinDriverNode(context=ctx, namespace='skin', parameter_overrides=[
        Parameter(k, value=v) for k, v in {'port': port, **params}.items()])
    listener = Node('listener', context=ctx)
    published: list = []
    listener.create_subscription(node.frame_pub.msg_type, node.frame_pub.topic_name, published.append,
                                 sensor_data_qos(10_000))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    executor.add_node(listener)
    return ctx, node, executor, published


def _feed(port: PtyPort, executor, frames: list[bytes], rate_hz: float = 150.0) -> None:
    for frame in frames:
        os.write(port.master, frame)     # not port.write: it waits for bytes the reader thread takes at once
        executor.spin_for(1.0 / rate_hz)


def test_frames_are_read_when_they_arrive_and_published_once() -> None:
    port = PtyPort()
    ctx, node, executor, published = _driver(port.path)
    try:
        assert node.reads_on_arrival
        assert len(node.timers) == 1                      # the status timer alone: nothing polls
        _feed(port, executor, skin_frames(range(60)))
        assert executor.spin_until(lambda: len(published) == 60, timeout_sec=5.0)
        stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in published]
        assert stamps == sorted(stamps) and len(set(stamps)) == 60
        assert node.counters()['frames'] == 60 and node.counters()['frames_missed'] == 0
    finally:
        node.destroy_node()
        ctx.shutdown()
        port.close()


def test_read_on_arrival_false_polls_as_before() -> None:
    port = PtyPort()
    ctx, node, executor, published = _driver(port.path, read_on_arrival=False)
    try:
        assert not node.reads_on_arrival and len(node.timers) == 2
        _feed(port, executor, skin_frames(range(30)))
        assert executor.spin_until(lambda: len(published) == 30, timeout_sec=5.0)
    finally:
        node.destroy_node()
        ctx.shutdown()
        port.close()


def test_an_unplugged_port_is_reported_and_read_again_once_back(capsys) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        link = os.path.join(tmp, 'ttySKIN')
        first = PtyPort()
        os.symlink(first.path, link)
        ctx, node, executor, published = _driver(link, reconnect_period_s=0.05)
        second = None
        try:
            _feed(first, executor, skin_frames(range(20)))
            assert executor.spin_until(lambda: len(published) == 20, timeout_sec=5.0)
            os.unlink(link)
            first.close()                                  # the cable is pulled: the read fails
            assert executor.spin_until(lambda: not node.driver.is_open, timeout_sec=5.0)
            assert not node.status().connected and node.status().last_error   # (a retry may have renamed it)
            assert 'stopped answering' in capsys.readouterr().err
            executor.spin_for(0.2)                         # retries find nothing at the path
            second = PtyPort()
            os.symlink(second.path, link)                  # plugged in again
            assert executor.spin_until(lambda: node.driver.is_open, timeout_sec=5.0)
            time.sleep(0.05)
            _feed(second, executor, skin_frames(range(20, 40)))
            assert executor.spin_until(lambda: len(published) == 40, timeout_sec=5.0)
            assert node.reconnects == 1 and node.status().connected
        finally:
            node.destroy_node()
            ctx.shutdown()
            if second is not None:
                second.close()


def test_poll_rate_hz_given_to_a_driver_that_reads_on_arrival_is_a_warning(capsys) -> None:
    port = PtyPort()
    ctx, node, _, _ = _driver(port.path, poll_rate_hz=50.0)
    try:
        assert node.reads_on_arrival
        assert 'poll_rate_hz (50) is not used' in capsys.readouterr().err
    finally:
        node.destroy_node()
        ctx.shutdown()
        port.close()


class _EndlessPort:
    """A port that always has 10 bytes waiting (a sensor far faster than the executor takes them)."""

    timeout = 0
    in_waiting = 10

    def read(self, size: int) -> bytes:
        return b'x' * size

    def cancel_read(self) -> None:
        pass


def test_a_reader_whose_executor_does_not_take_stops_reading_at_its_backlog() -> None:
    from touch_driver.port_reader import MAX_BACKLOG, PortReader

    class Guard:
        triggers = 0

        def trigger(self) -> None:
            Guard.triggers += 1

    reader = PortReader(_EndlessPort(), Guard(), 'test reader')
    reader.start()
    try:
        deadline = time.monotonic() + 5.0
        while len(reader.received) < MAX_BACKLOG and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.1)
        assert len(reader.received) == MAX_BACKLOG            # the bytes wait in the port, not in memory
        assert len(reader.take()) == MAX_BACKLOG and reader.alive
    finally:
        reader.stop()
    assert not reader.alive
