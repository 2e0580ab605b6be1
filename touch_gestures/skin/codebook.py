"""Codebook files and the recorder that fills them (cirillo2017 Fig. 5, training branch).

A codebook is a fitted recogniser's templates: n gestures x m recorded repetitions, as
feature vectors. The file is an ``.npz`` read with ``allow_pickle=False``::

    key                 shape       dtype     what
    format              ()          str       'social_touch.skin_codebook'
    format_version      ()          int64     1
    recogniser          ()          str       registry name, e.g. 'trace'
    params              ()          str       JSON of the recogniser's parameters
    classes             (n,)        str       gesture names, sorted
    templates           (T, d)      float32   feature vectors, grouped by class
    template_labels     (T,)        int64     index into classes
    class_thresholds    (n,)        float64   rejection distance per class (inf: none)

At load the format, version, recogniser name and parameters are checked, and so is the
feature dimension (against the features the named recogniser computes with those
parameters): a codebook recorded with 32 points does not silently match 16-point queries.

:class:`CodebookRecorder` collects m repetitions of each gesture from a stream of
segmented gestures (the ``social-touch codebook record`` tool feeds it from the skin),
refusing two-finger, truncated and empty touches.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from touch_graph.yamlconf import did_you_mean

from .base import TemplateRecogniser
from .errors import CodebookError
from .gesture import TouchGesture
from .registry import RECOGNISERS, make_recogniser

__all__ = ['FORMAT', 'FORMAT_VERSION', 'CodebookRecorder', 'load_codebook', 'save_codebook']

FORMAT = 'social_touch.skin_codebook'
FORMAT_VERSION = 1
_KEYS = ('format', 'format_version', 'recogniser', 'params', 'classes', 'templates', 'template_labels',
         'class_thresholds')


def save_codebook(path: str | Path, recogniser: TemplateRecogniser) -> Path:
    """Write a fitted recogniser's codebook to ``path`` (``.npz`` is appended if missing)."""
    if not hasattr(recogniser, 'templates_'):
        raise ValueError('the recogniser has no codebook yet: fit it (or record one) before saving')
    if recogniser.name not in RECOGNISERS:
        raise ValueError(f'recogniser {recogniser.name!r} is not in the registry; cannot name it in a file')
    path = Path(path)
    if path.suffix != '.npz':
        path = path.with_name(path.name + '.npz')
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        path, format=np.array(FORMAT), format_version=np.array(FORMAT_VERSION, dtype=np.int64),
        recogniser=np.array(recogniser.name), params=np.array(json.dumps(recogniser.get_params(), sort_keys=True)),
        classes=np.asarray(recogniser.classes_, dtype=str), templates=recogniser.templates_.astype(np.float32),
        template_labels=recogniser.template_labels_.astype(np.int64),
        class_thresholds=np.asarray(recogniser.class_thresholds_, dtype=np.float64))
    return path


def load_codebook(path: str | Path, recogniser: str | None = None) -> TemplateRecogniser:
    """Read a codebook file into a ready recogniser.

    Args:
        path: the ``.npz`` file.
        recogniser: if given, the file must have been made by this recogniser.

    Raises:
        CodebookError: missing or unreadable file, another format or version, an unknown
            recogniser or parameter, or arrays that do not fit together.
    """
    where = str(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except FileNotFoundError as err:
        raise CodebookError('codebook file not found; record one with `social-touch codebook record`', where) from err
    except (OSError, ValueError) as err:
        raise CodebookError(f'not a readable codebook (.npz without pickled objects): {err}', where) from err
    missing = [k for k in _KEYS if k not in data]
    if missing:
        raise CodebookError(f'missing array(s) {", ".join(missing)}; is this a skin codebook?', where)
    if str(data['format']) != FORMAT:
        raise CodebookError(f"format is {str(data['format'])!r}, expected {FORMAT!r}", where)
    version = int(data['format_version'])
    if version != FORMAT_VERSION:
        raise CodebookError(f'format_version {version} is not supported (this code reads {FORMAT_VERSION}); '
                            'record the codebook again', where)
    name = str(data['recogniser'])
    if name not in RECOGNISERS:
        raise CodebookError(f'recogniser {name!r} is unknown; known: {", ".join(RECOGNISERS)}'
                            f'{did_you_mean(name, RECOGNISERS)}', where)
    if recogniser is not None and name != recogniser:
        raise CodebookError(f'the codebook was made for recogniser {name!r}, not {recogniser!r}; record one for '
                            f'{recogniser!r} or use {name!r}', where)
    try:
        params = json.loads(str(data['params']))
        if not isinstance(params, dict):
            raise ValueError('params must be a JSON object')
        model = make_recogniser(name, **params)
    except (ValueError, TypeError) as err:
        raise CodebookError(f'bad recogniser parameters: {err}', where) from err
    classes, templates = data['classes'].astype(str), data['templates']
    codes, thresholds = data['template_labels'], data['class_thresholds']
    if templates.ndim != 2 or codes.shape != (len(templates),) or thresholds.shape != classes.shape \
            or len(classes) == 0 or codes.min(initial=0) < 0 or codes.max(initial=0) >= len(classes):
        raise CodebookError(f'arrays do not fit together: templates {templates.shape}, template_labels '
                            f'{codes.shape}, classes {classes.shape}, class_thresholds {thresholds.shape}', where)
    expected = _feature_size(model)
    if expected is not None and templates.shape[1] != expected:
        raise CodebookError(f'templates have {templates.shape[1]} features but {name} with these parameters '
                            f'computes {expected}; the file and its parameters disagree', where)
    try:
        model.set_codebook(templates, classes[codes], class_thresholds=thresholds)
    except ValueError as err:
        raise CodebookError(str(err), where) from err
    return model


def _feature_size(model: TemplateRecogniser) -> int | None:
    """Length of the model's feature vector, from a probe gesture (a short diagonal stroke)."""
    probe = TouchGesture.from_trajectory(np.array([[10.0, 10.0], [20.0, 15.0], [30.0, 30.0]]))
    features = model._features(probe)
    return None if features is None else len(features)


@dataclass
class CodebookRecorder:
    """Collect ``repetitions`` usable gestures of each name in ``gestures``, in order.

    >>> rec = CodebookRecorder(['line_right'], repetitions=1)
    >>> rec.current
    'line_right'
    >>> rec.add(TouchGesture.from_trajectory(np.array([[5.0, 20.0], [40.0, 20.0]])))
    (True, 'line_right 1/1')
    >>> rec.done
    True
    """

    gestures: Sequence[str]
    repetitions: int = 30
    min_points: int = 2
    samples: list[TouchGesture] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.gestures or len(set(self.gestures)) != len(self.gestures):
            raise ValueError(f'give one or more distinct gesture names; got {list(self.gestures)}')
        if self.repetitions < 1:
            raise ValueError(f'repetitions must be >= 1, got {self.repetitions}')

    @property
    def done(self) -> bool:
        return len(self.samples) >= len(self.gestures) * self.repetitions

    @property
    def current(self) -> str | None:
        """The gesture to trace next, or None when done."""
        return None if self.done else self.gestures[len(self.samples) // self.repetitions]

    def add(self, gesture: TouchGesture) -> tuple[bool, str]:
        """Offer one segmented gesture; returns (kept, a line for the person recording)."""
        name = self.current
        if name is None:
            return False, 'the codebook is complete'
        if gesture.multi_contact:
            return False, f'{name}: two fingers seen, trace with one finger and try again'
        if gesture.truncated:
            return False, f'{name}: the touch did not end, lift the finger after the gesture'
        if len(gesture.trajectory) < self.min_points:
            return False, f'{name}: too short ({len(gesture.trajectory)} points), trace the whole gesture'
        self.samples.append(gesture)
        self.labels.append(name)
        k = len(self.samples) - self.gestures.index(name) * self.repetitions
        return True, f'{name} {k}/{self.repetitions}'

    def undo(self) -> str | None:
        """Drop the last kept gesture (a bad repetition); returns its name."""
        if not self.samples:
            return None
        self.samples.pop()
        return self.labels.pop()

    def fit(self, recogniser: TemplateRecogniser) -> TemplateRecogniser:
        """Fit ``recogniser`` on what was collected (all gestures need at least one sample)."""
        missing = [g for g in self.gestures if g not in self.labels]
        if missing:
            raise ValueError(f'no repetition recorded yet for: {", ".join(missing)}')
        return recogniser.fit(self.samples, self.labels)
