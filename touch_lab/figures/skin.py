"""Figures of docs/skin-evaluation.md (``social-touch report skin``): traces through the virtual skin.

The traces are real ($1 unistroke logs); the sensor frames they become are synthetic (the virtual
skin read by the skin_driver node). Every figure says so.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from touch_gestures.skin.gesture import ACTIVE_MM, TouchGesture
from touch_lab.figures.markdown import figure_md
from touch_lab.figures.plots import (
    SpeedErrorPanel,
    confusion_figure,
    matrix_from_nested,
    speed_error_figure,
    traces_figure,
)
from touch_sim.skin.render import RenderSettings, render_sample
from touch_sim.skin.traces import TraceSample

__all__ = ['SYNTHETIC', 'example_traces', 'skin_figures']

SYNTHETIC = 'sensor frames simulated by the virtual skin (skin_driver node) from real traces'


def _path(gestures: list[TouchGesture]) -> np.ndarray | None:
    """(n, 2) contact points in mm of every gesture cut from one sample, in order; None if none was cut."""
    points = [g.trajectory for g in gestures if len(g.trajectory)]
    return np.concatenate(points).astype(np.float64) if points else None


def example_traces(samples: Sequence[TraceSample], seed: int = 0
                   ) -> list[tuple[str, np.ndarray, np.ndarray | None]]:
    """The first sample of each gesture, before the sensor and through it.

    Returns:
        [(gesture, (n, 2) true finger path in mm, (m, 2) contact points the skin reported in mm
        or None)], gestures sorted by name. "Before" is the evaluation's ``direct`` mode (the
        finger's true position at 150 Hz, same placement), "after" its ``sensor`` mode.
    """
    first: dict[str, TraceSample] = {}
    for s in samples:
        first.setdefault(s.gesture, s)
    out = []
    for i, name in enumerate(sorted(first)):
        before = _path(render_sample(first[name], RenderSettings(mode='direct', seed=seed), seed=seed + i))
        after = _path(render_sample(first[name], RenderSettings(mode='sensor', seed=seed), seed=seed + i))
        out.append((name, before if before is not None else np.zeros((0, 2)), after))
    return out


def skin_figures(out_dir: str | Path, report: dict, samples: Sequence[TraceSample],
                 speed_points: Sequence[tuple[str, int, int | None, float, float]],
                 say: Callable[[str], None] | None = None) -> dict[str, str]:
    """Draw the skin report's PNGs into ``out_dir``; returns figure key -> Markdown line.

    Args:
        report: :func:`touch_lab.skin.cli.evaluate_file` (through the skin, and before it).
        samples: the traces evaluated (one example per gesture is drawn).
        speed_points: (recogniser, resample length, templates per gesture or None for all,
            accuracy, us per recognition) of the speed-against-error sweep.

    Keys: ``confusion``, ``speed_error``, ``traces``.
    """
    best = report['best']
    out = {}
    rows, cols, counts = matrix_from_nested(report['recognisers'][best]['confusion'])
    out['confusion'] = figure_md(
        out_dir, 'skin-confusion.png', f'skin commands: confusion matrix of {best} (synthetic sensor)',
        lambda path: confusion_figure(path, counts, rows, cols, f'Skin gestures through the skin: {best}, '
                                      'leave-one-subject-out, nearest class', SYNTHETIC, 'traced gesture',
                                      'recognised'), say)
    sweep: dict[str, list] = {}
    for name, n, m, accuracy, us in speed_points:
        sweep.setdefault(f"{name}, {'all' if m is None else m} templates", []).append((us, 100 * (1 - accuracy),
                                                                                       f'{n}'))
    panels = [SpeedErrorPanel(sweep, 'us per recognition (median, one core)', 'resample length (labels)', logx=True,
                              ylabel='wrong nearest class, %')] if sweep else []
    panels.append(SpeedErrorPanel({name: [(r['us_per_recognition'], 100 * (1 - r['accuracy']), '')]
                                   for name, r in report['recognisers'].items()},
                                  'us per recognition (median, one core)', 'recognisers, all templates', logx=True,
                                  ylabel='wrong nearest class, %'))
    out['speed_error'] = figure_md(out_dir, 'skin-speed-error.png', 'skin: speed against error (synthetic sensor)',
                                   lambda path: speed_error_figure(path, panels, 'Skin recognisers: speed against '
                                                                   'error, through the skin', SYNTHETIC), say)
    out['traces'] = figure_md(
        out_dir, 'skin-traces.png', 'one trace per gesture before and after the sensor (synthetic sensor)',
        lambda path: traces_figure(path, example_traces(samples), ACTIVE_MM, 'One trace per gesture: the finger '
                                   'on the skin and what the skin reports', SYNTHETIC + '; grey: true finger path',
                                   'true finger path (before the sensor)', 'contact points the skin reports'), say)
    return out
