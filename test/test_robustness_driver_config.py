"""Robustness: a driver whose configuration can never work does not start, with a clear error;
a port that is merely absent keeps the reconnect loop (issue 12, build items 1 and 4)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.patch.panels import PanelCalibrator
from touch_driver.serial_driver import PortURLError
from touch_graph.errors import ConfigError, ParameterError
from touch_sim.harness import Harness, node_class

# (sensor, parameters, words the error must contain): each one of issue 12's tracebacks, now a clear error.
BAD_PARAMETERS = [
    ('bear', {'poll_rate_hz': -5.0}, ['poll_rate_hz', '[0.01, 100000.0]', '-5.0']),
    ('bear', {'expected_rate_hz': float('nan')}, ['expected_rate_hz', 'nan']),
    ('bear', {'status_period_s': 0.0}, ['status_period_s', '[0.001, 3600.0]']),
    ('bear', {'port': ''}, ["'port'", 'device path or URL']),
    ('bear', {'threshold': 1.5}, ['threshold', '[0.001, 0.999]', '1.5']),
    ('bear', {'baseline_frames': 0}, ['baseline_frames', '[1, 100000]']),
    ('patch', {'tau': -0.5}, ['tau', '[0.0, 1.0]']),
    ('patch', {'k': 2.0}, ["'k'", '[0.0, 0.99]']),
    ('patch', {'decimation': 0}, ['decimation', '[1, 1000]']),
    ('skin', {'baudrate': -9600}, ['baudrate', '[50, 12000000]', '-9600']),
    ('skin', {'warn_error_fraction': 0.5, 'error_error_fraction': 0.1}, ['warn_error_fraction', 'must not exceed']),
]
NEVER_OPEN = [
    ('skin', 'foo://x', "protocol 'foo' not known"),
    ('skin', 'skinsim://x?nosie=3', "did you mean 'noise'"),
    ('skin', 'bearsim://bear', 'virtual device of another sensor'),
    ('bear', 'skinsim://skin', 'virtual device of another sensor'),
    ('patch', 'patchsim://p?rate=abc', 'rate'),
]


def start(sensor: str, parameters: dict):
    with Harness() as harness:
        return harness.add_node(node_class(f'{sensor}_driver'), namespace=sensor, parameters=parameters)


@pytest.mark.parametrize(('sensor', 'parameters', 'words'), BAD_PARAMETERS)
def test_an_out_of_range_parameter_stops_the_node_with_the_range(sensor, parameters, words) -> None:
    with pytest.raises(ParameterError) as caught:
        start(sensor, parameters)
    for word in words:
        assert word in str(caught.value)


@pytest.mark.parametrize(('sensor', 'port', 'words'), NEVER_OPEN)
def test_a_port_that_can_never_open_stops_the_node(sensor, port, words) -> None:
    with pytest.raises(PortURLError, match=words):
        start(sensor, {'port': port})


def test_an_absent_port_keeps_the_reconnect_loop() -> None:
    node = start('skin', {'port': '/dev/ttyNOPE_social_touch'})
    assert not node.driver.is_open and 'No such file' in node.last_error


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(['poll_rate_hz', 'expected_rate_hz', 'status_period_s', 'reconnect_period_s']),
       st.one_of(st.floats(max_value=0.0), st.just(float('nan')), st.floats(min_value=1e7)))
def test_any_non_positive_or_absurd_period_is_refused(name: str, value: float) -> None:
    with pytest.raises(ParameterError, match=name):
        start('bear', {name: value})


# ---------------------------------------------------------------------- panels.yaml
PANELS = '\n'.join(f'  - {{name: p{i}}}' for i in range(11))


@pytest.mark.parametrize(('head', 'panels', 'words'), [
    ('threshold: -40.0', PANELS, ['threshold', '(0, inf)', ':1']),
    ('release_fraction: 1.5', PANELS, ['release_fraction', '(0, 1]', ':1']),
    ('window_s: 0', PANELS, ['window_s', '(0, 3600]', ':1']),
    ('format: 1', PANELS.replace('{name: p3}', '{name: p3, threshold: -1}'), ['panel #4', ':6']),
])
def test_a_wrong_panels_file_names_file_and_line(tmp_path: Path, head: str, panels: str, words: list[str]) -> None:
    path = tmp_path / 'panels.yaml'
    path.write_text(f'{head}\npanels:\n{panels}\n')
    with pytest.raises(ConfigError) as caught:
        PanelCalibrator.from_yaml(path)
    for word in words:
        assert word in str(caught.value)


@pytest.mark.parametrize(('text', 'words'), [(f'release_fraction: 1.5\npanels:\n{PANELS}\n', 'release_fraction'),
                                             (f'panels:\n{PANELS}\n  - {{name: p11}}\n', '11 panel signals')])
def test_the_patch_driver_does_not_start_on_a_wrong_panels_file(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / 'panels.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=words):
        start('patch', {'panels': str(path)})


# ---------------------------------------------------------------------- launch
def test_launch_exits_non_zero_naming_the_node_that_did_not_start(tmp_path: Path) -> None:
    launch = tmp_path / 'bad.launch.yaml'
    launch.write_text(textwrap.dedent("""\
        launch:
        - node:
            pkg: social_touch
            exec: skin_driver
            name: skin_driver
            namespace: skin
            param:
            - {name: port, value: 'skinsim://x?nosie=3'}
        """))
    run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                          'launch', str(launch), '--sim-time', '--duration', '1'],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert run.returncode != 0
    assert '/skin/skin_driver' in run.stderr and "did you mean 'noise'" in run.stderr
    assert 'Traceback' not in run.stderr
