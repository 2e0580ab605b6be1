"""Parameters set while our nodes run: the ones a node can apply take effect at once, the others are refused
with the reason (never accepted and ignored). Through the nodes' parameter services, as ros2 param set does."""

import numpy as np
import pytest
from test_skin_multistroke import codebook

from touch_driver.bear.node import BearDriverNode
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.monitor_node import TouchMonitorNode
from touch_gestures.patch.node import PatchGesturesNode
from touch_gestures.skin.codebook import save_codebook
from touch_gestures.skin.fused import FusedRecogniser
from touch_gestures.skin.node import HapticCommandsNode
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_graph.runtime.parameters import parameter_msg
from touch_graph.srv_types import get_service
from touch_sim.virtual_port import forget_devices

SetParameters = get_service('rcl_interfaces/srv/SetParameters')


@pytest.fixture
def graph():
    context = Context('sim')
    context.init()
    executor = SingleThreadedExecutor(context=context)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    made = []

    def start(node_class, **kwargs):
        node = node_class(context=context, cli_args=['--ros-args', '--log-level', 'error'], **kwargs)
        executor.add_node(node)
        made.append(node)
        return node

    def set_parameters(node, **values):
        """The results of /<node>/set_parameters, one per value, as ros2 param set gets them."""
        client = caller.create_client(SetParameters, f'{node.get_fully_qualified_name()}/set_parameters')
        request = SetParameters.Request(parameters=[parameter_msg(Parameter(k, value=v)) for k, v in values.items()])
        future = client.call_async(request)
        executor.spin_until_future_complete(future, 10)
        return [(r.successful, r.reason) for r in future.result().results]
    yield start, set_parameters
    for node in made:
        node.destroy_node()
    executor.shutdown()
    context.try_shutdown()
    forget_devices()


def test_patch_gestures_applies_its_event_rule_at_once(graph):
    start, set_parameters = graph
    node = start(PatchGesturesNode)
    before = node.detector
    assert set_parameters(node, threshold=0.95, dwell_s=0.1) == [(True, ''), (True, '')]
    assert (node.detector.threshold, node.detector.dwell) == (0.95, 2) and node.detector is not before
    [(ok, why)] = set_parameters(node, threshold=0.5)  # below the release in force (0.9 from the model)
    assert not ok and 'release' in why and 'in [0, threshold = 0.5]' in why
    assert node.detector.threshold == 0.95
    [(ok, why)] = set_parameters(node, model='/elsewhere.npz')
    assert not ok and 'read-only' in why


def test_haptic_commands_recomputes_its_rejection_at_once_and_keeps_the_old_on_refusal(graph):
    start, set_parameters = graph
    node = start(HapticCommandsNode)
    old = node.recogniser
    assert set_parameters(node, min_margin=0.5, min_extent_mm=9.0) == [(True, ''), (True, '')]
    assert node.recogniser.get_params()['min_margin'] == 0.5 and node.min_extent_mm == 9.0
    assert old.get_params()['min_margin'] != 0.5  # a copy was changed, not the one in use
    in_use = node.recogniser
    [(ok, why)] = set_parameters(node, max_distance=-5.0)
    assert not ok and 'max_distance' in why and node.recogniser is in_use
    [(ok, _)] = set_parameters(node, codebook='/x.npz')
    assert not ok


def test_new_rejection_values_keep_the_codebooks_strokes_durations_and_paths(graph, tmp_path):
    start, set_parameters = graph
    gestures, labels = codebook(np.random.default_rng(3), names=('X', 'H', 'Z'), per_class=6)
    path = save_codebook(tmp_path / 'symbols.npz', FusedRecogniser().fit(gestures, labels), vocabulary='symbols')
    commands = tmp_path / 'commands.yaml'
    commands.write_text('format_version: 1\ncommands:\n  X: stop\n')
    node = start(HapticCommandsNode, parameter_overrides=[Parameter('codebook', value=str(path)),
                                                          Parameter('commands', value=str(commands))])
    old = node.recogniser
    assert set_parameters(node, min_margin=0.3) == [(True, '')] and node.recogniser is not old
    for attr in ('template_strokes_', 'template_contact_s_', 'template_paths_'):
        was, kept = getattr(old, attr), getattr(node.recogniser, attr)
        assert was is not None and np.array_equal(kept, was, equal_nan=True), attr
    np.testing.assert_array_equal(node.recogniser.order_evidence_.thresholds, old.order_evidence_.thresholds)


def test_a_driver_applies_what_it_can_and_refuses_what_it_reads_at_start(graph):
    start, set_parameters = graph
    node = start(BearDriverNode, parameter_overrides=[Parameter('port', value='bearsim://bear')])
    assert set_parameters(node, frame_id='teddy', reconnect_period_s=2.0) == [(True, ''), (True, '')]
    assert node.header().frame_id == 'teddy' and node.reconnect_period_s == 2.0
    [(ok, why)] = set_parameters(node, threshold=0.5)
    assert not ok and why == "'threshold' is read when the driver starts; relaunch the node to change it"
    [(ok, why)] = set_parameters(node, reconnect_period_s=0.0)
    assert not ok and '[0.001, 3600.0]' in why and node.reconnect_period_s == 2.0


def test_bear_gestures_reads_everything_at_start(graph):
    start, set_parameters = graph
    node = start(BearGesturesNode)
    [(ok, why)] = set_parameters(node, threshold=0.4)
    assert not ok and 'read-only' in why and node.recogniser.threshold == pytest.approx(0.3)


def test_touch_monitor_switches_subtypes_live(graph):
    start, set_parameters = graph
    node = start(TouchMonitorNode)
    assert set_parameters(node, show_subtypes=True) == [(True, '')] and node.show_subtypes is True
