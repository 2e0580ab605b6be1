"""The view's commands and files: demo --view / --foxglove, the body layout, the colour ramp, bench view."""

from __future__ import annotations

import argparse
import subprocess
import sys

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap, BodySensor
from touch_graph.errors import ConfigError
from touch_graph.launch import evaluate_launch
from touch_graph.launch.cli import parse_launch_arguments
from touch_graph.paths import share_file
from touch_sim import demo
from touch_view.bench import bench_view
from touch_view.body_layout import VIEW_SIZE, load_layout, sensor_layout
from touch_view.colormap import heat_rgb


def test_demo_view_and_foxglove_add_their_nodes_to_the_scene():
    parser = argparse.ArgumentParser()
    demo.add_arguments(parser)
    args = parser.parse_args(['--view', '--view-port', '0', '--foxglove', '--foxglove-port', '9999'])
    assert args.view and args.view_port == 0 and args.foxglove and args.foxglove_port == 9999
    plan = evaluate_launch(share_file('launch', 'demo.launch.yaml'), parse_launch_arguments(
        ['view:=true', 'view_port:=0', 'foxglove:=true', 'foxglove_port:=9999']))
    nodes = {n.exec: n for n in plan.nodes}
    assert [p.value for p in nodes['touch_view'].parameter_values() if p.name == 'port'] == [0]
    assert [p.value for p in nodes['foxglove_server'].parameter_values() if p.name == 'port'] == [9999]
    plain = evaluate_launch(share_file('launch', 'demo.launch.yaml'), {})
    assert not {'touch_view', 'foxglove_server'} & {n.exec for n in plain.nodes}


def test_the_commands_explain_themselves():
    for command in ('view', 'foxglove'):
        result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', command, '--help'],
                                capture_output=True, text=True, timeout=60)
        text = ' '.join(result.stdout.split())
        assert result.returncode == 0 and '--port' in text and '0: any free port' in text


def test_every_sensor_of_the_bear_has_its_place_on_the_outline():
    body = BodyMap.default()
    positions, anchors = load_layout()
    assert set(positions) == set(body.names)            # no sensor falls back to its region's anchor
    assert set(anchors) >= {s.region for s in body}
    placed = sensor_layout(body)
    assert len({(p['view'], p['x'], p['y']) for p in placed}) == len(placed)   # no two on the same spot
    # The bear's own left is on the viewer's right in the front view.
    front = {p['name']: p for p in placed if p['view'] == 'front'}
    assert front['ear_left']['x'] > VIEW_SIZE[0] / 2 > front['ear_right']['x']


def test_a_sensor_the_layout_does_not_know_is_drawn_near_its_region(tmp_path):
    body = BodyMap([BodySensor(0, 'head1', 'crown front', 'head', 'center', 'small'),
                    BodySensor(1, 'tail', 'tail', 'torso_back', 'center', 'small'),
                    BodySensor(2, 'tail2', 'tail tip', 'torso_back', 'center', 'small')])
    placed = {p['name']: p for p in sensor_layout(body)}
    _, anchors = load_layout()
    view, x, y = anchors['torso_back']
    for name in ('tail', 'tail2'):
        assert placed[name]['view'] == view and np.hypot(placed[name]['x'] - x, placed[name]['y'] - y) < 10
    assert (placed['tail']['x'], placed['tail']['y']) != (placed['tail2']['x'], placed['tail2']['y'])
    bad = tmp_path / 'layout.yaml'
    bad.write_text('format: 1\nsensors:\n  head1: [side, 1, 2]\nregions: {}\n')
    with pytest.raises(ConfigError, match=r'layout.yaml:3: .head1. must be \[view, x, y\]'):
        load_layout(bad)


def test_maps_become_images_with_the_page_colours_and_masked_cells():
    values = np.linspace(0, 1, 256, dtype=np.float32)
    mask = np.ones(256, bool)
    mask[0] = False
    image = heat_rgb(values, 16, 16, scale=8, mask=mask)
    assert image.shape == (128, 128, 3) and image.dtype == np.uint8
    assert image[:8, :8].tolist() == [[[42, 42, 42]] * 8] * 8
    assert image[-1, -1].tolist() == [252, 255, 164]
    with pytest.raises(ValueError, match='16x16 map needs 256 cells'):
        heat_rgb(np.zeros(10), 16, 16)


@pytest.mark.slow
def test_bench_view_measures_both_modes_in_one_run():
    result = bench_view(repeats=1, clients=2, rate=4.0, scene_s=4.0)
    assert result['pages'] == 2 and len(result['cpu_s_runs']['with_view']) == 1
    assert result['cpu_s_without_view'] > 0 and result['extra_cpu'] is not None
    assert result['frames_sent_per_page'] > 5 and result['snapshots_per_s'] > 5
