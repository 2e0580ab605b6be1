"""A codebook recording in progress, on disk: the gestures kept so far, to resume later.

``social-touch codebook record`` saves one when it is stopped before the codebook is
complete (Ctrl-C), and ``--resume FILE`` continues from it. It holds the segmented gestures
themselves, not templates, so the codebook can still be made with any recogniser. The file
is an ``.npz`` read with ``allow_pickle=False``::

    key             shape       dtype     what
    format          ()          str       'social_touch.skin_recording'
    format_version  ()          int64     1
    gestures        (n,)        str       the gestures to record, in order
    repetitions     ()          int64     wanted per gesture
    min_extent_mm   ()          float64   the recorder's size rule
    skipped         (k,)        str       gestures left out
    labels          (G,)        str       gesture of each kept repetition, in recording order
    people          (G,)        str       who traced each ('' not known; optional: older files lack it)
    lengths         (G,)        int64     trajectory points of each
    trajectory      (sum, 2)    float32   contact points, mm, all gestures one after the other
    times, stroke   (sum,)      float64 s, int16
    binary_map      (G, 12, 12) bool;  peak_map (G, 12, 12) float32
    frames, strokes (G,) int64; start_s, duration_s (G,) float64; multi_contact, truncated (G,) bool
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from touch_gestures.skin.codebook import CodebookRecorder
from touch_gestures.skin.errors import CodebookError
from touch_gestures.skin.gesture import GRID, TouchGesture

__all__ = ['FORMAT', 'load_recording', 'save_recording']

FORMAT = 'social_touch.skin_recording'
FORMAT_VERSION = 1
_SCALARS = {'frames': np.int64, 'strokes': np.int64, 'start_s': np.float64, 'duration_s': np.float64,
            'multi_contact': bool, 'truncated': bool}


def save_recording(path: str | Path, recorder: CodebookRecorder) -> Path:
    """Write what ``recorder`` holds to ``path`` (written whole to a temporary file, then renamed)."""
    path = Path(path)
    if path.suffix != '.npz':
        path = path.with_name(path.name + '.npz')
    g = recorder.samples
    data = {
        'format': np.array(FORMAT), 'format_version': np.array(FORMAT_VERSION, dtype=np.int64),
        'gestures': np.array(recorder.gestures, dtype=str), 'repetitions': np.array(recorder.repetitions),
        'min_extent_mm': np.array(float(recorder.min_extent_mm)),
        'skipped': np.array(recorder.skipped, dtype=str).reshape(-1), 'labels': np.array(recorder.labels, dtype=str),
        'people': np.array(recorder.people, dtype=str).reshape(-1),
        'lengths': np.array([len(x.trajectory) for x in g], dtype=np.int64),
        'trajectory': np.concatenate([x.trajectory for x in g] or [np.zeros((0, 2), np.float32)]),
        'times': np.concatenate([x.times for x in g] or [np.zeros(0)]),
        'stroke': np.concatenate([x.stroke for x in g] or [np.zeros(0, np.int16)]),
        'binary_map': np.array([x.binary_map for x in g], dtype=bool).reshape(-1, GRID, GRID),
        'peak_map': np.array([x.peak_map for x in g], dtype=np.float32).reshape(-1, GRID, GRID),
    }
    for name, dtype in _SCALARS.items():
        data[name] = np.array([getattr(x, name) for x in g], dtype=dtype)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + '.tmp.npz')
    np.savez_compressed(tmp, **data)
    tmp.replace(path)
    return path


def load_recording(path: str | Path) -> CodebookRecorder:
    """A recorder holding the gestures of a recording file, ready to go on.

    Raises:
        CodebookError: missing or unreadable file, another format or version, arrays that do not fit.
    """
    where = str(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
    except FileNotFoundError as err:
        raise CodebookError('recording file not found', where) from err
    except (OSError, ValueError) as err:
        raise CodebookError(f'not a readable recording (.npz without pickled objects): {err}', where) from err
    if str(d.get('format', '')) != FORMAT:
        raise CodebookError(f"not a skin recording (format {str(d.get('format', 'missing'))!r}, expected {FORMAT!r}); "
                            'a codebook is resumed from the .partial.npz file the recorder wrote', where)
    if int(d['format_version']) != FORMAT_VERSION:
        raise CodebookError(f"format_version {int(d['format_version'])} is not supported (this code reads "
                            f'{FORMAT_VERSION})', where)
    try:
        lengths = d['lengths']
        n = len(lengths)
        ends = np.cumsum(lengths)
        if len(d['labels']) != n or (n and ends[-1] != len(d['trajectory'])) \
                or any(len(d[k]) != n for k in ('binary_map', 'peak_map', *_SCALARS)):
            raise ValueError(f'{n} gestures but arrays of other lengths')
        samples = []
        for i in range(n):
            lo, hi = ends[i] - lengths[i], ends[i]
            samples.append(TouchGesture(
                binary_map=d['binary_map'][i], peak_map=d['peak_map'][i], trajectory=d['trajectory'][lo:hi],
                times=d['times'][lo:hi], stroke=d['stroke'][lo:hi],
                **{k: (t(d[k][i]).item() if t is not bool else bool(d[k][i])) for k, t in _SCALARS.items()}))
        return CodebookRecorder([str(x) for x in d['gestures']], repetitions=int(d['repetitions']),
                                samples=samples, labels=[str(x) for x in d['labels']],
                                people=[str(x) for x in d.get('people', [''] * n)],
                                min_extent_mm=float(d['min_extent_mm']), skipped=[str(x) for x in d['skipped']])
    except (KeyError, ValueError) as err:
        raise CodebookError(f'a damaged recording: {err}', where) from err
