"""A node process stopped while it is still starting ends cleanly: exit code 0, no traceback.

The launcher (and a user's Ctrl-C) may signal a node process at any moment, also while the node's
constructor still runs; ros2 launch expects exit code 0 from a SIGINT. A CI run once caught the
window between "node visible in the graph" and "spin installed its handlers".
"""

import os
import signal

import pytest

from touch_graph.launch import processes, runner
from touch_graph.launch.specs import NodeSpec, spec_to_json
from touch_graph.node_main import StopSignals, run_node
from touch_graph.runtime import Node


class SignalledWhileStarting(Node):
    """A node whose constructor receives SIGINT, as if Ctrl-C came while it was starting."""

    constructed = 0

    def __init__(self, **kwargs):
        super().__init__('signalled_while_starting', **kwargs)
        os.kill(os.getpid(), signal.SIGINT)  # delivered at the next bytecode, inside __init__
        type(self).constructed += 1


def test_run_node_stops_cleanly_on_a_signal_during_the_constructor():
    previous = signal.getsignal(signal.SIGINT)
    assert run_node(SignalledWhileStarting, []) == 0
    assert SignalledWhileStarting.constructed == 1  # the constructor ran to its end
    assert signal.getsignal(signal.SIGINT) is previous  # handlers given back


def test_a_launched_node_process_stops_cleanly_on_a_signal_during_start(dds_domain, monkeypatch):
    started = runner.LaunchRunner.start

    def start_and_get_signalled(self):
        nodes = started(self)
        os.kill(os.getpid(), signal.SIGINT)  # between "in the graph" and "spinning"
        return nodes

    monkeypatch.setattr(runner.LaunchRunner, 'start', start_and_get_signalled)
    spec = NodeSpec(pkg='social_touch', exec='touch_monitor', name='early_stop', namespace=None, params=(),
                    remaps=(), file='<test>', line=None)
    assert processes.node_process_main([spec_to_json(spec), str(os.getppid())]) == 0


def test_a_second_signal_raises_keyboard_interrupt():
    with StopSignals() as stop:
        os.kill(os.getpid(), signal.SIGINT)
        assert stop.requested and stop.signal == signal.SIGINT
        woken = []
        stop.wake_with(lambda: woken.append(True))  # a stop that came before the waker: woken at once
        assert woken == [True]
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
