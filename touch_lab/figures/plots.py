"""The figure kinds of the reports: confusion matrix, speed against error, posteriors over time, traces.

Each function takes plain arrays and lists (what the evaluations return), draws one PNG with
:mod:`.png` and returns its path. Data that cannot make the figure (nothing to draw, shapes that
do not agree) raises :class:`~touch_lab.figures.png.FigureInputError` saying what is wrong; odd but
valid data is drawn and marked (a class never predicted is an empty column, a class never true
a row of dashes, NaN points are left out and counted in the title).
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D

from touch_lab.figures.png import FigureInputError, drawing, note_synthetic, save_png

__all__ = ['SpeedErrorPanel', 'confusion_figure', 'matrix_from_nested', 'posteriors_figure',
           'speed_error_figure', 'traces_figure']

#: Class colours (matplotlib's tab10), the same class keeps its colour within a figure.
COLOURS = ('#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f',
           '#bcbd22', '#17becf')


def _colour(i: int) -> str:
    return COLOURS[i % len(COLOURS)]


def _wrap(text: str, width: int) -> str:
    return '\n'.join(textwrap.wrap(text, width))


def matrix_from_nested(nested: Mapping[str, Mapping[str, int]]) -> tuple[list[str], list[str], np.ndarray]:
    """``{row: {column: count}}`` -> (row labels, column labels in first-seen order, (R, K) int64 counts)."""
    rows = list(nested)
    cols: list[str] = []
    for row in nested.values():
        cols += [c for c in row if c not in cols]
    counts = np.array([[int(nested[r].get(c, 0)) for c in cols] for r in rows], dtype=np.int64).reshape(len(rows),
                                                                                                     len(cols))
    return rows, cols, counts


def confusion_figure(path: str | Path, counts: np.ndarray | Sequence[Sequence[int]], true_labels: Sequence[str],
                     predicted_labels: Sequence[str], title: str, synthetic: str | None,
                     true_axis: str = 'true', predicted_axis: str = 'predicted') -> Path:
    """A confusion matrix: colour = share of the row (recall per true class), text = counts.

    Args:
        counts: (R, K) non-negative counts, rows = true classes, columns = predicted ones (K may
            differ from R: e.g. a "not recognised" column).
        synthetic: what is synthetic about the data (printed on the figure), None for real data.

    Raises:
        FigureInputError: shapes that do not match the labels, negative or non-finite counts, or
            no counts at all.
    """
    c = np.asarray(counts, dtype=np.float64)
    if c.ndim != 2 or c.shape != (len(true_labels), len(predicted_labels)):
        raise FigureInputError(f'{title}: confusion counts of shape {c.shape} do not match '
                               f'{len(true_labels)} true x {len(predicted_labels)} predicted labels')
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise FigureInputError(f'{title}: confusion counts must be finite and non-negative')
    if c.sum() == 0:
        raise FigureInputError(f'{title}: the confusion matrix is empty (no samples were scored)')
    totals = c.sum(axis=1, keepdims=True)
    share = np.divide(c, totals, out=np.full_like(c, np.nan), where=totals > 0)  # a class never true: NaN row
    n_rows, n_cols = c.shape
    side = max(4.2, 1.6 + 0.42 * max(n_rows, n_cols))
    with drawing(min(side + 1.4, 9.0), min(side, 8.0)) as fig:
        ax = fig.add_subplot()
        image = ax.imshow(np.ma.masked_invalid(share), vmin=0.0, vmax=1.0, cmap='Blues', aspect='auto')
        small = 7 if max(n_rows, n_cols) > 10 else 8
        for i in range(n_rows):
            for j in range(n_cols):
                text = '-' if totals[i, 0] == 0 else f'{int(c[i, j])}'
                if text == '0':
                    continue
                dark = share[i, j] > 0.6 if totals[i, 0] else False
                ax.text(j, i, text, ha='center', va='center', fontsize=small, color='white' if dark else 'black')
        ax.set_xticks(range(n_cols), [str(x) for x in predicted_labels], rotation=45, ha='right')
        ax.set_yticks(range(n_rows), [str(x) for x in true_labels])
        ax.set_xlabel(predicted_axis)
        ax.set_ylabel(true_axis)
        never = [str(predicted_labels[j]) for j in range(n_cols) if c[:, j].sum() == 0]
        ax.set_title(_wrap(title, 60) + (f'\nnever {predicted_axis}: {", ".join(never)}' if never else ''))
        fig.colorbar(image, ax=ax, shrink=0.8, label='share of the true class (row)')
        if synthetic:
            note_synthetic(fig, synthetic)
        return save_png(fig, path)


class SpeedErrorPanel:
    """One panel of a speed-against-error figure: named series of (cost, error %, point label).

    Attributes:
        series: name -> [(x, error_percent, label)], drawn as a line through its points in the
            given order (a single point is a marker); label may be ''.
        xlabel: what x is, with its unit (e.g. "median detection latency, s").
        title: the panel's title. logx: log-scaled x (for costs spanning decades).
    """

    def __init__(self, series: Mapping[str, Sequence[tuple[float, float, str]]], xlabel: str, title: str,
                 logx: bool = False, ylabel: str = 'error, %') -> None:
        self.series = {k: list(v) for k, v in series.items()}
        self.xlabel, self.title, self.logx, self.ylabel = xlabel, title, logx, ylabel


def speed_error_figure(path: str | Path, panels: Sequence[SpeedErrorPanel], title: str, synthetic: str | None
                       ) -> Path:
    """Speed (cost or latency) against error, one panel per comparison, lower left is better.

    Raises:
        FigureInputError: no panel, or a panel without a single finite point.
    """
    if not panels:
        raise FigureInputError(f'{title}: no panels to draw')
    with drawing(5.0 * len(panels) + 0.5, 4.2) as fig:
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
        for ax, panel in zip(axes, panels, strict=True):
            dropped = 0
            drawn = 0
            for i, (name, points) in enumerate(panel.series.items()):
                good = [(x, y, lab) for x, y, lab in points if math.isfinite(x) and math.isfinite(y)
                        and (x > 0 or not panel.logx)]
                dropped += len(points) - len(good)
                if not good:
                    continue
                xs, ys = [p[0] for p in good], [p[1] for p in good]
                ax.plot(xs, ys, marker='o', ms=4, lw=1.2, color=_colour(i), label=name)
                for x, y, lab in good:
                    if lab:
                        ax.annotate(lab, (x, y), textcoords='offset points', xytext=(4, 3), fontsize=7,
                                    color=_colour(i))
                drawn += len(good)
            if drawn == 0:
                raise FigureInputError(f'{title}: panel "{panel.title}" has no finite point to draw')
            if panel.logx:
                ax.set_xscale('log')
            ax.set_xlabel(panel.xlabel)
            ax.set_ylabel(panel.ylabel)
            ax.set_title(_wrap(panel.title, 60) + (f' ({dropped} points without a value left out)' if dropped else ''))
            ax.grid(True, lw=0.4, alpha=0.5)
            ax.legend(loc='best', frameon=False)
        fig.suptitle(_wrap(title, 100))
        if synthetic:
            note_synthetic(fig, synthetic)
        return save_png(fig, path)


def posteriors_figure(path: str | Path, times_s: np.ndarray, log_posteriors: np.ndarray, classes: Sequence[str],
                      truth: Sequence[tuple[float, float, str]], detections: Sequence[tuple[float, str]],
                      threshold: float, title: str, synthetic: str | None) -> Path:
    """Class posteriors over time with the true gestures shaded and the detected events marked
    (the shape of sympartner2018 Fig. 7).

    Args:
        times_s: (T,) frame times, s, increasing.
        log_posteriors: (T, C) natural-log posteriors (rows need not be normalised: they are,
            in the log domain); a row without a finite value is a gap in the lines.
        truth: (onset_s, offset_s, class) of each performed gesture.
        detections: (time_s, class) of each event the detector sent.
        threshold: the event rule's posterior threshold (drawn as a dashed line).

    Raises:
        FigureInputError: no frames (an empty window), or shapes that do not agree.
    """
    t = np.asarray(times_s, dtype=np.float64)
    lp = np.asarray(log_posteriors, dtype=np.float64)
    if t.size == 0 or lp.size == 0:
        raise FigureInputError(f'{title}: no frames to draw (empty window)')
    if lp.ndim != 2 or lp.shape != (t.size, len(classes)):
        raise FigureInputError(f'{title}: log posteriors of shape {lp.shape} do not match {t.size} frames x '
                               f'{len(classes)} classes')
    finite = np.where(np.isfinite(lp), lp, -np.inf)
    top = finite.max(axis=1, keepdims=True)
    ok = np.isfinite(top[:, 0])
    shifted = np.exp(finite - np.where(ok[:, None], top, 0.0))
    post = np.full_like(lp, np.nan)
    post[ok] = shifted[ok] / shifted[ok].sum(axis=1, keepdims=True)  # sum >= 1 where ok: the top term is exp(0)
    index = {str(c): i for i, c in enumerate(classes)}
    with drawing(10.0, 3.8) as fig:
        ax = fig.add_subplot()
        for on, off, name in truth:
            ax.axvspan(on, max(off, on + 1e-3), color=_colour(index.get(str(name), len(classes))), alpha=0.15, lw=0)
        for i, name in enumerate(classes):
            ax.plot(t, post[:, i], lw=1.1, color=_colour(i), label=f'p({name} | window)')
        ax.axhline(threshold, color='0.3', lw=0.8, ls='--', label=f'threshold {threshold:g}')
        for when, name in detections:
            colour = _colour(index.get(str(name), len(classes)))
            ax.axvline(when, color=colour, lw=1.0, ls=':')
            ax.annotate(str(name), (when, 1.02), xycoords=('data', 'axes fraction'), rotation=90, fontsize=7,
                        color=colour, ha='center', va='bottom')
        ax.set_xlim(float(t[0]), float(t[-1]))
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel('time, s')
        ax.set_ylabel('posterior')
        gaps = '' if ok.all() else f' ({int((~ok).sum())} frames without a posterior)'
        ax.set_title(_wrap(title, 110) + gaps, pad=28)
        ax.legend(loc='center left', bbox_to_anchor=(1.0, 0.5), frameon=False)
        if synthetic:
            note_synthetic(fig, synthetic + '; shaded: performed gesture, dotted: detected event')
        return save_png(fig, path)


def traces_figure(path: str | Path, examples: Sequence[tuple[str, np.ndarray, np.ndarray | None]],
                  extent_mm: float, title: str, synthetic: str | None, before: str = 'before the sensor',
                  after: str = 'what the skin reports') -> Path:
    """One small panel per gesture: the trace before the sensor and what the sensor reported, in mm.

    Args:
        examples: (gesture name, (n, 2) path before the sensor in mm, (m, 2) contact points the
            sensor reported in mm or None when the segmenter cut no gesture from the frames).
        extent_mm: side of the sensing area, mm (the axes show 0..extent_mm).

    Raises:
        FigureInputError: no examples, or a path that is not (n, 2).
    """
    if not examples:
        raise FigureInputError(f'{title}: no example traces to draw')
    n = len(examples)
    cols = min(n, 4 if n <= 8 else 8)
    rows = math.ceil(n / cols)
    with drawing(1.5 * cols + 0.3, 1.55 * rows + 0.9) as fig:
        axes = fig.subplots(rows, cols, squeeze=False)
        for k, ax in enumerate(axes.flat):
            ax.set_xticks([])
            ax.set_yticks([])
            if k >= n:
                ax.set_axis_off()
                continue
            name, raw, seen = examples[k]
            raw = np.asarray(raw, dtype=np.float64)
            if raw.ndim != 2 or raw.shape[1] != 2:
                raise FigureInputError(f'{title}: the trace of {name} has shape {raw.shape}, not (n, 2)')
            ax.plot(raw[:, 0], raw[:, 1], color='0.55', lw=2.4, alpha=0.7, solid_capstyle='round')
            if len(raw):
                ax.plot(raw[0, 0], raw[0, 1], 'o', color='0.35', ms=3)
            if seen is None or len(seen) == 0:
                ax.text(0.5, 0.08, 'no gesture cut', transform=ax.transAxes, ha='center', fontsize=7, color='#d62728')
            else:
                seen = np.asarray(seen, dtype=np.float64)
                ax.plot(seen[:, 0], seen[:, 1], '.-', color='#d62728', lw=0.8, ms=2.0)
            ax.set_xlim(0, extent_mm)
            ax.set_ylim(extent_mm, 0)  # rows grow downwards, as on the skin's map
            ax.set_aspect('equal')
            ax.set_title(str(name), fontsize=8)
        handles = [Line2D([], [], color='0.55', lw=2.4, alpha=0.7, label=before),
                   Line2D([], [], color='#d62728', marker='.', lw=0.8, ms=2.0, label=after)]
        fig.legend(handles=handles, loc='outside lower right', ncols=2, frameon=False)
        fig.suptitle(title)
        if synthetic:
            note_synthetic(fig, synthetic)
        return save_png(fig, path)
