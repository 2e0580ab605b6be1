"""The ROS 2 package: colcon builds it with the node executables, export-interfaces writes the msgs package."""

import ast
import json
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from importlib.metadata import entry_points
from pathlib import Path

import pytest
from doctest_testing import check_doctests

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the test extra installs tomli
    import tomli as tomllib

from touch_graph.cli.export_interfaces import export_interfaces
from touch_graph.errors import ConfigError
from touch_graph.messages import msg_files

ROOT = Path(__file__).resolve().parent.parent
NODES = ('bear_driver', 'patch_driver', 'skin_driver', 'bear_gestures', 'patch_gestures', 'haptic_commands',
         'touch_monitor',
         'recorder', 'player')
PROJECT = tomllib.loads((ROOT / 'pyproject.toml').read_text())['project']
#: pyproject.toml's dependency -> package.xml's rosdep key for it.
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'scikit-learn': 'python3-sklearn', 'scipy': 'python3-scipy',
               'pyserial': 'python3-serial', 'pyyaml': 'python3-yaml', 'matplotlib': 'python3-matplotlib',
               'rosbags': 'python3-rosbags-pip', 'cyclonedds': 'python3-cyclonedds-pip', 'mcap': 'python3-mcap-pip',
               'foxglove-sdk': 'python3-foxglove-sdk-pip'}


def _pyproject_nodes() -> dict[str, tuple[str, str]]:
    """Executable name -> (module, node class), from pyproject.toml's social_touch.nodes group."""
    return {name: tuple(value.split(':')) for name, value in PROJECT['entry-points']['social_touch.nodes'].items()}


def _bounds(requirement: str) -> tuple[str, dict[str, str]]:
    """``'numpy>=2.0.2,<2.5  # why'`` -> ``('numpy', {'version_gte': '2.0.2', 'version_lt': '2.5'})``."""
    match = re.fullmatch(r'([A-Za-z0-9_.-]+)((?:\s*(?:>=|<)\s*[0-9.]+\s*,?)*)', requirement.strip())
    assert match, requirement
    names = {'>=': 'version_gte', '<': 'version_lt'}
    return match[1].lower(), {names[op]: version for op, version in re.findall(r'(>=|<)\s*([0-9.]+)', match[2])}


def test_package_xml_is_format_3_ament_python_with_declared_dependencies():
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.get('format') == '3' and root.findtext('name') == 'social_touch'
    assert root.find('export/build_type').text == 'ament_python'
    depends = {e.text for e in root if e.tag.endswith('depend')}
    assert {'rclpy', 'std_msgs', 'diagnostic_msgs', 'python3-numpy', 'python3-serial', 'python3-yaml',
            'python3-pytest', 'python3-hypothesis'} <= depends


def test_package_xml_is_in_step_with_pyproject():
    """Name, version, licence, description and every dependency with its bounds, in both files."""
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.findtext('name') == PROJECT['name']
    assert root.findtext('version') == PROJECT['version']
    assert root.findtext('license') == PROJECT['license']['text']
    assert ' '.join(root.findtext('description').split()) == PROJECT['description']
    stated = {e.text: {k: v for k, v in e.attrib.items() if k.startswith('version_')}
              for e in root if e.tag.endswith('depend')}
    required = dict(_bounds(line) for line in PROJECT['dependencies'])
    assert set(required) == set(ROSDEP_KEYS), 'a dependency without its rosdep key here (ROSDEP_KEYS)'
    for name, bounds in required.items():
        assert stated.get(ROSDEP_KEYS[name]) == bounds, f'package.xml: {ROSDEP_KEYS[name]} {bounds}'


def test_bounds_parse_as_written():
    assert _bounds('numpy>=2.0.2,<2.5') == ('numpy', {'version_gte': '2.0.2', 'version_lt': '2.5'})
    assert _bounds('PyYAML >= 6.0') == ('pyyaml', {'version_gte': '6.0'})


def test_the_lowest_versions_ci_installs_are_the_lower_bounds():
    """constraints/lowest.txt pins each dependency at its lower bound (CI installs both ends)."""
    pins = dict(line.split('==') for line in (ROOT / 'constraints' / 'lowest.txt').read_text().split('\n')
                if '==' in line and not line.startswith('#'))
    pins = {name.lower(): version for name, version in pins.items()}
    for name, bounds in dict(_bounds(line) for line in PROJECT['dependencies']).items():
        assert pins.get(name) == bounds['version_gte'], name


def test_setup_py_holds_only_what_colcon_needs():
    """The metadata is pyproject.toml's: setup() gets the files installed under share/ and python_requires."""
    tree = ast.parse((ROOT / 'setup.py').read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, 'id', None) == 'setup']
    assert len(calls) == 1 and {k.arg for k in calls[0].keywords} == {'data_files', 'python_requires'}
    python_requires = next(k.value.value for k in calls[0].keywords if k.arg == 'python_requires')
    assert python_requires == '>=3.10' and PROJECT['dynamic'] == ['requires-python']


def test_every_node_module_has_a_main_and_its_class():
    import importlib
    nodes = _pyproject_nodes()
    assert set(PROJECT['scripts']) == {'social-touch', *nodes}
    assert set(NODES) <= set(nodes)
    for name, (module_name, class_name) in nodes.items():
        module = importlib.import_module(module_name)
        assert callable(module.main), name
        assert isinstance(getattr(module, class_name), type), name


def test_installed_entry_points_match_pyproject():
    installed = {e.name: e.value for e in entry_points(group='social_touch.nodes')}
    assert installed == {name: f'{m}:{c}' for name, (m, c) in _pyproject_nodes().items()}, \
        'reinstall (pip install -e .) after changing pyproject.toml'
    scripts = {e.name: e.value for e in entry_points(group='console_scripts') if e.dist.name == PROJECT['name']}
    assert scripts == PROJECT['scripts']


def test_entry_points_are_only_where_another_package_plugs_in_and_load():
    """Nodes, scene generators and URL handlers: one entry point each; commands and targets are tables in code."""
    groups = PROJECT['entry-points']
    assert {'social_touch.nodes', 'social_touch.scene_generators', 'social_touch.serial_url_handlers'} == set(groups)
    for group, declared in groups.items():
        installed = {e.name: e.value for e in entry_points(group=group)}
        assert installed == declared, f'{group}: reinstall (pip install -e .) after changing pyproject.toml'
        for ep in entry_points(group=group):
            loaded = ep.load()
            if group == 'social_touch.serial_url_handlers':
                assert (Path(loaded.__file__).parent / f'protocol_{ep.name}.py').is_file(), ep
            else:
                assert callable(loaded), ep


def _tables():
    from touch_lab.cli import bench, targets
    from touch_lab.cli.main import COMMANDS
    return {'social-touch': COMMANDS, 'eval': targets.EVAL_TARGETS, 'train': targets.TRAIN_TARGETS,
            'codebook': targets.CODEBOOK_TARGETS, 'report': targets.REPORT_TARGETS, 'bench': bench.BENCHES}


def test_every_line_of_every_command_table_loads_with_a_one_line_help():
    from touch_graph.cli.main import load
    for table_name, table in _tables().items():
        for name, command in table.items():
            assert command.help and '\n' not in command.help and len(command.help) <= 120, (table_name, name)
            loaded = load(command.target)
            if table_name == 'bench':
                assert callable(loaded), (table_name, name)
            else:
                assert callable(loaded.add_arguments) and callable(loaded.run), (table_name, name)


def test_the_runtime_table_names_only_runtime_modules():
    from touch_graph.cli.main import COMMANDS
    assert all(command.target.split('.')[0] == 'touch_graph' for command in COMMANDS.values())


HELP_IMPORTS = '''
import json, sys
from touch_lab.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(json.dumps(sorted(sys.modules)))
'''


@pytest.mark.parametrize('argv', [['--help'], ['eval', '--help'], ['report', '--help']])
def test_help_imports_none_of_the_modules_it_does_not_print(argv):
    """The top-level --help and a command's list of targets read the tables, not the command modules."""
    proc = subprocess.run([sys.executable, '-c', HELP_IMPORTS, *argv], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    modules = set(json.loads(proc.stdout.splitlines()[-1]))
    targets = {command.target.split(':')[0] for table in _tables().values() for command in table.values()}
    loaded = targets & modules
    if argv[0] != '--help':
        loaded -= {'touch_lab.cli.targets'}     # the command itself, which prints its targets
    assert loaded == set()
    assert not {'numpy', 'sklearn', 'cyclonedds', 'touch_sim'} & {m.split('.')[0] for m in modules}


def test_a_target_s_help_imports_that_target_alone():
    proc = subprocess.run([sys.executable, '-c', HELP_IMPORTS, 'eval', 'bear', '--help'], capture_output=True,
                          text=True, timeout=60)
    modules = set(json.loads(proc.stdout.splitlines()[-1]))
    assert 'touch_lab.bear.cli' in modules and 'touch_lab.skin.cli' not in modules
    assert '--repeats' in proc.stdout or 'usage: social-touch eval bear' in proc.stdout


@pytest.mark.parametrize('argv', [['--help'], ['eval', '--help'], ['eval', 'bear', '--help'],
                                  ['train', 'bear', '--help'], ['train', 'patch', '--help'],
                                  ['report', 'skin', '--help'], ['bench', '--help'], ['codebook', 'record', '--help'],
                                  ['codebook', 'info', '--help'], ['report', '--help'],
                                  ['lines', '--help'],
                                  ['demo', '--help']])
def test_the_cli_is_the_one_way_in_and_every_command_explains_itself(argv, capsys):
    from touch_lab.cli.main import main
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith('usage: social-touch') and len(out.splitlines()) > 3


def test_no_module_has_its_own_entry_point_outside_the_cli():
    """No ``if __name__ == '__main__'`` and no argparse ``main()`` beside the runner and the console script."""
    offenders = []
    for path in sorted(ROOT.glob('touch_*/**/*.py')):
        text = path.read_text()
        rel = path.relative_to(ROOT).as_posix()
        if rel in ('touch_graph/cli/main.py', 'touch_lab/cli/main.py'):  # the runner and the console script
            continue
        if "__name__ == '__main__'" in text or ('ArgumentParser(' in text and '\ndef main(' in text):
            offenders.append(rel)
    assert offenders == []


def test_export_interfaces_writes_an_ament_cmake_package(tmp_path):
    package = export_interfaces(tmp_path)
    root = ET.parse(package / 'package.xml').getroot()
    assert root.findtext('name') == 'social_touch_msgs'
    assert root.findtext('member_of_group') == 'rosidl_interface_packages'
    assert {e.text for e in root.findall('depend')} == {'builtin_interfaces', 'geometry_msgs', 'std_msgs'}
    cmake = (package / 'CMakeLists.txt').read_text()
    for path in msg_files():
        assert f'"msg/{path.name}"' in cmake
        assert (package / 'msg' / path.name).read_text() == path.read_text()
    assert 'DEPENDENCIES builtin_interfaces geometry_msgs std_msgs' in cmake
    with pytest.raises(ConfigError, match='--force'):
        export_interfaces(tmp_path)
    export_interfaces(tmp_path, force=True)


@pytest.mark.slow
def test_colcon_builds_the_package_and_installs_the_executables(tmp_path):
    pytest.importorskip('colcon_core')
    pytest.importorskip('colcon_ros')
    source = tmp_path / 'src' / 'social_touch'
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        '.git', '.venv', 'build', 'install', 'log', '__pycache__', '*.egg-info', '.pytest_cache', '.ruff_cache',
        '.hypothesis'))
    result = subprocess.run([sys.executable, '-m', 'colcon', 'build', '--base-paths', 'src'], cwd=tmp_path,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    lib = tmp_path / 'install' / 'social_touch' / 'lib' / 'social_touch'
    for name in (*NODES, 'social-touch'):
        assert (lib / name).is_file(), f'{name} missing from {sorted(p.name for p in lib.iterdir())}'
    share = tmp_path / 'install' / 'social_touch' / 'share' / 'social_touch'
    assert (share / 'launch' / 'demo.launch.yaml').is_file()
    assert (share / 'config' / 'scenes' / 'bear_people.yaml').is_file()
    assert len(list((share / 'msg').glob('*.msg'))) == len(msg_files())
    assert (tmp_path / 'install' / 'social_touch' / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'social_touch').is_file()


def test_cli_doctests():
    import touch_graph.cli.main
    import touch_graph.cli.options
    check_doctests(touch_graph.cli.main)
    check_doctests(touch_graph.cli.options)


def test_lines_counts_every_layer(capsys):
    from touch_lab.cli.main import main
    assert main(['lines', '--json']) == 0
    import json
    counts = json.loads(capsys.readouterr().out)
    assert set(counts['layers']) == {'runtime', 'simulation', 'lab', 'view'}
    # Every package the distribution ships is counted in some layer.
    include = tomllib.loads((ROOT / 'pyproject.toml').read_text())['tool']['setuptools']['packages']['find']['include']
    assert sorted(counts['packages']) == sorted(pattern.rstrip('*') for pattern in include)
    assert counts['tree']['lines'] == sum(c['lines'] for c in counts['layers'].values())
    assert 0 < counts['runtime_share_lines'] < 1 and counts['tests']['files'] > 10
