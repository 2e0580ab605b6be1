"""Robustness: damaged model and codebook files, CLI arguments that can never work, and bear levels
outside the calibrated range are clear errors or counted skips, never tracebacks (issue 12)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_bear_node import Graph, frame

from touch_gestures.bear.features import FEATURE_NAMES
from touch_gestures.skin.codebook import load_codebook
from touch_gestures.skin.errors import CodebookError
from touch_lab.bear.subtype_training import SubtypeClassifier


def tiny_model(path: Path) -> Path:
    rng = np.random.default_rng(0)
    X = rng.random((40, len(FEATURE_NAMES)), dtype=np.float32)   # one column per bear feature
    SubtypeClassifier().fit(X, np.where(X[:, 0] < 0.5, 'none', 'hold')).save(path, rate_hz=3.4, buffer_len=20)
    return path


def damaged(source: Path, target: Path, keep: int | None) -> Path:
    data = source.read_bytes()
    target.write_bytes(b'' if keep is None else data[:keep])
    return target


# ---------------------------------------------------------------------- bear subtype model
@pytest.mark.parametrize('keep', [None, 0, 10, 200, -20])
def test_a_truncated_or_empty_bear_model_is_a_clear_error(tmp_path: Path, keep) -> None:
    model = tiny_model(tmp_path / 'model.npz')
    bad = damaged(model, tmp_path / 'bad.npz', keep)
    with pytest.raises(ValueError, match=r'bad\.npz') as caught:
        SubtypeClassifier.load(bad)
    assert 'truncated' in str(caught.value) or 'not a bear subtype model' in str(caught.value)


@pytest.mark.parametrize('key', ['mean', 'scale', 'coef', 'intercept'])
def test_a_bear_model_with_nan_parameters_is_refused_at_load(tmp_path: Path, key: str) -> None:
    model = tiny_model(tmp_path / 'model.npz')
    with np.load(model, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays[key] = np.full_like(arrays[key], np.nan)
    np.savez(tmp_path / 'nan.npz', **arrays)
    with pytest.raises(ValueError, match=f"non-finite values in '{key}'"):
        SubtypeClassifier.load(tmp_path / 'nan.npz')


def test_a_missing_bear_model_says_how_to_make_one(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match='train'):
        SubtypeClassifier.load(tmp_path / 'none.npz')


# ---------------------------------------------------------------------- skin codebook
def codebook_bytes(tmp_path: Path) -> bytes:
    """A well-formed .npz (not a codebook: the loader must fail on its content, not on its zip)."""
    np.savez(tmp_path / 'arrays.npz', format=np.array('x'), data=np.arange(1000))
    return (tmp_path / 'arrays.npz').read_bytes()


@pytest.mark.parametrize('keep', [0, 10, 300, -30])
def test_a_truncated_or_empty_codebook_is_a_clear_error(tmp_path: Path, keep: int) -> None:
    path = tmp_path / 'codebook.npz'
    path.write_bytes(codebook_bytes(tmp_path)[:keep])
    with pytest.raises(CodebookError, match=r'codebook\.npz') as caught:
        load_codebook(path)
    assert 'truncated or empty' in str(caught.value)


@settings(max_examples=30, deadline=None)
@given(st.binary(max_size=400))
def test_any_bytes_as_a_codebook_give_a_codebook_error(tmp_path_factory, data: bytes) -> None:
    path = tmp_path_factory.mktemp('cb') / 'codebook.npz'
    path.write_bytes(data)
    with pytest.raises(CodebookError):
        load_codebook(path)


# ---------------------------------------------------------------------- CLI arguments
@pytest.mark.parametrize('argv', [
    ['record', '-a', '--duration', '0'], ['record', '-a', '--flush-period', '0'], ['record', '-a', '--duration', 'nan'],
    ['play', 'nowhere', '--rate', '0'], ['play', 'nowhere', '--rate', '-1'],
])
def test_cli_arguments_that_can_never_work_are_usage_errors(tmp_path: Path, argv: list[str]) -> None:
    run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                          *argv], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    assert 'expected a number' in run.stderr and 'Traceback' not in run.stderr
    assert not any(tmp_path.iterdir())            # nothing recorded, no empty bag left behind


# ---------------------------------------------------------------------- bear_gestures levels
@pytest.mark.parametrize('level', [3e38, 1.0001, -0.5, np.float32(np.finfo(np.float32).max)])
def test_a_level_outside_the_calibrated_range_is_counted_never_a_touch(level: float) -> None:
    g = Graph(subtype_classifier='rule')
    try:
        head = 5
        bad = [frame(i, on={head: level}) for i in range(1, 8)]    # 2 s of an impossible level
        g.update([frame(0), *bad, frame(8)])
        assert g.node.skipped == {'out_of_range': 7}
        assert g.node.frames == 2 and not g.got['subtype'] and not g.got['symbolic']
    finally:
        g.close()
