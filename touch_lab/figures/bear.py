"""Figures of docs/bear-evaluation.md (``social-touch report bear``): synthetic people on a virtual bear."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from touch_lab.figures.markdown import figure_md
from touch_lab.figures.plots import SpeedErrorPanel, confusion_figure, speed_error_figure

__all__ = ['SYNTHETIC', 'bear_figures']

SYNTHETIC = 'simulated people (knight2009 Table II statistics) on a virtual bear read by the bear_driver node'


def _error_pct(accuracy: float | None) -> float:
    return float('nan') if accuracy is None else 100.0 * (1.0 - accuracy)


def bear_figures(out_dir: str | Path, main_result: dict, sweep: Sequence[dict], models: Sequence[dict],
                 say: Callable[[str], None] | None = None) -> dict[str, str]:
    """Draw the bear report's PNGs into ``out_dir``; returns figure key -> Markdown line.

    Args:
        main_result: :func:`touch_lab.bear.evaluate.evaluate` at the main configuration.
        sweep: rows of :func:`touch_lab.bear.report.speed_error_table`.
        models: rows of :func:`touch_lab.bear.report.compare_models`.

    Keys: ``subtype_confusion``, ``symbolic_confusion``, ``speed_error``, ``first_word`` (when the result has one).
    """
    cfg = main_result['config']
    where = f"{cfg['rate_hz']} Hz, buffer {cfg['buffer_len']}, {cfg['n_people']} test people"
    model = main_result['model']
    out = {}
    for key, part, what in (('subtype_confusion', 'subtype', 'touch subtypes per interaction'),
                            ('symbolic_confusion', 'symbolic', 'symbolic gestures')):
        labels = model[part]['labels']
        out[key] = figure_md(out_dir, f'bear-{part}-confusion.png', f'{what}: confusion matrix (synthetic)',
                             lambda path, labels=labels, part=part, what=what: confusion_figure(
                                 path, model[part]['confusion'], labels, labels,
                                 f'Bear {what}, trained model ({where})', SYNTHETIC), say)
    by_rate: dict[str, list[tuple[float, float, str]]] = {}
    for row in sweep:
        by_rate.setdefault(f"{row['rate_hz']} Hz", []).append(
            (row['subtype_latency_s'] if row['subtype_latency_s'] is not None else float('nan'),
             _error_pct(row['subtype_accuracy']), f"{row['buffer_len']} cycles"))
    panels = [SpeedErrorPanel(by_rate, 'median subtype latency from touch start, s',
                              'scan rate and buffer (trained model)', ylabel='subtype error per interaction, %')]
    if models:
        panels.append(SpeedErrorPanel({row['model']: [(row['us_per_56_sensors'], _error_pct(row['balanced_accuracy']),
                                                       '')] for row in models},
                                      'us per prediction of 56 sensors (one core)', 'subtype models',
                                      logx=True, ylabel='1 - balanced accuracy per sensor-cycle, %'))
    out['speed_error'] = figure_md(out_dir, 'bear-speed-error.png', 'bear: speed against error (synthetic)',
                                   lambda path: speed_error_figure(path, panels, 'Bear: speed against error',
                                                                   SYNTHETIC), say)
    fw = model.get('first_word')
    if fw:
        series = {name: [(t, _error_pct(a), '') for t, a in zip(fw['taus_s'], fw[key], strict=True)]
                  for name, key in (('said: latest START, else most confident CANDIDATE', 'said_accuracy'),
                                    ('decided: STARTs only', 'decided_accuracy'))}
        panel = SpeedErrorPanel(series, 'time since the gesture started, s', f'symbolic gestures ({where})',
                                ylabel='labelled gestures not (yet) said right, %')
        out['first_word'] = figure_md(out_dir, 'bear-first-word.png',
                                      'bear: error of what is said against time since onset (synthetic)',
                                      lambda path: speed_error_figure(path, [panel], 'Bear symbolic gestures: the '
                                                                      'first word against the decision', SYNTHETIC),
                                      say)
    return out
