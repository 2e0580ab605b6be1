"""Draw one report figure next to its Markdown file and give the line that shows it."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from touch_lab.figures.png import FigureInputError

__all__ = ['figure_md']


def figure_md(out_dir: str | Path, file_name: str, alt: str, draw: Callable[[Path], Path],
              say: Callable[[str], None] | None = None) -> str:
    """Draw ``out_dir / file_name`` with ``draw(path)``; returns the Markdown image line (a relative link).

    Data that cannot make the figure (:class:`FigureInputError`) does not stop the report: the
    old PNG, which would no longer match the text, is removed and the line says why there is none.
    """
    path = Path(out_dir) / file_name
    try:
        draw(path)
    except FigureInputError as err:
        if say:
            say(f'figure {file_name} not drawn: {err}')
        path.unlink(missing_ok=True)
        return f'*Figure {file_name} not drawn: {err}.*'
    return f'![{alt}]({file_name})'
