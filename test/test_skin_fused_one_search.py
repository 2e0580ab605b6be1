"""The fused recogniser searches the trace once per touch, its decisions unchanged (issue 26 item 2).

Gestures are synthetic (test/test_skin_codebook_people.py's letters and random corners). The decisions before the
mend are main's own, kept in test/data/skin_codebook_main_2e02c34_decisions.npz (test/test_skin_size_evidence.py);
here each decision is also checked against the score computed the way it was before: the second opinion asked again.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_skin_acceptance import people_codebook, scribbles
from test_skin_codebook_people import drawn

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.doubt import CONTEXT_FEATURES
from touch_lab.skin.acceptance import calibrate_acceptance


def touches(rng):
    return scribbles(rng, 40) + drawn(rng, people=1, per_person=3, backwards=())[0]


@pytest.mark.parametrize('context', [('disagreement',), CONTEXT_FEATURES])
def test_a_fused_decision_searches_the_trace_once_and_decides_as_asking_again(monkeypatch, context):
    model, rng = people_codebook(name='fused')
    calibrate_acceptance(model, 0.005, scribbles(rng, 80), context=context)
    assert len(model.acceptance_['score_weights']) > 5   # the context is read
    gestures = touches(np.random.default_rng(8))
    searches = []
    trace = model.trace_
    search = trace.class_distances
    monkeypatch.setattr(trace, 'class_distances', lambda g: searches.append(g) or search(g))
    matches = model.predict_many(gestures)
    usable = [g for g in gestures if model.cloud_.features(g) is not None]
    assert len(searches) == len(usable)   # one trace search per touch the cloud reads
    # As before: the second opinion asked again for the score's context.
    assert {m.rejected for m in matches} >= {None, 'score'}
    for g, match in zip(gestures, matches, strict=True):
        per_class = model.class_distances(g)
        allowed = model.codebook_evidence_.allowed(g)
        if allowed is not None and (allowed.all() or not allowed.any()):
            allowed = None
        best = model._nearest(g, per_class, allowed)
        again, _ = model._decide(per_class, best, allowed, g, model.opinions(g, per_class)[1])
        if match.rejected not in ('strokes', 'duration', 'order'):   # the later checks come after the decision
            assert again == match


def test_a_recogniser_of_one_opinion_hands_on_none():
    model, rng = people_codebook(name='trace')
    g = scribbles(rng, 1)[0]
    per_class = model.class_distances(g)
    assert model._named(g, per_class, None) == (model._nearest(g, per_class, None), None)
    assert TemplateRecogniser._named is type(model)._named
