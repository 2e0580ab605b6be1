"""launch/skin_patches.launch.yaml: N namespaced skin patches (driver + recogniser) from one argument."""

from __future__ import annotations

import pytest

from touch_graph.compat import sensor_data_qos
from touch_graph.errors import LaunchError
from touch_graph.launch import LaunchRunner, evaluate_launch
from touch_graph.launch.cli import launch_share
from touch_graph.messages import get_message
from touch_graph.paths import share_file

LAUNCH = share_file('launch', 'skin_patches.launch.yaml')


def _plan(patches: str):
    return evaluate_launch(LAUNCH, {'patches': patches}, find_package_share=launch_share)


@pytest.mark.parametrize('patches', ['1', '2', '8'])
def test_one_argument_sets_how_many_patches_start(patches: str) -> None:
    names = sorted(f'{spec.namespace}/{spec.name}' for spec in _plan(patches).nodes)
    n = int(patches)
    assert names == sorted([f'/skin{k}/skin_driver' for k in range(n)] + [f'/skin{k}/haptic_commands'
                                                                          for k in range(n)])


def test_a_count_out_of_range_is_refused() -> None:
    with pytest.raises(LaunchError, match='patches'):
        _plan('9')


def test_two_patches_launch_and_each_publishes_its_frames() -> None:
    frames: dict[str, list] = {'/skin0/frame': [], '/skin1/frame': []}
    with LaunchRunner(_plan('2').nodes, sim_time=True) as runner:
        listener = runner.runtime.Node('listener', context=runner.context)
        SkinFrame = get_message('SkinFrame')
        for topic, got in frames.items():
            listener.create_subscription(SkinFrame, topic, got.append, sensor_data_qos(1000))
        runner.executor.add_node(listener)
        runner.spin(1.0)
        drivers = {node.get_namespace(): node for node in runner.nodes if node.get_name() == 'skin_driver'}
        assert sorted(drivers) == ['/skin0', '/skin1']
        assert all(node.frame_id == f'{ns[1:]}_link' for ns, node in drivers.items())
    # 1 s of simulated time at 150 Hz on each patch's own virtual device
    assert all(len(got) >= 100 for got in frames.values()), {t: len(g) for t, g in frames.items()}
    assert frames['/skin0/frame'][0].header.frame_id == 'skin0_link'
