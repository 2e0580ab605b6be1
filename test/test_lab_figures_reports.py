"""Each report command writes its PNGs next to its Markdown and references them (small configurations).

The measurements are the real ones, made smaller: fewer simulated people, fewer settings, shorter
benchmarks (the full sizes take minutes to a quarter of an hour each: ``social-touch report ...``).
"""

from __future__ import annotations

import argparse
import functools
import re
from pathlib import Path

import pytest
from figures_testing import assert_report_png

from touch_lab.bear import report as bear_report
from touch_lab.bear import transfer as bear_transfer
from touch_lab.bear.evaluate import EvalConfig
from touch_lab.cli.main import main as social_touch
from touch_lab.patch import report as patch_report
from touch_lab.skin import report as skin_report
from touch_lab.skin.datasets import write_traces
from touch_sim.skin.synthetic import synthetic_traces

pytestmark = pytest.mark.slow

#: Subtype models of the bear report quick enough to fit in a test.
FAST_MODELS = ('logistic regression (ours, SubtypeClassifier)', 'paper rule (Table II defaults)',
               'Gaussian naive Bayes')


def assert_figures_referenced(markdown: Path, expected: set[str]) -> None:
    """Every expected PNG exists beside ``markdown``, is a valid report figure and is shown by it."""
    text = markdown.read_text(encoding='utf-8')
    shown = set(re.findall(r'!\[[^\]]+\]\(([^)]+\.png)\)', text))
    assert 'not drawn' not in text
    assert shown == expected, (shown, expected)
    for name in expected:
        assert_report_png(markdown.parent / name)
    assert {p.name for p in markdown.parent.glob('*.png')} >= expected


def _smaller(function, **sizes):
    """``function`` with some keyword arguments forced smaller, whatever the caller passes."""
    @functools.wraps(function)
    def call(*args, **kwargs):
        return function(*args, **{**kwargs, **sizes})
    return call


def test_report_patch_writes_and_shows_its_figures(tmp_path, monkeypatch):
    monkeypatch.setattr(patch_report, 'bench_frame', _smaller(patch_report.bench_frame, repeats=1, frames=100,
                                                              sklearn_frames=10, train_people=2, train_events=2))
    out = tmp_path / 'docs' / 'patch-evaluation.md'
    patch_report.write_report(out, people=2, events=2, windows_s=(3.0,), components=(2,), say=lambda _: None)
    assert_figures_referenced(out, {'patch-event-confusion.png', 'patch-sample-confusion.png',
                                    'patch-posteriors.png', 'patch-speed-error.png'})
    assert 'SYNTHETIC' in out.read_text(encoding='utf-8')


def test_report_bear_writes_and_shows_its_figures(tmp_path, monkeypatch):
    evaluate = bear_report.evaluate
    small = {'n_people': 1, 'train_people': 2, 'subtype_reps': 1, 'gesture_reps': 1, 'seed': 3}
    monkeypatch.setattr(bear_report, 'evaluate', lambda config, progress=None, model=None: evaluate(EvalConfig(
        rate_hz=config.rate_hz, buffer_len=config.buffer_len, **small), model=model))
    cross_population = bear_transfer.cross_population
    monkeypatch.setattr(bear_transfer, 'cross_population', lambda config, models=None, progress=None: cross_population(
        EvalConfig(rate_hz=config.rate_hz, buffer_len=config.buffer_len, **small), models))
    monkeypatch.setattr(bear_report, 'bench_cycle', _smaller(bear_report.bench_cycle, repeats=1, cycles=20))
    monkeypatch.setattr(bear_report, 'compare_models', _smaller(bear_report.compare_models, train_people=1,
                                                                test_people=1, only=FAST_MODELS))
    speed_error_table = bear_report.speed_error_table
    monkeypatch.setattr(bear_report, 'speed_error_table',
                        lambda _rates, buffers, **kwargs: speed_error_table((3.4,), buffers, **kwargs))
    monkeypatch.setattr(bear_report, 'gap_sweep', _smaller(bear_report.gap_sweep, n_people=1, rates=(3.4,),
                                                           gaps=(1.0,)))
    monkeypatch.setattr(bear_report, 'alias_table', _smaller(bear_report.alias_table, freqs=(1.0,)))
    assert social_touch(['report', 'bear', '--quick', '--out-dir', str(tmp_path)]) == 0
    assert_figures_referenced(tmp_path / 'bear-evaluation.md', {'bear-subtype-confusion.png',
                                                                 'bear-symbolic-confusion.png', 'bear-speed-error.png',
                                                                 'bear-first-word.png'})
    assert 'the first word' in (tmp_path / 'bear-evaluation.md').read_text(encoding='utf-8')


def test_report_skin_writes_and_shows_its_figures(tmp_path, monkeypatch):
    monkeypatch.setenv('HOME', str(tmp_path))           # the render cache (~/.cache) of this test only
    shapes = ('line_right', 'line_left', 'diagonal_down')
    traces = tmp_path / 'traces.csv'
    write_traces(traces, synthetic_traces(shapes, performers=2, repetitions=2, seed=4))
    monkeypatch.setattr(skin_report, 'SYNTHETIC_SETS', {'three lines': shapes})
    monkeypatch.setattr(skin_report, 'CONDITIONS', {'default': {}})
    random_touches = skin_report.random_touches
    monkeypatch.setattr(skin_report, 'random_touches', lambda _count, **kwargs: random_touches(6, **kwargs))
    monkeypatch.setattr(skin_report, 'evaluate_file', _smaller(skin_report.evaluate_file, random_count=6))
    monkeypatch.setattr(skin_report, 'bench_recognition', _smaller(skin_report.bench_recognition, repeats=1,
                                                                   queries=4, templates_per_gesture=3))
    out = tmp_path / 'docs' / 'skin-evaluation.md'
    skin_report.run(argparse.Namespace(traces=str(traces), output=str(out), quick=True))
    assert_figures_referenced(out, {'skin-confusion.png', 'skin-speed-error.png', 'skin-traces.png'})
