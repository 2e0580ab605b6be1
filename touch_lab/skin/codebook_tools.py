"""Edit skin codebooks: extend one with new touches, remove a gesture, merge two (``social-touch codebook``).

Templates are feature vectors of one recogniser with one set of parameters; two codebooks merge
only when both match (the file format checks the same at load, :mod:`touch_gestures.skin.codebook`).
Every edit recomputes the per-class rejection thresholds from the templates it keeps, as ``fit`` does.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.recognisers import make_recogniser

__all__ = ['extend_codebook', 'merge_codebooks', 'remove_gestures', 'template_labels']


def template_labels(model: TemplateRecogniser) -> np.ndarray:
    """(T,) gesture name of every template of a fitted recogniser."""
    return np.asarray(model.classes_)[model.template_labels_]


def _fresh(model: TemplateRecogniser, templates: np.ndarray, labels: Sequence[str]) -> TemplateRecogniser:
    out = make_recogniser(model.name, **model.get_params())
    out.set_codebook(templates, labels)
    return out


def extend_codebook(model: TemplateRecogniser, gestures: Sequence[TouchGesture],
                    labels: Sequence[str]) -> TemplateRecogniser:
    """A new recogniser with ``model``'s templates plus one per usable gesture of ``gestures``.

    Raises:
        ValueError: lengths differ or none of the gestures gives a template.
    """
    if len(gestures) != len(labels):
        raise ValueError(f'one label per gesture; got {len(gestures)} gestures and {len(labels)} labels')
    new = make_recogniser(model.name, **model.get_params()).fit(gestures, labels)
    return _fresh(model, np.concatenate([model.templates_, new.templates_]),
                  [*template_labels(model), *template_labels(new)])


def remove_gestures(model: TemplateRecogniser, names: Sequence[str]) -> TemplateRecogniser:
    """A new recogniser without the templates of ``names`` (ValueError for a name it does not know)."""
    unknown = sorted(set(names) - set(model.classes_))
    if unknown:
        raise ValueError(f'the codebook has no gesture {", ".join(unknown)}; it has {", ".join(model.classes_)}')
    labels = template_labels(model)
    keep = ~np.isin(labels, list(names))
    if len(set(labels[keep])) < 1:
        raise ValueError('removing them leaves an empty codebook')
    return _fresh(model, model.templates_[keep], labels[keep])


def merge_codebooks(a: TemplateRecogniser, b: TemplateRecogniser) -> TemplateRecogniser:
    """The templates of both (same recogniser and parameters, else ValueError)."""
    if a.name != b.name or a.get_params() != b.get_params():
        raise ValueError(f'codebooks of different recognisers or parameters cannot merge: {a.name} '
                         f'{a.get_params()} and {b.name} {b.get_params()}')
    return _fresh(a, np.concatenate([a.templates_, b.templates_]), [*template_labels(a), *template_labels(b)])
