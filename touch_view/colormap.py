"""Maps as RGB images: the same colour ramp as the page (``static/view.js``), for Foxglove's Image panel.

>>> rgb = heat_rgb(np.array([0.0, 1.0, 0.5, np.nan], dtype=np.float32), rows=2, cols=2, scale=1)
>>> rgb.shape, rgb[0, 0].tolist(), rgb[0, 1].tolist(), rgb[1, 1].tolist()
((2, 2, 3), [0, 0, 4], [252, 255, 164], [0, 0, 4])
"""

from __future__ import annotations

import numpy as np

__all__ = ['INFERNO', 'heat_rgb']

#: Anchors of a perceptually ordered ramp (after matplotlib's 'inferno'), equally spaced on [0, 1].
INFERNO = np.array([[0, 0, 4], [87, 16, 110], [188, 55, 84], [249, 142, 9], [252, 255, 164]], dtype=np.float64)
_LUT = np.stack([np.interp(np.linspace(0.0, 1.0, 256), np.linspace(0.0, 1.0, len(INFERNO)), INFERNO[:, k])
                 for k in range(3)], axis=1).round().astype(np.uint8)


def heat_rgb(values: np.ndarray, rows: int, cols: int, scale: int = 8, mask: np.ndarray | None = None) -> np.ndarray:
    """(rows*scale, cols*scale, 3) uint8 image of a row-major map of values in [0, 1].

    Args:
        values: (rows*cols,) cells, unitless; clipped to [0, 1], NaN read as 0.
        scale: each cell becomes scale x scale pixels (nearest), so viewers that smooth stay sharp.
        mask: (rows*cols,) bool, False where a cell does not exist (drawn dark grey).
    """
    cells = np.nan_to_num(np.asarray(values, dtype=np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    if cells.size != rows * cols:
        raise ValueError(f'a {rows}x{cols} map needs {rows * cols} cells, got {cells.size}')
    image = _LUT[np.rint(np.clip(cells, 0.0, 1.0) * 255.0).astype(np.intp)].reshape(rows, cols, 3)
    if mask is not None:
        image[~np.asarray(mask, dtype=bool).reshape(rows, cols)] = 42
    return np.repeat(np.repeat(image, scale, axis=0), scale, axis=1)
