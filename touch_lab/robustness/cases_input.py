"""Robustness cases: YAML a user can write, numbers typed on a command line, a full disk.

Each case is ``(area, case, callable or CLI argv)`` as in :mod:`touch_lab.robustness.cases`. A YAML
case raises the stack's error (a clear error), and is ``wrong`` when that took a second or more; a
full-disk case records on a real 200 KiB filesystem (a tmpfs this process mounts and unmounts:
needs root) and returns what was kept; one that lost something already recorded or saved raises
:class:`~touch_lab.robustness.outcomes.DataLost`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_model import SubtypeModel
from touch_gestures.bear.symbolic import GestureLibrary
from touch_gestures.skin.codebook import load_codebook, save_codebook
from touch_gestures.skin.commands import load_command_map
from touch_graph import messages
from touch_graph.bag import BagRecorder
from touch_graph.bag.player import bag_info
from touch_graph.bag.reindex import reindex
from touch_graph.cli.export_interfaces import export_interfaces
from touch_graph.errors import BagError
from touch_graph.files import write_text
from touch_graph.launch.parser import parse_launch_file
from touch_graph.paths import share_file
from touch_graph.runtime.param_yaml import ParameterOverrides

from .outcomes import DataLost

__all__ = ['input_cases']

#: How long refusing a hostile YAML file may take, s.
YAML_REFUSAL_S = 1.0


def _laughs(key: str = 'gestures', levels: int = 9) -> str:
    """The "billion laughs": 9 anchors of 9 aliases of the one before (9**9 values in ~330 bytes)."""
    names = 'abcdefghijklmnop'
    lines = [f'a: &a [{",".join(["lol"] * 9)}]']
    lines += [f'{names[i]}: &{names[i]} [{",".join(["*" + names[i - 1]] * 9)}]' for i in range(1, levels - 1)]
    lines.append(f'{key}: [{",".join(["*" + names[levels - 2]] * 9)}]')
    return '\n'.join(lines) + '\n'


YAML_TEXTS = {
    'anchors and aliases (333 bytes, 9**9 values)': _laughs(),
    'an alias inside its own anchor': 'gestures: &a [*a]\n',
    '10000 nested lists': '[' * 10_000 + ']' * 10_000 + '\n',
    '3 MB of one value': 'gestures: ' + 'x' * (3 * 1024 * 1024) + '\n',
    'bytes that are not UTF-8': '\udcff\udcfe',
}


def _loader(kind: str) -> Callable[[Path], Any]:
    """The function that reads a ``kind`` of file, its module imported (so a timing counts only the read)."""
    if kind == 'gestures:=':
        return GestureLibrary.load
    if kind == 'launch file':
        return parse_launch_file
    if kind == 'body map':
        return BodyMap.load
    if kind == 'skin commands':
        return load_command_map
    if kind == 'parameter file':
        return ParameterOverrides.from_file

    def bag(path: Path) -> Any:
        bag_dir = path.parent / 'bag'
        bag_dir.mkdir()
        (bag_dir / 'bag.mcap').write_bytes(b'\x89MCAP0\r\n')
        path.replace(bag_dir / 'metadata.yaml')
        return bag_info(bag_dir)
    return bag


def _yaml_file(kind: str, text: str) -> Callable[[], Any]:
    def load() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / 'input.yaml'
            path.write_bytes(text.encode('utf-8', 'surrogateescape'))
            read = _loader(kind)
            start = time.perf_counter()
            try:
                read(path)
            except Exception:
                if time.perf_counter() - start >= YAML_REFUSAL_S:
                    return False  # refused, but only after the expansion it must not do
                raise
        return False  # accepted: none of these files can be meant
    return load


def _typed_check_excerpt() -> Any:
    """A million-item value where a mapping is expected: the error quotes an excerpt, not the value."""
    text = 'gestures: [' + ','.join(['1'] * 50_000) + ']\nformat: [' + ','.join(['1'] * 50_000) + ']\n'
    try:
        GestureLibrary.loads(text, source='big.yaml')
    except ValueError as err:
        if len(str(err)) > 500:
            return False
        raise
    return False


YAML_KINDS = ('gestures:=', 'launch file', 'body map', 'skin commands', 'parameter file', "a bag's metadata.yaml")

#: ``social-touch`` argv with a number that can never work; each must be one usage error (exit 2).
NUMBER_ARGVS = [
    ['play', 'nowhere', '--rate', '1e308'], ['play', 'nowhere', '--rate', 'nan'], ['play', 'nowhere', '--rate', '-1'],
    ['play', 'nowhere', '--start-offset', 'inf'], ['play', 'nowhere', '--wait', '-1'],
    ['topic', 'pub', '/x', 'std_msgs/msg/String', '--rate', '0'],
    ['topic', 'pub', '/x', 'std_msgs/msg/String', '--rate', 'inf'],
    ['topic', 'pub', '/x', 'std_msgs/msg/String', '--times', '0'], ['topic', 'echo', '/x', '-n', '-1'],
    ['topic', 'echo', '/x', '--timeout', 'nan'], ['topic', 'hz', '/x', '--window', '0'],
    ['service', 'call', '/x', 'std_srvs/srv/Trigger', '--timeout', '1e308'],
    ['param', 'list', '--timeout', 'nan'], ['record', '-a', '--duration', '1e308'],
    ['launch', 'x.launch.yaml', '--rate', 'nan'], ['launch', 'x.launch.yaml', '--duration', '-1'],
    ['view', '--port', '70000'], ['view', '--rate', '1000'], ['foxglove', '--port', '-1'],
    ['foxglove', '--image-rate', 'nan'], ['demo', '--duration', '0'], ['bench', 'framing', '--repeats', '-1'],
    ['eval', 'bear', '--repetitions', '0'], ['eval', 'bear', '--seed', '-1'],
]


# ---------------------------------------------------------------------- a full disk
@contextlib.contextmanager
def small_disk(kib: int = 200) -> Iterator[Path]:
    """A real filesystem of ``kib`` KiB (tmpfs), unmounted afterwards; OSError when it cannot be mounted."""
    with tempfile.TemporaryDirectory() as tmp:
        mount = Path(tmp) / 'disk'
        mount.mkdir()
        run = subprocess.run(['mount', '-t', 'tmpfs', '-o', f'size={kib}k', 'tmpfs', str(mount)],
                             capture_output=True, text=True)
        if run.returncode != 0:
            raise OSError(f'cannot mount a {kib} KiB tmpfs (root needed): {run.stderr.strip()}')
        try:
            yield mount
        finally:
            subprocess.run(['umount', str(mount)], check=False)


def _fill_with_bag(disk: Path) -> tuple[Any, str]:
    """Record 1 kB messages on ``disk`` until it is full; the recorder and the first error it raised."""
    data = messages.serialize(messages.get_message('std_msgs/msg/String')(data='x' * 1000), 'std_msgs/msg/String')
    bag = BagRecorder(disk / 'bag', flush_period_s=None).open()
    for i in range(10_000):
        try:
            bag.write('/chatter', 'std_msgs/msg/String', 1_000 + i * 1_000_000, data)
            if i % 20 == 0:
                bag.flush()
        except BagError as err:
            with contextlib.suppress(BagError):
                bag.close()
            return bag, str(err)
    raise AssertionError('the disk never filled')


def _recorder_on_full_disk() -> Any:
    with small_disk() as disk, tempfile.TemporaryDirectory() as elsewhere:
        bag, said = _fill_with_bag(disk)
        if 'ENOSPC' not in said or 'bag reindex' not in said:
            return False
        report = reindex(disk / 'bag', Path(elsewhere) / 'bag')
        if report.message_count < bag.flushed_messages:
            raise DataLost(f'{bag.flushed_messages} messages flushed, {report.message_count} recovered')
        return (f'{said.split(";")[0]}; {bag.flushed_messages} flushed of {bag.message_count} received, '
                f'{report.message_count} recovered by reindex -o on another disk')


def _reindex_on_full_disk() -> Any:
    with small_disk() as disk:
        _fill_with_bag(disk)
        before = (disk / 'bag' / 'bag.mcap').read_bytes()
        try:
            reindex(disk / 'bag')
        except BagError:
            if (disk / 'bag' / 'bag.mcap').read_bytes() != before:
                raise DataLost('refused, but the recorded bag changed') from None
            if len(list((disk / 'bag').iterdir())) != 1:
                return False  # refused, but it left a partial file behind
            raise
    return False  # it cannot have worked: there is no room


def _reindex_command_on_full_disk() -> Any:
    with small_disk() as disk:
        _fill_with_bag(disk)
        run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                              'bag', 'reindex', str(disk / 'bag')], capture_output=True, text=True, timeout=120)
    last = (run.stderr.strip().splitlines() or [''])[-1]
    if run.returncode != 1 or 'Traceback' in run.stderr or 'ENOSPC' not in last:
        return False
    return f'exit 1: {last[:160]}'


def _enospc(*args: Any, **kwargs: Any) -> Any:
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@contextlib.contextmanager
def _patched(owner: Any, name: str) -> Iterator[None]:
    saved = getattr(owner, name)
    setattr(owner, name, _enospc)
    try:
        yield
    finally:
        setattr(owner, name, saved)


def _injected(kind: str) -> Callable[[], Any]:
    """A writer whose write meets OSError(ENOSPC): a clear error, the previous file kept, nothing partial."""
    def write() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            target = tmp / ('report.md' if kind == 'report' else 'model.npz')
            if kind == 'report':
                target.write_text('previous\n')
            elif kind != 'export-interfaces':
                shutil.copyfile(share_file('config', {'codebook': 'skin_codebook.npz', 'bear model':
                                                      'bear_subtype_model.npz'}[kind]), target)
            before = target.read_bytes() if target.exists() else None
            try:
                if kind == 'report':
                    with _patched(Path, 'write_text'):
                        write_text(target, 'new\n')
                elif kind == 'export-interfaces':
                    with _patched(Path, 'write_text'):
                        export_interfaces(tmp)
                elif kind == 'codebook':
                    recogniser = load_codebook(target)
                    with _patched(np.lib.format, 'write_array'):
                        save_codebook(target, recogniser)
                else:
                    model = SubtypeModel.load(target)
                    with _patched(np.lib.format, 'write_array'):
                        model.save(target)
            finally:
                kept = (target.read_bytes() if target.exists() else None) == before
                left = sorted(p.name for p in tmp.iterdir())
                if not kept:
                    raise DataLost(f'the previous {target.name} was not kept')
                if left != ([target.name] if before is not None else []):
                    raise AssertionError(f'something partial was left: {left}')
        return False
    return write


def input_cases() -> list[tuple[str, str, Any]]:
    """``(area, case, callable or CLI argv)`` of this module's cases."""
    cases: list[tuple[str, str, Any]] = []
    for name, text in YAML_TEXTS.items():
        kinds = YAML_KINDS if name.startswith('anchors') else ('gestures:=',)
        for kind in kinds:
            cases.append(('YAML a user writes', f'{kind}: {name}', _yaml_file(kind, text)))
    cases.append(('YAML a user writes', 'topic pub values: anchors and aliases',
                  ['topic', 'pub', '/x', 'std_msgs/msg/String', _laughs('data')]))
    cases.append(('YAML a user writes', 'a 50000-item list where a number is expected', _typed_check_excerpt))
    for argv in NUMBER_ARGVS:
        cases.append(('numbers on the command line', 'social-touch ' + ' '.join(argv), argv))
    cases += [
        ('full disk (real 200 KiB tmpfs)', 'bag recorder: the disk fills', _recorder_on_full_disk),
        ('full disk (real 200 KiB tmpfs)', 'bag reindex in place on the full disk', _reindex_on_full_disk),
        ('full disk (real 200 KiB tmpfs)', 'social-touch bag reindex on the full disk', _reindex_command_on_full_disk),
    ]
    for kind in ('report', 'codebook', 'bear model', 'export-interfaces'):
        cases.append(('full disk (ENOSPC injected)', f'{kind}: the disk fills mid-write', _injected(kind)))
    return cases
