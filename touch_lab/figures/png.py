"""Draw and save report figures deterministically: Agg canvas, fixed size and dpi, no metadata.

The same measurements give the same PNG bytes (for a given matplotlib and FreeType): no
timestamp, no software version in the file, fonts and sizes set here rather than taken
from the user's matplotlibrc.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import matplotlib
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ['DPI', 'FigureInputError', 'drawing', 'note_synthetic', 'save_png']

#: Dots per inch of every report figure: a 8 x 4.5 in figure is 800 x 450 pixels.
DPI = 100

#: rcParams fixed for every figure, so a user's matplotlibrc cannot change the files.
_STYLE = {
    'font.family': 'DejaVu Sans', 'font.size': 9.0, 'axes.titlesize': 10.0, 'axes.labelsize': 9.0,
    'legend.fontsize': 8.0, 'xtick.labelsize': 8.0, 'ytick.labelsize': 8.0, 'axes.grid': False,
    'image.cmap': 'viridis', 'savefig.facecolor': 'white', 'figure.facecolor': 'white',
    'path.simplify': True, 'svg.hashsalt': 'social_touch',
}


class FigureInputError(ValueError):
    """The data cannot make this figure (empty, mismatched shapes, nothing finite); says why."""


@contextmanager
def drawing(width_in: float, height_in: float) -> Iterator[Figure]:
    """A figure on its own Agg canvas (no pyplot, no global figure registry), constrained layout.

    Draw and save inside the ``with`` block: the report style (fonts, sizes) holds there.

    Args:
        width_in, height_in: size in inches; the PNG is ``DPI`` times that in pixels.
    """
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout='constrained')
        FigureCanvasAgg(fig)
        yield fig


def note_synthetic(fig: Figure, what: str) -> None:
    """Label the figure's data as synthetic, bottom left, so a copied PNG still says so."""
    # supxlabel, not fig.text: the constrained layout keeps room for it below the axes' own labels.
    fig.supxlabel(f'SYNTHETIC: {what}', x=0.005, ha='left', fontsize=7, color='0.35', style='italic')


def save_png(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as a PNG of exactly its size x ``DPI`` pixels, without metadata; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Software=None drops the only text chunk matplotlib writes (its version): stable bytes.
    fig.savefig(path, dpi=DPI, format='png', metadata={'Software': None}, pil_kwargs={'optimize': True})
    return path
