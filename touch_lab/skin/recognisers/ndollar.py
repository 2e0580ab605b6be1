"""$N for multi-stroke gestures: :class:`NDollarRecogniser`.

$N (Anthony and Wobbrock, GI 2010) turns a multi-stroke template into unistrokes: its strokes joined in
every order, each either way round; a query is joined in the order it was traced. Matching is
$N-Protractor's (GI 2012) closed-form cosine distance. The details follow the authors' ``ndollar.js``;
where this module differs, it says so:

1. **Features** (what a codebook file stores): the strokes resampled along the ink to ``ink_points``
   points, each stroke 2 points plus its share of the rest by ink length (independent of the order),
   centred and divided by the larger side of the box; then each point's stroke number (padding: -1).
   Layout: ``(3 * ink_points,)`` float32, x and y interleaved, then the stroke numbers.
2. **Expansion** (``_prepare_codebook``): k <= ``permuted_strokes`` strokes become all k! 2^k
   unistrokes; beyond, the recorded order with every direction (2^k) while within that budget, else the
   recorded order and the whole trace backwards. The reference has no bound: this is ours.
3. **Unistroke normalisation**: resampled to ``n_points`` along the joined path, rotated to the
   indicative angle, scaled to a square (uniformly below ``one_d_ratio``), rotated back (the skin has
   a fixed frame), centred, a unit vector; the start direction runs to the ``n_points // 8``-th point.
4. **Distance**: the angle between unit vectors (radians) after the best rotation within
   ``max_rotation_deg``, Protractor's closed form clamped to the range (the reference's
   ``atan(b / a)`` picks the worst rotation when ``a < 0``).
5. **Pruning**: unistrokes whose start direction differs by more than ``start_angle_deg`` are not
   compared; with ``same_strokes`` only templates of the query's stroke count. When that leaves
   nothing, every unistroke is compared (the reference answers "no match"; here rejection decides).

``distances`` gives one distance per template, the smallest over its unistrokes (inf: none compared).
$N joins both directions of every stroke, so it is direction-blind unless ``reverse_strokes=False``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.features import arc_length_resample
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.stroke_orders import split_strokes

__all__ = ['NDollarRecogniser', 'expansion_orders', 'ink_features']

#: Stroke number of the unused slots of a feature vector.
PADDING = -1


def ink_features(points: np.ndarray, stroke: np.ndarray | None, ink_points: int = 128) -> np.ndarray | None:
    """(m, 2) points with (m,) stroke ids -> (3 * ink_points,) float32 (module doc, 1); None if the
    gesture has more strokes than ``ink_points`` (nothing left to resample) or no point.

    >>> f = ink_features(np.array([[0.0, 0], [4, 0], [0, 4], [4, 4]]), np.array([0, 0, 1, 1]), 6)
    >>> f[:12].reshape(6, 2).round(2).tolist()   # two strokes of 3 points: their ink shares are equal
    [[-0.5, -0.5], [0.0, -0.5], [0.5, -0.5], [-0.5, 0.5], [0.0, 0.5], [0.5, 0.5]]
    >>> f[12:].tolist()
    [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return None
    strokes = [pts] if stroke is None else split_strokes(pts, np.asarray(stroke).reshape(-1))
    k = len(strokes)
    if k > ink_points:
        return None
    floor = 2 if 2 * k <= ink_points else 1
    lengths = np.array([np.hypot(*np.diff(s, axis=0).T).sum() for s in strokes])
    total = float(lengths.sum())
    spare = ink_points - floor * k
    # Each stroke's share rounds down on its own: the same counts in any order (module doc, 1).
    counts = floor + (np.floor(spare * lengths / total).astype(np.int64) if total > 0 else 0)
    out = np.zeros((ink_points, 2))
    sid = np.full(ink_points, PADDING, dtype=np.float64)
    at = 0
    for i, (s, c) in enumerate(zip(strokes, np.broadcast_to(counts, (k,)).tolist(), strict=True)):
        out[at:at + c] = arc_length_resample(s, c)
        sid[at:at + c] = i
        at += c
    ink = out[:at]
    ink -= ink.mean(axis=0)
    size = float((ink.max(axis=0) - ink.min(axis=0)).max())
    if size > 1e-9:
        ink /= size
    out[at:] = ink[-1]   # padding repeats the last point: finite, and never read
    return np.concatenate([out.reshape(-1), sid]).astype(np.float32)


@lru_cache(maxsize=16)
def expansion_orders(k: int, permuted_strokes: int, reverse_strokes: bool = True
                     ) -> tuple[tuple[tuple[int, bool], ...], ...]:
    """The unistrokes a template of ``k`` strokes becomes: each a tuple of (stroke, reversed) (module doc, 2).

    >>> len(expansion_orders(2, 3)), len(expansion_orders(3, 3)), len(expansion_orders(4, 3))
    (8, 48, 16)
    >>> len(expansion_orders(7, 3)), expansion_orders(2, 3, reverse_strokes=False)
    (2, (((0, False), (1, False)), ((1, False), (0, False))))
    """
    if k <= permuted_strokes:
        orders = list(itertools.permutations(range(k)))
    else:
        orders = [tuple(range(k))]
    budget = math.factorial(permuted_strokes) * 2 ** permuted_strokes
    if not reverse_strokes:
        return tuple(tuple((s, False) for s in order) for order in orders)
    if k <= permuted_strokes or 2 ** k <= budget:
        return tuple(tuple((s, bool(bits >> i & 1)) for i, s in enumerate(order))
                     for order in orders for bits in range(2 ** k))
    forward = tuple((s, False) for s in range(k))
    return forward, tuple((s, True) for s in reversed(range(k)))


def _resample_paths(paths: np.ndarray, n: int) -> np.ndarray:
    """(U, m, 2) polylines -> (U, n, 2) points equally spaced along each (jumps count); a path
    that never moves gives n copies of its first point. One searchsorted for all rows."""
    U, m, _ = paths.shape
    if U == 1:   # a query: the single-path resampling has fewer numpy calls (us per recognition)
        return arc_length_resample(paths[0], n)[None]
    step = np.hypot(*np.moveaxis(np.diff(paths, axis=1), -1, 0))          # (U, m - 1)
    cum = np.concatenate([np.zeros((U, 1)), np.cumsum(step, axis=1)], axis=1)
    total = cum[:, -1:]
    frac = cum / np.where(total > 0, total, 1.0)                          # each row in [0, 1]
    # Rows laid end to end 2 apart: one sorted array, exact to ~1e-16 x 2U.
    keys = (frac + 2.0 * np.arange(U)[:, None]).reshape(-1)
    targets = np.linspace(0.0, 1.0, n)[None, :] + 2.0 * np.arange(U)[:, None]
    hi = np.clip(np.searchsorted(keys, targets.reshape(-1), side='right'), 1, U * m - 1).reshape(U, n)
    hi = np.minimum(hi, (np.arange(U)[:, None] + 1) * m - 1)              # stay within the row
    lo = hi - 1
    flat = paths.reshape(-1, 2)
    k_lo, k_hi = keys[lo], keys[hi]
    span = k_hi - k_lo
    w = np.where(span > 0, (targets - k_lo) / np.where(span > 0, span, 1.0), 0.0).clip(0.0, 1.0)
    out = flat[lo] + w[..., None] * (flat[hi] - flat[lo])
    still = total[:, 0] <= 0
    out[still] = paths[still, :1]
    return out


def _rotate(points: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(U, n, 2) points rotated by (U,) radians about the origin."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    x, y = points[..., 0], points[..., 1]
    return np.stack([x * c - y * s, x * s + y * c], axis=-1)


def unistroke_vectors(paths: np.ndarray, n_points: int, one_d_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """(U, m, 2) joined strokes -> (U, 2 n) float64 unit vectors and (U,) start angles, radians
    (NaN where the start does not move): module doc, 3."""
    pts = _resample_paths(paths, n_points)
    centre = pts.mean(axis=1, keepdims=True)
    pts = pts - centre
    first = pts[:, 0]
    indicative = np.arctan2(-first[:, 1], -first[:, 0])   # from the first point to the centroid
    pts = _rotate(pts, -indicative)
    lo, hi = pts.min(axis=1), pts.max(axis=1)
    w, h = (hi - lo).T
    big = np.maximum(w, h)
    line = np.minimum(w, h) <= one_d_ratio * big
    # A line scales uniformly; a 2-D shape to a square (ScaleDimTo); a dab (big 0) not at all.
    sx = 1.0 / np.where(line, big, w).clip(min=1e-12)
    sy = 1.0 / np.where(line, big, h).clip(min=1e-12)
    still = big <= 1e-12
    sx[still] = sy[still] = 1.0
    pts = pts * np.stack([sx, sy], axis=-1)[:, None, :]
    pts = _rotate(pts, indicative)                        # back to the skin's frame
    pts -= pts.mean(axis=1, keepdims=True)
    start = pts[:, n_points // 8] - pts[:, 0]
    moved = np.hypot(start[:, 0], start[:, 1]) > 1e-9
    angles = np.where(moved, np.arctan2(start[:, 1], start[:, 0]), np.nan)
    vec = pts.reshape(len(pts), -1)
    norm = np.linalg.norm(vec, axis=1, keepdims=True)
    vec = np.where(norm > 0, vec / np.where(norm > 0, norm, 1.0), 0.0)
    return vec, angles


class NDollarRecogniser(TemplateRecogniser):
    """$N-Protractor over the codebook's unistrokes (module doc).

    Args:
        n_points: points per unistroke ($N's ``NumPoints`` 96).
        ink_points: points per gesture along the ink in the features (module doc, 1).
        permuted_strokes: templates of up to this many strokes are joined in every order (module doc, 2).
        reverse_strokes: join every stroke both ways ($N); False keeps each stroke's direction (orders only).
        max_rotation_deg: largest rotation of a query against a unistroke, degrees (module doc, 4).
        start_angle_deg: unistrokes starting more than this away from the query's start are not compared
            (None: all are).
        same_strokes: compare only templates of as many strokes as the query.
        one_d_ratio: a box thinner than this (short side / long side) is a line, scaled uniformly.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.

    Attributes (after fit or load):
        unistroke_owner_: (U,) the codebook template each unistroke comes from, sorted by start angle.
    """

    name = 'ndollar'

    @property
    def direction_aware(self) -> bool:  # both ways of every stroke: a line equals its reverse
        return not self.reverse_strokes

    def __init__(self, n_points: int = 96, ink_points: int = 128, permuted_strokes: int = 3,
                 reverse_strokes: bool = True, max_rotation_deg: float = 0.0, start_angle_deg: float | None = 30.0,
                 same_strokes: bool = False, one_d_ratio: float = 0.25,
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.ink_points = ink_points
        self.permuted_strokes = permuted_strokes
        self.reverse_strokes = reverse_strokes
        self.max_rotation_deg = max_rotation_deg
        self.start_angle_deg = start_angle_deg
        self.same_strokes = same_strokes
        self.one_d_ratio = one_d_ratio
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def _check_params(self) -> None:
        super()._check_params()
        if self.n_points < 16 or self.ink_points < 2 or not 1 <= self.permuted_strokes <= 6:
            raise ValueError(f'need n_points >= 16, ink_points >= 2 and permuted_strokes in 1..6 (6 strokes: '
                             f'46,080 unistrokes a template); got {self.n_points}, {self.ink_points}, '
                             f'{self.permuted_strokes}')
        if not 0 <= self.max_rotation_deg <= 180:
            raise ValueError(f'max_rotation_deg must be in [0, 180], got {self.max_rotation_deg!r}')
        if self.start_angle_deg is not None and not 0 <= self.start_angle_deg <= 180:
            raise ValueError(f'start_angle_deg must be in [0, 180] or None, got {self.start_angle_deg!r}')
        if not 0 <= self.one_d_ratio <= 1:
            raise ValueError(f'one_d_ratio must be in [0, 1], got {self.one_d_ratio!r}')

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        return ink_features(gesture.trajectory, gesture.stroke, self.ink_points)

    def _strokes(self, features: np.ndarray) -> list[np.ndarray]:
        """(3 * ink_points,) features -> the strokes' (m_i, 2) float64 points, in traced order."""
        n = self.ink_points
        pts = features[:2 * n].reshape(n, 2).astype(np.float64)
        sid = features[2 * n:]
        used = sid != PADDING
        return split_strokes(pts[used], sid[used])

    def _expand(self, features: np.ndarray, as_traced: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
        """A template's unistrokes, or with ``as_traced`` the query's one (its strokes in traced order):
        (U, 2 n) unit vectors, (U,) start angles, and the number of strokes."""
        strokes = self._strokes(features)
        if as_traced:
            orders = (tuple((s, False) for s in range(len(strokes))),)
        else:
            orders = expansion_orders(len(strokes), self.permuted_strokes, self.reverse_strokes)
        backwards = [s[::-1] for s in strokes]
        paths = np.stack([np.concatenate([backwards[s] if rev else strokes[s] for s, rev in order])
                          for order in orders])
        vec, angles = unistroke_vectors(paths, self.n_points, self.one_d_ratio)
        return vec, angles, len(strokes)

    def _prepare_codebook(self) -> None:
        vectors, angles, owners, counts = [], [], [], []
        for t, features in enumerate(self.templates_):
            vec, ang, k = self._expand(features)
            vectors.append(vec)
            angles.append(ang)
            owners.append(np.full(len(vec), t, dtype=np.intp))
            counts.append(k)
        angles_all = np.concatenate(angles)
        # Sorted by start angle (NaN, a start that never moves, last): a query's window is a slice.
        order = np.argsort(angles_all, kind='stable')
        self._vectors = np.concatenate(vectors)[order].astype(np.float32)
        self._angles = angles_all[order]
        self.unistroke_owner_ = np.concatenate(owners)[order]
        self._n_angled = int(np.isfinite(self._angles).sum())
        self._template_counts = np.asarray(counts, dtype=np.int64)
        self._unistroke_counts = self._template_counts[self.unistroke_owner_]
        # Each class's rows of the sorted unistrokes (a referee asks about two classes only): every class has
        # templates, and every template at least one unistroke.
        unistroke_class = self.template_labels_[self.unistroke_owner_]
        self._class_rows = [np.flatnonzero(unistroke_class == c) for c in range(len(self.classes_))]
        self._class_rows_cache: dict[tuple[int, ...], tuple[np.ndarray, np.ndarray]] = {}

    def _windows(self, angle: float) -> list[slice]:
        """Slices of the sorted unistrokes whose start is within ``start_angle_deg`` of ``angle``,
        plus those without a start direction (compared always)."""
        angles, n_angled = self._angles, self._n_angled
        tail = slice(n_angled, len(angles))
        if self.start_angle_deg is None or not np.isfinite(angle) or self.start_angle_deg >= 180:
            return [slice(0, len(angles))]
        half = math.radians(self.start_angle_deg)
        angled = angles[:n_angled]
        out = [tail]
        lo, hi = angle - half, angle + half
        # The window on the circle as at most three ranges of [-pi, pi].
        for a, b in ((lo, hi), (lo + 2 * math.pi, hi + 2 * math.pi), (lo - 2 * math.pi, hi - 2 * math.pi)):
            a, b = max(a, -math.pi), min(b, math.pi)
            if a <= b:
                i, j = int(np.searchsorted(angled, a, side='left')), int(np.searchsorted(angled, b, side='right'))
                if j > i:
                    out.append(slice(i, j))
        return out

    def _similarities(self, rows: slice, queries: np.ndarray, vectors: np.ndarray | None = None) -> np.ndarray:
        """Cosine of the best rotation within ``max_rotation_deg`` for the unistrokes ``rows`` of ``vectors``
        (default: the codebook's sorted unistrokes; module doc, 4); ``queries`` is (2, 2 n) float32: the
        query and the query turned by 90 degrees (whose dot product with a unistroke is Protractor's b). Two
        matrix-vector products on contiguous rows (a (2 n, 2) product or a strided vector takes numpy's slow
        paths); ``einsum``, not ``@``: BLAS splits a long product over threads, which wait for each other on a
        busy machine, while einsum's loop stays in this thread."""
        block = (self._vectors if vectors is None else vectors)[rows]
        a = np.einsum('ij,j->i', block, queries[0]).astype(np.float64)
        if self.max_rotation_deg <= 0:
            return a
        b = np.einsum('ij,j->i', block, queries[1]).astype(np.float64)
        # a cos t + b sin t = h cos(t - atan2(b, a)) peaks at h = hypot(a, b) when the best angle is within
        # the bound (a >= h cos(bound)); else at the bound on b's side. No trigonometric call per unistroke.
        bound = math.radians(self.max_rotation_deg)
        c, s = math.cos(bound), math.sin(bound)
        h = np.hypot(a, b)
        return np.where(a >= h * c, h, a * c + np.abs(b) * s)

    def _query(self, query: np.ndarray) -> tuple[np.ndarray, float, int]:
        """The query's (2, 2 n) float32 unit vector and its turn by 90 degrees (:meth:`_similarities`), its
        start angle (radians, NaN: none) and its number of strokes."""
        # The strokes in traced order, joined: the feature's used points as they are (what _expand(as_traced)
        # joins after splitting them, in fewer numpy calls); a stroke begins where the stroke number changes.
        n = self.ink_points
        sid = query[2 * n:]
        used = sid != PADDING
        ids = sid[used]
        k = 1 + int(np.count_nonzero(ids[1:] != ids[:-1]))
        vec, angles = unistroke_vectors(query[:2 * n].reshape(n, 2)[used].astype(np.float64)[None], self.n_points,
                                        self.one_d_ratio)
        queries = np.empty((2, vec.shape[1]), dtype=np.float32)
        queries[0] = vec[0]
        queries[1, 0::2], queries[1, 1::2] = vec[0, 1::2], -vec[0, 0::2]   # turned by 90 degrees
        return queries, float(angles[0]), k

    def distances(self, query: np.ndarray) -> np.ndarray:
        queries, angle, k = self._query(query)
        out = self._search(self._windows(angle), queries, k)
        if not np.isfinite(out).any():   # pruning left nothing: compare all (module doc, 5)
            out = self._search([slice(0, len(self._angles))], queries, None)
        return out

    def class_distances_among(self, gesture: TouchGesture, classes: Sequence[int]) -> np.ndarray | None:
        """``class_distances(gesture)[classes]`` ((len(classes),) float64; None if unusable), comparing only
        those classes' unistrokes: what a referee between two classes needs, at a fraction of the cost.

        The start-angle window and the stroke-count rule are the whole search's: whether pruning left
        nothing at all to compare (then every unistroke is, module doc 5) is decided over the whole codebook."""
        self._check_fitted()
        features = self.features(gesture)
        if features is None:
            return None
        queries, angle, k = self._query(features)
        windows = self._windows(angle)
        rows, starts = self._rows_of(tuple(int(c) for c in classes))
        d = np.arccos(np.clip(self._similarities(slice(None), queries, self._vectors[rows]), -1.0, 1.0))
        if self._compares_any(windows, k):   # else the whole search would compare all: so does each class's
            keep = np.zeros(len(rows), dtype=bool)
            for w in windows:   # the rows of the two classes within the whole search's windows
                if w.stop > w.start:
                    keep |= (rows >= w.start) & (rows < w.stop)
            if self.same_strokes:
                keep &= self._unistroke_counts[rows] == k
            d = np.where(keep, d, np.inf)
        return np.minimum.reduceat(d, starts)   # NaN propagates, as np.minimum.at in _search

    def _rows_of(self, classes: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The sorted unistrokes of ``classes`` (their rows, class after class) and where each class starts;
        kept per tuple of classes (at most n_classes squared pairs for a referee)."""
        cached = self._class_rows_cache.get(classes)
        if cached is None:
            parts = [self._class_rows[c] for c in classes]
            cached = np.concatenate(parts), np.cumsum([0] + [len(p) for p in parts[:-1]])
            self._class_rows_cache[classes] = cached
        return cached

    def _compares_any(self, windows: list[slice], strokes: int) -> bool:
        """Whether :meth:`_search` over ``windows`` compares any unistroke (gives a finite distance)."""
        for rows in windows:
            if rows.stop > rows.start and (not self.same_strokes or (self._unistroke_counts[rows] == strokes).any()):
                return True
        return False

    def _search(self, windows: list[slice], queries: np.ndarray, strokes: int | None) -> np.ndarray:
        """(T,) smallest angle over each template's unistrokes within ``windows`` (inf: none compared)."""
        out = np.full(len(self.templates_), np.inf)
        for rows in windows:
            if rows.stop <= rows.start:
                continue
            d = np.arccos(np.clip(self._similarities(rows, queries), -1.0, 1.0))
            if self.same_strokes and strokes is not None:
                d[self._unistroke_counts[rows] != strokes] = np.inf
            np.minimum.at(out, self.unistroke_owner_[rows], d)
        return out
