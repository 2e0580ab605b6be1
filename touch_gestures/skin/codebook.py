"""Codebook files and the recorder that fills them (cirillo2017 Fig. 5, training branch).

A codebook is a fitted recogniser's templates (n gestures x m repetitions, as feature vectors)
in an ``.npz`` read with ``allow_pickle=False``::

    key                 shape       dtype     what
    format              ()          str       'social_touch.skin_codebook'
    format_version      ()          int64     2 (1 is still read)
    recogniser          ()          str       registry name, e.g. 'trace' (:mod:`.registry`)
    params              ()          str       JSON of the recogniser's parameters
    classes             (n,)        str       gesture names, sorted
    templates           (T, d)      float32   feature vectors, grouped by class
    template_labels     (T,)        int64     index into classes
    class_thresholds    (n,)        float64   rejection distance per class (inf: none)
    description         ()          str       optional: how it was recorded (synthetic or not)
    vocabulary          ()          str       v2: the vocabulary's name ('commands', 'symbols'...)
    gap_s               ()          float64   v2: the segmenter's gap, s (a lift this long ends a gesture)
    max_strokes         ()          int64     v2: most strokes of a template
    template_strokes    (T,)        int64     optional: strokes of each template
    template_contact_s  (T,)        float64   optional: time in contact of each template, s
                                              (an older ``template_durations`` is not read)
    template_paths      (T, n, 2)   float32   optional: each one-stroke template's path, NaN for
                                              the others (:mod:`.order_evidence`)
    template_people     (T,)        str       optional: who drew each template ('' not known)
    template_sizes_mm   (T,)        float64   optional: each template's size, mm (the diagonal of its
                                              bounding box, :func:`.doubt.touch_size_mm`; NaN not known)
    acceptance          ()          str       optional: JSON record of a calibrated acceptance
                                              (:mod:`.base`, :mod:`touch_lab.skin.acceptance`)

A version 1 file is the single-stroke vocabulary ``commands``: ``gap_s`` 0.15 s, ``max_strokes`` 1.
The loaded recogniser carries ``vocabulary_``, ``gap_s_`` and ``max_strokes_``.

At load the format, version, recogniser name, parameters and feature dimension are checked. Only the
recognisers of :data:`.registry.RECOGNISERS` load here: the runtime does not reach into the lab, and
the error says to record the codebook again with ``trace`` or ``fused`` (the lab's tools pass their
own registry as ``recognisers``).

:class:`CodebookRecorder` collects m repetitions of each gesture from a stream of segmented gestures
(``social-touch codebook record``), refusing two-finger, truncated, empty and tiny touches.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from touch_graph.files import replacing
from touch_graph.yamlconf import did_you_mean

from .base import TemplateRecogniser
from .errors import CodebookError
from .gesture import TouchGesture
from .registry import DEFAULT_RECOGNISER, MULTISTROKE_RECOGNISER, RECOGNISERS, recogniser_from
from .screening import MIN_EXTENT_MM, MIN_POINTS, gesture_extent_mm, screen_gesture
from .segmentation import default_gap_s

__all__ = ['FORMAT', 'FORMAT_VERSION', 'CodebookRecorder', 'load_codebook', 'save_codebook']

FORMAT = 'social_touch.skin_codebook'
FORMAT_VERSION = 2
#: Versions this code reads.
READABLE_VERSIONS = (1, 2)
#: What a version 1 file is.
_V1_VOCABULARY = ('commands', 1)
_KEYS = ('format', 'format_version', 'recogniser', 'params', 'classes', 'templates', 'template_labels',
         'class_thresholds')


def save_codebook(path: str | Path, recogniser: TemplateRecogniser, description: str | None = None,
                  vocabulary: str = 'commands', gap_s: float | None = None,
                  recognisers: Mapping[str, type[TemplateRecogniser]] = RECOGNISERS) -> Path:
    """Write a fitted recogniser's codebook to ``path`` (``.npz`` is appended if missing).

    ``description`` (optional, e.g. how it was recorded and whether the data are synthetic) is
    kept in the file and comes back as the loaded recogniser's ``description_``. ``gap_s``
    defaults to the vocabulary's (:func:`~.segmentation.default_gap_s` of the most strokes
    a template has). ``recognisers``: the registry the file's recogniser must be in (the lab's for its
    own recognisers)."""
    if not hasattr(recogniser, 'templates_'):
        raise ValueError('the recogniser has no codebook yet: fit it (or record one) before saving')
    if recognisers.get(recogniser.name) is not type(recogniser):
        raise ValueError(f'recogniser {recogniser.name!r} is not in the registry ({", ".join(recognisers)}); cannot '
                         'name it in a file')
    max_strokes = int(getattr(recogniser, 'max_strokes_', 1))
    gap_s = default_gap_s(max_strokes) if gap_s is None else float(gap_s)
    if not (np.isfinite(gap_s) and gap_s >= 0) or not str(vocabulary).strip():
        raise ValueError(f'a codebook needs a vocabulary name and a gap >= 0 s; got {vocabulary!r}, {gap_s}')
    path = Path(path)
    if path.suffix != '.npz':
        path = path.with_name(path.name + '.npz')
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:  # whole or not at all: a full disk keeps the previous codebook
        np.savez_compressed(
            tmp, format=np.array(FORMAT), format_version=np.array(FORMAT_VERSION, dtype=np.int64),
            recogniser=np.array(recogniser.name), params=np.array(json.dumps(recogniser.get_params(), sort_keys=True)),
            classes=np.asarray(recogniser.classes_, dtype=str), templates=recogniser.templates_.astype(np.float32),
            template_labels=recogniser.template_labels_.astype(np.int64),
            class_thresholds=np.asarray(recogniser.class_thresholds_, dtype=np.float64),
            vocabulary=np.array(str(vocabulary)), gap_s=np.array(gap_s, dtype=np.float64),
            max_strokes=np.array(max_strokes, dtype=np.int64),
            **({} if description is None else {'description': np.array(str(description))}),
            **({} if getattr(recogniser, 'template_strokes_', None) is None
               else {'template_strokes': np.asarray(recogniser.template_strokes_, dtype=np.int64)}),
            **({} if getattr(recogniser, 'template_contact_s_', None) is None
               else {'template_contact_s': np.asarray(recogniser.template_contact_s_, dtype=np.float64)}),
            **({} if getattr(recogniser, 'template_paths_', None) is None
               else {'template_paths': np.asarray(recogniser.template_paths_, dtype=np.float32)}),
            **({} if getattr(recogniser, 'template_people_', None) is None
               else {'template_people': np.asarray(recogniser.template_people_, dtype=str)}),
            **({} if getattr(recogniser, 'template_sizes_mm_', None) is None
               else {'template_sizes_mm': np.asarray(recogniser.template_sizes_mm_, dtype=np.float64)}),
            **({} if getattr(recogniser, 'acceptance_', None) is None
               else {'acceptance': np.array(json.dumps(recogniser.acceptance_, sort_keys=True))}))
    return path


def load_codebook(path: str | Path, recogniser: str | None = None,
                  recognisers: Mapping[str, type[TemplateRecogniser]] = RECOGNISERS) -> TemplateRecogniser:
    """Read a codebook file into a ready recogniser.

    Args:
        path: the ``.npz`` file.
        recogniser: if given, the file must have been made by this recogniser.
        recognisers: the registry the file's recogniser must be in (default: the runtime's, module doc).

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
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise CodebookError(f'not a readable codebook (.npz without pickled objects; truncated or empty?): '
                            f'{type(err).__name__}: {err}', where) from err
    missing = [k for k in _KEYS if k not in data]
    if missing:
        raise CodebookError(f'missing array(s) {", ".join(missing)}; is this a skin codebook?', where)
    if str(data['format']) != FORMAT:
        raise CodebookError(f"format is {str(data['format'])!r}, expected {FORMAT!r}", where)
    version = int(data['format_version'])
    if version not in READABLE_VERSIONS:
        raise CodebookError(f'format_version {version} is not supported (this code reads '
                            f'{", ".join(map(str, READABLE_VERSIONS))}); record the codebook again', where)
    if version >= 2 and not all(k in data for k in ('vocabulary', 'gap_s', 'max_strokes')):
        raise CodebookError('a version 2 codebook needs vocabulary, gap_s and max_strokes', where)
    name = str(data['recogniser'])
    if name not in recognisers:
        if recognisers is RECOGNISERS:
            raise CodebookError(f'made with recogniser {name!r}, which the robot does not run (it runs '
                                f'{", ".join(RECOGNISERS)}; {name!r} is not one of them: a lab recogniser, '
                                'touch_lab.skin.recognisers, kept to be measured against, or a misspelling'
                                f'{did_you_mean(name, RECOGNISERS)}); record the codebook again with '
                                f'`social-touch codebook record --recogniser {DEFAULT_RECOGNISER}` (single-stroke '
                                f'gestures) or `--recogniser {MULTISTROKE_RECOGNISER}` (multi-stroke)', where)
        raise CodebookError(f'recogniser {name!r} is unknown; known: {", ".join(recognisers)}'
                            f'{did_you_mean(name, recognisers)}', where)
    if recogniser is not None and name != recogniser:
        raise CodebookError(f'the codebook was made for recogniser {name!r}, not {recogniser!r}; record one for '
                            f'{recogniser!r} or use {name!r}', where)
    try:
        params = json.loads(str(data['params']))
        if not isinstance(params, dict):
            raise ValueError('params must be a JSON object')
        model = recogniser_from(recognisers, name, params)
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
        acceptance = json.loads(str(data['acceptance'])) if 'acceptance' in data else None
        if acceptance is not None and not isinstance(acceptance, dict):
            raise ValueError('acceptance must be a JSON object')
    except ValueError as err:
        raise CodebookError(f'bad acceptance record: {err}', where) from err
    try:
        model.set_codebook(templates, classes[codes], class_thresholds=thresholds,
                           template_strokes=data.get('template_strokes'),
                           template_contact_s=data.get('template_contact_s'),
                           template_paths=data.get('template_paths'),
                           template_people=data.get('template_people'), acceptance=acceptance,
                           template_sizes_mm=data.get('template_sizes_mm'))
    except ValueError as err:
        raise CodebookError(str(err), where) from err
    model.description_ = str(data['description']) if 'description' in data else None
    if version == 1:
        model.vocabulary_, model.max_strokes_ = _V1_VOCABULARY
        model.gap_s_ = default_gap_s(model.max_strokes_)
    else:
        model.vocabulary_, model.max_strokes_ = str(data['vocabulary']), int(data['max_strokes'])
        model.gap_s_ = float(data['gap_s'])
        if not (np.isfinite(model.gap_s_) and model.gap_s_ >= 0 and model.max_strokes_ >= 1):
            raise CodebookError(f'gap_s must be >= 0 s and max_strokes >= 1; got {model.gap_s_}, '
                                f'{model.max_strokes_}', where)
    return model


def _feature_size(model: TemplateRecogniser) -> int | None:
    """Length of the model's feature vector, from a probe gesture (a short diagonal stroke)."""
    probe = TouchGesture.from_trajectory(np.array([[10.0, 10.0], [20.0, 15.0], [30.0, 30.0]]))
    features = model.features(probe)
    return None if features is None else len(features)


@dataclass
class CodebookRecorder:
    """Collect ``repetitions`` usable gestures of each name in ``gestures``, in order.

    A touch is refused (with a line saying why and what to do) when it is no traced gesture:
    two fingers, a touch that never ended, too few points or smaller than ``min_extent_mm``
    (:func:`~.screening.screen_gesture`, the same rule as the skin node's). :meth:`undo` drops
    the last kept repetition, :meth:`skip` leaves the current gesture out of the codebook.
    ``person`` names who traces now (set it when another person takes over): ``people`` keeps it
    for each repetition, and the codebook keeps it for each template ('' when not known).

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
    min_points: int = MIN_POINTS
    samples: list[TouchGesture] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    min_extent_mm: float = MIN_EXTENT_MM
    skipped: list[str] = field(default_factory=list)
    person: str = ''
    people: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.gestures = list(self.gestures)
        if not self.gestures or len(set(self.gestures)) != len(self.gestures):
            raise ValueError(f'give one or more distinct gesture names; got {self.gestures}')
        if self.repetitions < 1:
            raise ValueError(f'repetitions must be >= 1, got {self.repetitions}')
        if not (np.isfinite(self.min_extent_mm) and self.min_extent_mm >= 0) or self.min_points < 1:
            raise ValueError(f'need min_extent_mm >= 0 (mm) and min_points >= 1; got {self.min_extent_mm}, '
                             f'{self.min_points}')
        unknown = sorted({*self.labels, *self.skipped} - set(self.gestures))
        if not self.people:
            self.people = [''] * len(self.labels)     # a recording of before people were kept
        if unknown or not (len(self.labels) == len(self.samples) == len(self.people)):
            raise ValueError(f'samples, labels and people must pair up, with labels and skipped among the gestures; '
                             f'got {len(self.samples)} samples, {len(self.labels)} labels, {len(self.people)} people, '
                             f'unknown names {unknown}')

    def count(self, name: str) -> int:
        """Repetitions of ``name`` kept so far."""
        return self.labels.count(name)

    @property
    def done(self) -> bool:
        return self.current is None

    @property
    def current(self) -> str | None:
        """The gesture to trace next (the first not complete and not skipped), or None when done."""
        for name in self.gestures:
            if name not in self.skipped and self.count(name) < self.repetitions:
                return name
        return None

    def add(self, gesture: TouchGesture) -> tuple[bool, str]:
        """Offer one segmented gesture; returns (kept, a line for the person recording)."""
        name = self.current
        if name is None:
            return False, 'the codebook is complete'
        reason = screen_gesture(gesture, self.min_extent_mm, self.min_points)
        if reason == 'multi_contact':
            return False, f'{name}: two fingers seen, trace with one finger and try again'
        if reason == 'truncated':
            return False, f'{name}: the touch did not end, lift the finger after the gesture'
        if reason == 'too_few_points':
            return False, f'{name}: too short ({len(gesture.trajectory)} points), trace the whole gesture'
        if reason == 'too_small':
            return False, (f'{name}: too small ({gesture_extent_mm(gesture):.1f} mm across), trace it over at '
                           f'least {self.min_extent_mm:.0f} mm of the skin')
        self.samples.append(gesture)
        self.labels.append(name)
        self.people.append(self.person)
        return True, f'{name} {self.count(name)}/{self.repetitions}'

    def undo(self) -> str | None:
        """Drop the last kept gesture (a bad repetition); returns its name."""
        if not self.samples:
            return None
        self.samples.pop()
        self.people.pop()
        return self.labels.pop()

    def skip(self) -> str | None:
        """Leave the current gesture out (what was kept of it is dropped); returns its name."""
        name = self.current
        if name is None:
            return None
        self.skipped.append(name)
        keep = [i for i, label in enumerate(self.labels) if label != name]
        self.samples = [self.samples[i] for i in keep]
        self.labels = [self.labels[i] for i in keep]
        self.people = [self.people[i] for i in keep]
        return name

    def fit(self, recogniser: TemplateRecogniser) -> TemplateRecogniser:
        """Fit ``recogniser`` on what was collected (every gesture not skipped needs at least one sample),
        with who drew each repetition."""
        missing = [g for g in self.gestures if g not in self.labels and g not in self.skipped]
        if missing:
            raise ValueError(f'no repetition recorded yet for: {", ".join(missing)}')
        if not self.samples:
            raise ValueError('nothing was recorded: every gesture was skipped')
        return recogniser.fit(self.samples, self.labels, people=self.people)
