"""Report figures (touch_lab.figures): valid PNGs of the promised size, stable bytes, clear errors on hard input.

The report commands' own tests (they write their PNGs next to the Markdown and reference them)
are in test_lab_figures_reports.py; here the figure kinds on hand-made data.
"""

from __future__ import annotations

import numpy as np
import pytest
from figures_testing import assert_report_png

from touch_lab.figures.markdown import figure_md
from touch_lab.figures.plots import (
    SpeedErrorPanel,
    confusion_figure,
    matrix_from_nested,
    posteriors_figure,
    speed_error_figure,
    traces_figure,
)
from touch_lab.figures.png import DPI, FigureInputError


def test_a_confusion_matrix_with_a_class_never_predicted_and_one_never_true(tmp_path):
    path = confusion_figure(tmp_path / 'c.png', [[5, 1, 0], [0, 3, 0], [0, 0, 0]], ['a', 'b', 'c'], ['a', 'b', 'c'],
                            'hard input', 'made by hand')
    info = assert_report_png(path)
    # fixed size and dpi (no tight bounding box): 5.6 x 4.2 in for up to six classes, whatever the labels say
    assert (info['width'], info['height']) == (round(5.6 * DPI), round(4.2 * DPI))


def test_the_same_data_gives_the_same_bytes(tmp_path):
    a = confusion_figure(tmp_path / 'a.png', [[2, 1], [0, 4]], ['x', 'y'], ['x', 'y'], 'stable', 'made by hand')
    b = confusion_figure(tmp_path / 'b.png', [[2, 1], [0, 4]], ['x', 'y'], ['x', 'y'], 'stable', 'made by hand')
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.parametrize('counts, true, pred, message', [
    ([[0, 0], [0, 0]], ['a', 'b'], ['a', 'b'], 'empty'),
    ([[1, 2, 3]], ['a', 'b'], ['a', 'b'], 'do not match'),
    (np.zeros((0, 0)), [], [], 'empty'),
    ([[1, float('nan')], [0, 1]], ['a', 'b'], ['a', 'b'], 'finite'),
    ([[1, -1], [0, 1]], ['a', 'b'], ['a', 'b'], 'non-negative'),
])
def test_a_confusion_matrix_that_cannot_be_drawn_says_why(tmp_path, counts, true, pred, message):
    with pytest.raises(FigureInputError, match=message):
        confusion_figure(tmp_path / 'x.png', counts, true, pred, 'bad', None)
    assert not (tmp_path / 'x.png').exists()


def test_matrix_from_nested_keeps_columns_only_some_rows_have():
    rows, cols, counts = matrix_from_nested({'a': {'a': 3, 'b': 1}, 'b': {'b': 2, '<segmentation>': 1}})
    assert rows == ['a', 'b'] and cols == ['a', 'b', '<segmentation>']
    assert counts.tolist() == [[3, 1, 0], [0, 2, 1]]


def test_posteriors_over_time_with_gaps_and_unnormalised_rows(tmp_path):
    t = np.arange(200) / 20.0
    lp = np.log(np.full((200, 4), 0.25))
    lp[40:80, 2] = 5.0                      # not normalised: the figure normalises in the log domain
    lp[100:110] = np.nan                    # frames without a posterior: gaps, counted in the title
    lp[120:130] = -np.inf
    path = posteriors_figure(tmp_path / 'p.png', t, lp, ['push', 'slap', 'stroke', 'tickle'],
                             [(2.0, 3.5, 'stroke'), (6.0, 7.0, 'not a class')], [(2.4, 'stroke'), (9.0, 'odd')],
                             0.99, 'hard input', 'made by hand')
    assert assert_report_png(path)['width'] == 10 * DPI


def test_posteriors_of_an_empty_window_is_a_clear_error(tmp_path):
    with pytest.raises(FigureInputError, match='no frames'):
        posteriors_figure(tmp_path / 'p.png', np.zeros(0), np.zeros((0, 4)), 'abcd', [], [], 0.99, 'empty', None)
    with pytest.raises(FigureInputError, match='do not match'):
        posteriors_figure(tmp_path / 'p.png', np.arange(5.0), np.zeros((5, 3)), 'abcd', [], [], 0.99, 'shape', None)


def test_speed_against_error_leaves_out_points_without_a_value(tmp_path):
    panels = [SpeedErrorPanel({'a': [(1.0, 10.0, 'x'), (2.0, float('nan'), 'y')], 'b': [(0.0, 3.0, '')]},
                              'us', 'log axis drops x <= 0', logx=True)]
    assert_report_png(speed_error_figure(tmp_path / 's.png', panels, 'hard input', 'made by hand'))
    with pytest.raises(FigureInputError, match='no finite point'):
        speed_error_figure(tmp_path / 's.png', [SpeedErrorPanel({'a': [(1.0, float('nan'), '')]}, 'us', 'p')],
                           'nothing', None)
    with pytest.raises(FigureInputError, match='no panels'):
        speed_error_figure(tmp_path / 's.png', [], 'nothing', None)


def test_traces_with_a_gesture_the_segmenter_did_not_cut(tmp_path):
    line = np.column_stack([np.linspace(5, 40, 30), np.linspace(5, 20, 30)])
    examples = [('cut', line, line + 0.5), ('not cut', line, None), ('empty', np.zeros((0, 2)), np.zeros((0, 2)))]
    info = assert_report_png(traces_figure(tmp_path / 't.png', examples, 47.0, 'hard input', 'made by hand'))
    assert (info['width'], info['height']) == (round(4.8 * DPI), round(2.45 * DPI))   # 3 panels of 1.5 in
    with pytest.raises(FigureInputError, match='no example'):
        traces_figure(tmp_path / 't.png', [], 47.0, 'none', None)
    with pytest.raises(FigureInputError, match=r'not \(n, 2\)'):
        traces_figure(tmp_path / 't.png', [('bad', np.zeros(5), None)], 47.0, 'bad', None)


def test_a_figure_that_cannot_be_drawn_becomes_a_line_saying_so_and_no_stale_file(tmp_path):
    stale = tmp_path / 'c.png'
    stale.write_bytes(b'an old figure')
    said = []
    line = figure_md(tmp_path, 'c.png', 'alt', lambda path: confusion_figure(path, [[0]], ['a'], ['a'], 'empty', None),
                     said.append)
    assert line.startswith('*Figure c.png not drawn:') and 'empty' in line
    assert not stale.exists() and said and 'c.png' in said[0]
    line = figure_md(tmp_path, 'd.png', 'alt text',
                     lambda path: confusion_figure(path, [[1]], ['a'], ['a'], 'ok', None))
    assert line == '![alt text](d.png)' and (tmp_path / 'd.png').is_file()
