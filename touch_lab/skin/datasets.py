"""Reader for traced-gesture CSV files (the layout of ``../shared/data/unistroke_dev.csv.gz``).

One row per point, with a header line::

    subject,variant,gesture,sample,stroke,x,y,t_ms
    2,fast,arrow,0,0,66,252,0.0

``x``, ``y`` are screen pixels (y grows downward; any unit works, only shape matters),
``t_ms`` is milliseconds from the first point of the sample. The rows of one sample
(same subject, variant, gesture and sample) are grouped into a :class:`TraceSample`;
``stroke`` numbers the strokes of a multi-stroke sample (0, 1, ...). Files may be plain
or gzip-compressed (recognised by their first bytes, not their name).

A row that does not parse (a missing field, a word where a number belongs, NaN or
infinite coordinates) raises :class:`TraceFormatError` naming the file and line, or with
``errors='skip'`` is counted in :attr:`TraceSet.skipped_rows` and skipped.

>>> import io
>>> text = 'subject,variant,gesture,sample,stroke,x,y,t_ms\\n1,a,line,0,0,0,0,0\\n1,a,line,0,0,9,0,30\\n'
>>> traces = read_traces(io.StringIO(text))
>>> [(s.gesture, len(s.x), s.n_strokes) for s in traces.samples]
[('line', 2, 1)]
"""

from __future__ import annotations

import csv
import gzip
import io
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from touch_gestures.skin.errors import TraceFormatError
from touch_sim.skin.traces import TraceSample

__all__ = ['COLUMNS', 'TraceSample', 'TraceSet', 'read_traces', 'write_traces']

#: The columns a trace file must have, in any order (extra columns are ignored).
COLUMNS = ('subject', 'variant', 'gesture', 'sample', 'stroke', 'x', 'y', 't_ms')
_KEY_COLUMNS = COLUMNS[:4]


@dataclass
class TraceSet:
    """The samples of a trace file, in file order, and what was skipped on the way."""

    samples: list[TraceSample]
    path: str = '<stream>'
    rows: int = 0
    skipped_rows: int = 0
    skip_reasons: dict[str, int] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.samples)

    def __iter__(self) -> Iterator[TraceSample]:
        return iter(self.samples)

    @property
    def subjects(self) -> list[str]:
        return sorted({s.subject for s in self.samples}, key=_natural_key)

    @property
    def gestures(self) -> list[str]:
        return sorted({s.gesture for s in self.samples})

    @property
    def multi_stroke_samples(self) -> int:
        return sum(1 for s in self.samples if s.n_strokes > 1)


def _natural_key(text: str) -> tuple:
    """Sort '2' before '10' but still sort words.

    >>> sorted(['10', '2', 'b', 'a'], key=_natural_key)
    ['2', '10', 'a', 'b']
    """
    return (0, int(text), '') if text.isdigit() else (1, 0, text)


def _open_text(source: str | Path | IO) -> tuple[IO[str], str, bool]:
    if not isinstance(source, (str, Path)):
        return source, getattr(source, 'name', '<stream>'), False
    path = Path(source)
    try:
        with path.open('rb') as raw:
            magic = raw.read(2)
        if magic == b'\x1f\x8b':
            return io.TextIOWrapper(gzip.open(path, 'rb'), encoding='utf-8', newline=''), str(path), True
        return path.open('r', encoding='utf-8', newline=''), str(path), True
    except FileNotFoundError as err:
        raise TraceFormatError('file not found; give a CSV (or .csv.gz) with columns '
                               + ','.join(COLUMNS), str(path)) from err
    except OSError as err:
        raise TraceFormatError(f'cannot read file: {err}', str(path)) from err


def read_traces(source: str | Path | IO[str], errors: str = 'raise', limit: int | None = None) -> TraceSet:
    """Read a trace file into samples grouped by subject/variant/gesture/sample.

    Args:
        source: a path (plain or gzip CSV) or an open text stream.
        errors: ``'raise'`` (a bad row raises :class:`TraceFormatError` with its line) or
            ``'skip'`` (bad rows are counted in ``skipped_rows`` and left out).
        limit: keep only the first ``limit`` samples (in file order); None keeps all.

    Raises:
        TraceFormatError: missing file, missing columns, a bad row (with ``errors='raise'``),
            or a file without any sample.
    """
    if errors not in ('raise', 'skip'):
        raise ValueError(f"errors must be 'raise' or 'skip', got {errors!r}")
    if limit is not None and limit < 1:
        raise ValueError(f'limit must be a positive number of samples or None, got {limit}')
    stream, name, owned = _open_text(source)
    try:
        return _parse(stream, name, errors, limit)
    except (gzip.BadGzipFile, EOFError, UnicodeDecodeError) as err:
        raise TraceFormatError(f'not a readable CSV or gzip file ({err})', name) from err
    finally:
        if owned:
            stream.close()


def _parse(stream: IO[str], name: str, errors: str, limit: int | None) -> TraceSet:
    reader = csv.reader(stream)
    header = next(reader, None)
    if header is None:
        raise TraceFormatError('empty file; expected a header line ' + ','.join(COLUMNS), name, 1)
    header = [h.strip() for h in header]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise TraceFormatError(f'missing column(s) {", ".join(missing)}; expected a header with '
                               f'{",".join(COLUMNS)}, got {",".join(header)}', name, 1)
    index = [header.index(c) for c in COLUMNS]
    width = max(index) + 1
    groups: dict[tuple[str, ...], list[tuple[int, float, float, float]]] = {}
    result = TraceSet([], path=name)

    def bad(line: int, reason: str, detail: str) -> None:
        if errors == 'raise':
            raise TraceFormatError(detail, name, line)
        result.skipped_rows += 1
        result.skip_reasons[reason] = result.skip_reasons.get(reason, 0) + 1

    for line, row in enumerate(reader, start=2):
        if not row or (len(row) == 1 and not row[0].strip()):
            continue  # blank line
        result.rows += 1
        if len(row) < width:
            bad(line, 'short row', f'expected {len(header)} fields ({",".join(header)}), got {len(row)}: {row!r}')
            continue
        key = tuple(row[i].strip() for i in index[:4])
        if key not in groups and limit is not None and len(groups) >= limit:
            break
        try:
            stroke = int(row[index[4]])
            x, y, t = (float(row[i]) for i in index[5:])
        except ValueError:
            bad(line, 'not a number', 'stroke must be an integer and x, y, t_ms numbers; got '
                + ','.join(row[i] for i in index[4:]))
            continue
        if not all(math.isfinite(v) for v in (x, y, t)) or stroke < 0:
            bad(line, 'non-finite or negative', f'x, y, t_ms must be finite and stroke >= 0; got '
                f'stroke={stroke}, x={x}, y={y}, t_ms={t}')
            continue
        groups.setdefault(key, []).append((stroke, x, y, t))
    result.samples = [_make_sample(key, points) for key, points in groups.items()]
    if not result.samples:
        raise TraceFormatError(f'no valid sample in the file ({result.rows} rows, {result.skipped_rows} skipped)',
                               name)
    return result


def _make_sample(key: tuple[str, ...], points: list[tuple[int, float, float, float]]) -> TraceSample:
    arr = np.asarray(points, dtype=np.float64)
    # Stable sort by (stroke, time) so a file written in any row order gives the same trace.
    order = np.lexsort((arr[:, 3], arr[:, 0]))
    arr = arr[order]
    return TraceSample(*key, x=arr[:, 1].copy(), y=arr[:, 2].copy(), t_ms=arr[:, 3].copy(),
                       stroke=arr[:, 0].astype(np.int32))


def write_traces(path: str | Path, samples: Iterable[TraceSample]) -> None:
    """Write samples in the trace layout (gzip when ``path`` ends in ``.gz``); for tests and tools."""
    path = Path(path)
    opener = gzip.open if path.suffix == '.gz' else open
    with opener(path, 'wt', encoding='utf-8', newline='') as out:
        writer = csv.writer(out)
        writer.writerow(COLUMNS)
        for s in samples:
            for stroke, x, y, t in zip(s.stroke, s.x, s.y, s.t_ms, strict=True):
                writer.writerow([s.subject, s.variant, s.gesture, s.sample, int(stroke), repr(float(x)),
                                 repr(float(y)), repr(float(t))])
