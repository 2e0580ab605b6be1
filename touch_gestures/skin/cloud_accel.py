"""The compiled search of :class:`~.clouds.CloudRecogniser`: which implementation runs, and the codebook for it.

:mod:`.clouds` is numpy, and at 16 gestures x 30 templates a recognition is ~30 numpy calls of 1-3 us
each, not arithmetic. Where the C extension ``touch_gestures.skin._cloud_accel`` was built (``pip install``
compiles it when a C compiler and Python's headers are there, as it does the CDR codec,
:mod:`touch_graph.cdr_accel`), the raster bounds and the exact search run in one C call on the same
arrays; the numpy path stays the reference and the fall-back (``test/test_skin_cloud_accel.py`` checks
that both name the same classes with the same distances, to a few ulp of float64). One rule differs where
it is free: among templates tied for the ``exact``-th smallest raster bound (duplicates, coarse rasters) the
kernel matches the first in template order, numpy's ``argpartition`` one of its own choosing. The features the
search needs are compiled too: the resampling along the ink and the cloud's normalisation (the same
numbers as numpy's where numpy takes its AVX-512 loop for complex absolute values, else to an ulp), and
$N's features and unistroke of one path (the referee's query: the features the same numbers, the
unistroke to ~1e-14), and the trace's time bins and scaling (:mod:`.proposed`, the same numbers) and class minima (equal
but for the sign of a zero).

``SOCIAL_TOUCH_SKIN_ACCEL=python`` forces the numpy path, ``=c`` insists on the compiled one (an error if it
is not built); unset, the compiled one where built. The choice is read once, at import.
"""

from __future__ import annotations

import os

import numpy as np

from .errors import SkinGestureError

try:
    from . import _cloud_accel
    IMPORT_ERROR = ''
except ImportError as err:  # not built: no compiler at install time, or an unsupported platform
    _cloud_accel = None
    IMPORT_ERROR = str(err)

__all__ = ['ACCEL_VARIABLE', 'IMPORT_ERROR', 'available', 'cloud', 'implementation', 'ink', 'make_codebook',
           'oriented_cells', 'oriented_mean', 'relative_sum', 'resample', 'trace', 'trace_minima', 'unistroke']

#: Environment variable choosing the cloud search: ``python``, ``c``, or unset (the compiled one where built).
ACCEL_VARIABLE = 'SOCIAL_TOUCH_SKIN_ACCEL'


def available() -> bool:
    """True when the C extension was built and imports."""
    return _cloud_accel is not None


def _choose() -> str:
    wish = os.environ.get(ACCEL_VARIABLE, '').strip().lower()
    if wish not in ('', 'c', 'python'):
        raise SkinGestureError(f"{ACCEL_VARIABLE}={wish!r}: expected 'c' (the compiled cloud search), 'python' "
                               '(numpy), or unset')
    if wish == 'c' and not available():
        raise SkinGestureError(f'{ACCEL_VARIABLE}=c but the compiled cloud search is not built: {IMPORT_ERROR} '
                               '(reinstall with a C compiler and the Python headers, e.g. apt install '
                               'build-essential python3-dev)')
    return 'python' if wish == 'python' or not available() else 'c'


_IMPLEMENTATION = _choose()

#: The compiled twins of :func:`.features.arc_length_resample_complex`, :func:`.clouds.cloud_features` and
#: :func:`.ndollar.unistroke_vectors` of one path, or None where numpy is chosen: ``resample(points, stroke,
#: n)``, ``cloud(points, stroke, n)``, ``unistroke(path, n, one_d_ratio) -> (vector, start angle)``.
resample = _cloud_accel.resample if _IMPLEMENTATION == 'c' else None
cloud = _cloud_accel.cloud if _IMPLEMENTATION == 'c' else None
unistroke = _cloud_accel.unistroke if _IMPLEMENTATION == 'c' else None
#: ... and of :func:`.ndollar.ink_features`: ``ink(points, stroke, ink_points)`` (None where numpy is chosen).
ink = _cloud_accel.ink if _IMPLEMENTATION == 'c' else None
#: ... and of :func:`.proposed.trace_features`: ``trace(points, times, n_points, aspect_floor)``, finite points and
#: times only (a ValueError otherwise); None where numpy is chosen.
trace = _cloud_accel.trace if _IMPLEMENTATION == 'c' else None
#: ... and of :class:`.proposed.TraceRecogniser`'s distances and their class minima after numpy's matrix-vector
#: product: ``trace_minima(sq_norms, products, query_sq, n_points, class_starts)``.
trace_minima = _cloud_accel.trace_minima if _IMPLEMENTATION == 'c' else None
#: ... and :func:`.fused.relative_distances` of two (n,) arrays summed: ``relative_sum(first, second)``.
relative_sum = _cloud_accel.relative_sum if _IMPLEMENTATION == 'c' else None
#: ... and the oriented cloud's query (:mod:`.oriented`): ``oriented_cells(points, stroke, n, grid, bins)``, the
#: raster cells of :func:`.oriented.oriented_cloud` (finite points only: a ValueError otherwise), and
#: ``oriented_mean(fields, cells)``, oriented.py's ``gather_mean`` of float32 fields; None where numpy is chosen.
oriented_cells = _cloud_accel.oriented_cells if _IMPLEMENTATION == 'c' else None
oriented_mean = _cloud_accel.oriented_mean if _IMPLEMENTATION == 'c' else None


def implementation() -> str:
    """``'c'`` when :class:`~.clouds.CloudRecogniser` searches with the compiled kernel, ``'python'`` for numpy."""
    return _IMPLEMENTATION


def make_codebook(fields: np.ndarray, clouds: np.ndarray, labels: np.ndarray, n_classes: int, grid: int,
                  exact: int, table: np.ndarray | None = None):
    """The compiled codebook (``_cloud_accel.Codebook``: ``bounds(query)``, ``distances(query, solve)``) of
    ``fields`` (grid * grid, T) float32, ``clouds`` (T, n, 2) float64, ``labels`` (T,) class indices and the
    cell-to-cell ``table`` (grid * grid, grid * grid) float32 or None; None where the numpy path is chosen.
    The arrays are copied: the codebook does not see later changes."""
    if _IMPLEMENTATION != 'c':
        return None
    return _cloud_accel.Codebook(np.ascontiguousarray(fields, dtype=np.float32),
                                 np.ascontiguousarray(clouds, dtype=np.float64),
                                 np.ascontiguousarray(labels, dtype=np.intp), int(n_classes), int(grid), int(exact),
                                 None if table is None else np.ascontiguousarray(table, dtype=np.float32))
