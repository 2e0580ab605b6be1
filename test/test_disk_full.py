"""Writers that meet a full disk: a clear error naming ENOSPC, what was kept, what to do; nothing lost.

The bag recorder and ``bag reindex`` (the recovery the recorder recommends) run on a real small
filesystem (a tmpfs of 200 KiB, mounted and unmounted here); reports, models, codebooks and
export-interfaces get an OSError(ENOSPC) injected at their write.
"""

from __future__ import annotations

import errno
import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from touch_graph import messages
from touch_graph.bag import BagRecorder
from touch_graph.bag.player import bag_info, open_reader
from touch_graph.bag.reindex import reindex
from touch_graph.errors import BagError
from touch_graph.files import DiskFullError, write_text

STRING = 'std_msgs/msg/String'


@pytest.fixture
def small_disk(tmp_path):
    """A real 200 KiB filesystem (tmpfs), unmounted afterwards."""
    mount = tmp_path / 'disk'
    mount.mkdir()
    if shutil.which('mount') is None:
        pytest.skip('no mount command: cannot make a small filesystem here')
    run = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=200k', 'tmpfs', str(mount)],
                         capture_output=True, text=True)
    if run.returncode != 0:
        pytest.skip(f'cannot mount a 200 KiB tmpfs here (needs root): {run.stderr.strip()}')
    try:
        yield mount
    finally:
        subprocess.run(['umount', str(mount)], check=True)


def record_until_full(path: Path, flush_every: int = 20) -> tuple[BagRecorder, list[str]]:
    """Write 1 kB messages until the disk is full and 50 more after; the errors raised."""
    data = messages.serialize(messages.get_message(STRING)(data='x' * 1000), STRING)
    bag = BagRecorder(path, flush_period_s=None).open()
    errors: list[str] = []
    i = 0
    while len(errors) < 50:
        try:
            bag.write('/chatter', STRING, 1_000 + i * 1_000_000, data)
            if i % flush_every == 0:
                bag.flush()
        except BagError as err:
            errors.append(str(err))
        i += 1
        assert i < 10_000, 'the disk never filled'
    return bag, errors


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_recorder_on_a_full_disk_stops_says_what_was_kept_and_loses_nothing_flushed(small_disk, tmp_path):
    bag, errors = record_until_full(small_disk / 'bag')
    first = errors[0]
    assert first.startswith('ENOSPC: no space left') and 'recording stopped' in first
    assert f'at least the {bag.flushed_messages} flushed' in first and 'bag reindex' in first and ' -o ' in first
    assert bag.full is not None and bag.dropped >= 49
    size = (small_disk / 'bag' / 'bag.mcap').stat().st_size
    with pytest.raises(BagError, match='ENOSPC'):
        bag.close()
    # Nothing more reached the file after the disk was full (no bytes after a torn chunk).
    assert (small_disk / 'bag' / 'bag.mcap').stat().st_size == size
    # In place, reindex has no room: refused before it writes, the bag untouched, nothing left behind.
    before = digest(small_disk / 'bag' / 'bag.mcap')
    with pytest.raises(BagError, match='ENOSPC') as refused:
        reindex(small_disk / 'bag')
    assert 'Nothing of the bag was changed' in str(refused.value) and '-o OTHER_DIR/bag' in str(refused.value)
    assert digest(small_disk / 'bag' / 'bag.mcap') == before
    assert sorted(p.name for p in (small_disk / 'bag').iterdir()) == ['bag.mcap']
    # On another disk, every flushed message comes back, readable.
    report = reindex(small_disk / 'bag', tmp_path / 'rebuilt')
    assert report.message_count >= bag.flushed_messages > 0
    assert bag_info(tmp_path / 'rebuilt')['messages'] == report.message_count
    reader = open_reader(tmp_path / 'rebuilt')
    try:
        texts = [messages.deserialize(raw, STRING).data for _, _, raw in reader.messages()]
    finally:
        reader.close()
    assert len(texts) == report.message_count and set(texts) == {'x' * 1000}


def test_the_reindex_command_on_a_full_disk_is_one_clear_error(small_disk):
    bag, _ = record_until_full(small_disk / 'bag')
    with pytest.raises(BagError):
        bag.close()
    run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                          'bag', 'reindex', str(small_disk / 'bag')], capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and 'Traceback' not in run.stderr
    assert 'ENOSPC' in run.stderr and 'Nothing of the bag was changed' in run.stderr


def test_a_disk_that_fills_during_reindex_leaves_the_bag_as_it_was(small_disk, monkeypatch):
    """The free-space check passes (a lying disk_usage), the rewrite then meets the real ENOSPC."""
    bag, _ = record_until_full(small_disk / 'bag')
    with pytest.raises(BagError):
        bag.close()
    target = small_disk / 'bag'
    before = digest(target / 'bag.mcap')

    class Plenty:
        free = 1 << 40
    monkeypatch.setattr(shutil, 'disk_usage', lambda path: Plenty())
    with pytest.raises(BagError, match='ENOSPC') as err:
        reindex(target)
    assert 'Nothing of the bag was changed' in str(err.value)
    assert digest(target / 'bag.mcap') == before
    assert sorted(p.name for p in target.iterdir()) == ['bag.mcap']


def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, 'No space left on device')


def test_a_report_on_a_full_disk_keeps_the_previous_one(tmp_path, monkeypatch):
    report = tmp_path / 'report.md'
    write_text(report, 'the previous report\n')
    monkeypatch.setattr(Path, 'write_text', _enospc)
    with pytest.raises(DiskFullError, match='ENOSPC') as err:
        write_text(report, 'the new report\n')
    assert 'the previous report.md is unchanged' in str(err.value)
    monkeypatch.undo()
    assert report.read_text() == 'the previous report\n'
    assert [p.name for p in tmp_path.iterdir()] == ['report.md']


@pytest.mark.parametrize('writer', ['codebook', 'bear model', 'patch model', 'model card'])
def test_a_model_or_codebook_on_a_full_disk_keeps_the_previous_one(tmp_path, monkeypatch, writer):
    from touch_graph.paths import share_file
    shipped = {'codebook': 'skin_codebook.npz', 'bear model': 'bear_subtype_model.npz',
               'patch model': 'patch_gestures.npz', 'model card': 'patch_gestures.npz'}[writer]
    path = tmp_path / 'model.npz'
    shutil.copyfile(share_file('config', shipped), path)
    before = digest(path)

    def save():
        if writer == 'codebook':
            from touch_gestures.skin.codebook import load_codebook, save_codebook
            save_codebook(path, load_codebook(path))
        elif writer == 'bear model':
            from touch_gestures.bear.subtype_model import SubtypeModel
            SubtypeModel.load(path).save(path)
        elif writer == 'patch model':
            from touch_gestures.patch.model_io import load_model, save_model
            save_model(path, load_model(path))
        else:
            from touch_gestures.model_card import attach_card
            attach_card(path, {'note': 'x'})
    monkeypatch.setattr(np.lib.format, 'write_array', _enospc)
    with pytest.raises(DiskFullError, match='ENOSPC'):
        save()
    monkeypatch.undo()
    assert digest(path) == before
    assert [p.name for p in tmp_path.iterdir()] == ['model.npz']


def test_export_interfaces_on_a_full_disk_leaves_no_half_package(tmp_path, monkeypatch):
    from touch_graph.cli.export_interfaces import export_interfaces
    monkeypatch.setattr(Path, 'write_text', _enospc)
    with pytest.raises(DiskFullError, match='ENOSPC'):
        export_interfaces(tmp_path)
    assert list(tmp_path.iterdir()) == []
