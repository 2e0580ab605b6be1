"""``social-touch launch``: file lookup, name:=value arguments, --show-args, --print-description, a timed run."""

import argparse
import shutil
from pathlib import Path

import pytest
from test_launch_runner import REGISTRY

import touch_graph.launch.cli as cli
import touch_graph.launch.runner as runner_module
from touch_graph.errors import ConfigError, LaunchError

FILES = Path(__file__).parent / 'launch_files'
GRAPH = str(FILES / 'graph.launch.yaml')


def parse(*words):
    parser = argparse.ArgumentParser(prog='social-touch launch')
    cli.add_arguments(parser)
    return parser.parse_args(list(words))


@pytest.fixture
def share(tmp_path, monkeypatch):
    """A fake installed share directory for package 'social_touch' with launch/ and a nested file."""
    root = tmp_path / 'share'
    (root / 'launch').mkdir(parents=True)
    (root / 'extra' / 'deep').mkdir(parents=True)
    shutil.copy(FILES / 'graph.launch.yaml', root / 'launch' / 'demo.launch.yaml')
    shutil.copytree(FILES / 'params', root / 'launch' / 'params')
    (root / 'extra' / 'deep' / 'other.launch.yaml').write_text('launch: []\n')

    def lookup(package):
        if package != 'social_touch':
            raise ConfigError(f"package '{package}' not found")
        return root

    monkeypatch.setattr(cli, 'launch_share', lookup)
    return root


def test_file_or_package_and_file(share):
    assert cli.find_launch_file([GRAPH, 'a:=1']) == (Path(GRAPH), ['a:=1'])
    assert cli.find_launch_file(['social_touch', 'demo.launch.yaml', 'robot:=x']) == (
        share / 'launch' / 'demo.launch.yaml', ['robot:=x'])
    nested = share / 'extra' / 'deep' / 'other.launch.yaml'
    assert cli.find_launch_file(['social_touch', 'other.launch.yaml'])[0] == nested


@pytest.mark.parametrize(('words', 'fragment'), [
    (['social_touch', 'demo.lauch.yaml'], "no launch file 'demo.lauch.yaml' (did you mean 'demo.launch.yaml'?)"),
    (['nopkg', 'demo.launch.yaml'], "nopkg is neither a file nor a package: package 'nopkg' not found"),
    (['missing.launch.yaml'], 'launch file not found: missing.launch.yaml'),
    (['missing.launch.yaml', 'a:=1'], 'launch file not found'),
    (['robot:=x'], 'expected a launch file (or PKG FILE) before the launch arguments'),
])
def test_lookup_errors(share, words, fragment):
    with pytest.raises(LaunchError) as info:
        cli.find_launch_file(words)
    assert fragment in str(info.value)


def test_launch_arguments_are_name_value_pairs():
    assert cli.parse_launch_arguments(['a:=1', 'b:=x:=y', 'c:=']) == {'a': '1', 'b': 'x:=y', 'c': ''}
    with pytest.raises(LaunchError, match="unexpected argument 'robot=x': launch arguments are name:=value"):
        cli.parse_launch_arguments(['robot=x'])
    with pytest.raises(LaunchError, match="unexpected argument ':=1'"):
        cli.parse_launch_arguments([':=1'])
    with pytest.raises(LaunchError, match="'a' is given twice"):
        cli.parse_launch_arguments(['a:=1', 'a:=2'])


def test_show_args_lists_names_descriptions_defaults(capsys):
    assert cli.run(parse(str(FILES / 'scene.launch.yaml'), '--show-args')) == 0
    out = capsys.readouterr().out
    assert out.startswith("Arguments (pass arguments as '<name>:=<value>'):")
    assert "    'rate':\n        bear frame rate in Hz\n        (default: '25.0')" in out
    assert "Valid choices are: ['true', 'false']" in out
    assert "'skin_ns'" in out  # from the included file


def test_show_args_marks_required_arguments(tmp_path, capsys):
    path = tmp_path / 'req.launch.yaml'
    path.write_text("launch:\n- arg: {name: port, description: serial port URL}\n")
    cli.run(parse(str(path), '-s'))
    assert "    'port':\n        serial port URL\n        (required)" in capsys.readouterr().out


def test_print_description_starts_nothing(capsys, monkeypatch):
    monkeypatch.setattr(runner_module.LaunchRunner, 'start', lambda self: pytest.fail('must not start'))
    assert cli.run(parse(GRAPH, 'robot:=r2', '--print-description')) == 0
    out = capsys.readouterr().out
    assert '/r2/bear/driver  (social_touch/talker)' in out and 'remap frame -> /touch/frame' in out
    assert 'param period = 0.1' in out


def test_unknown_argument_lists_the_declared_ones():
    with pytest.raises(LaunchError, match=r"unknown launch argument 'robto' \(did you mean 'robot'\?\); this launch "
                                          'file declares: robot, period, params'):
        cli.run(parse(GRAPH, 'robto:=r2', '-p'))


def test_rate_needs_sim_time():
    with pytest.raises(LaunchError, match='--rate needs --sim-time'):
        cli.run(parse(GRAPH, '--rate', '2'))


@pytest.mark.parametrize('option', [['--duration', '-1'], ['--duration', 'nan'], ['--rate', '0']])
def test_bad_numbers_are_rejected_by_the_parser(option):
    with pytest.raises(SystemExit):
        parse(GRAPH, *option)


def test_a_timed_run_on_simulated_time(capsys, monkeypatch, share):
    monkeypatch.setattr(runner_module, 'entry_point_registry', lambda: REGISTRY)
    assert cli.run(parse('social_touch', 'demo.launch.yaml', 'period:=0.5', '--sim-time', '--duration', '2')) == 0
    err = capsys.readouterr().err
    assert '[launch] 2 node(s) running in this process: /teddy/bear/driver, /teddy/listener' in err
    assert '[launch] all nodes stopped' in err


def test_a_scene_with_no_nodes_says_so(tmp_path, capsys):
    path = tmp_path / 'empty.launch.yaml'
    path.write_text('launch: []\n')
    assert cli.run(parse(str(path))) == 0
    assert 'no nodes to start' in capsys.readouterr().err
