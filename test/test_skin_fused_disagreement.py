"""The fused recogniser's disagreement rule (issue 26): where the cloud's first class rejects the one named."""

from __future__ import annotations

import numpy as np
import pytest
from test_lab_skin_refereed import NAMES, held_out
from test_skin_multistroke import codebook

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.fused import FusedRecogniser, confused_pairs


@pytest.fixture(scope='module')
def training():
    return codebook(np.random.default_rng(0), names=NAMES, per_class=10)


@pytest.fixture(scope='module')
def both(training):
    gestures, labels = training
    return (FusedRecogniser(disagreement='always').fit(gestures, labels),
            FusedRecogniser().fit(gestures, labels))


class _Rows(TemplateRecogniser):
    """Stands in for a reading: distances of a query (a row index) from a fixed (Q, R) matrix."""

    def __init__(self, matrix) -> None:
        self.matrix = np.asarray(matrix, dtype=np.float64)

    def distances(self, query):
        return self.matrix[int(query[0])]


def test_pairs_are_confused_where_a_templates_nearest_other_is_of_the_other_class():
    labels = np.array([0, 0, 1, 1, 2])
    # Template 1 (class 0) is nearest template 2 (class 1); every other template's nearest is its own class,
    # but for template 4, alone in class 2, whose nearest is template 3 (class 1).
    d = np.array([[0, 1, 5, 5, 5],
                  [1, 0, .5, 5, 5],
                  [5, 5, 0, 1, 5],
                  [5, 5, 1, 0, 5],
                  [5, 5, 5, 2, 0]])
    out = confused_pairs(labels, 3, [(_Rows(d), np.arange(5)[:, None], np.arange(5))])
    assert out.tolist() == [[False, True, False], [True, False, True], [False, True, False]]


def test_a_reading_with_several_rows_per_template_leaves_all_of_its_own_out():
    labels = np.array([0, 1])
    # Rows 0 and 1 are template 0 (two stroke orders), row 2 template 1: template 0's nearest other row is 2.
    d = np.array([[0, 0, 3], [3, 3, 0]])
    out = confused_pairs(labels, 2, [(_Rows(d), np.array([[0], [1]]), np.array([0, 0, 1]))])
    assert out[0, 1] and out[1, 0]


def test_a_template_alone_with_nothing_to_compare_confuses_nothing():
    out = confused_pairs(np.array([0]), 1, [(_Rows([[0.0]]), np.array([[0]]), np.array([0]))])
    assert out.tolist() == [[False]]


def test_the_rule_names_the_same_class_and_fires_a_superset_of_always(both):
    always, confused = both
    assert always.confused_ is None
    assert confused.confused_.shape == (len(NAMES), len(NAMES))
    assert (confused.confused_ == confused.confused_.T).all() and not confused.confused_.diagonal().any()
    for g in held_out()[0]:
        a, c = always.predict(g), confused.predict(g)
        assert a.nearest == c.nearest
        if a.label is not None:
            assert c == a


def test_a_disagreement_of_an_unconfused_pair_is_decided_against_the_others(both):
    _, fused = both
    n = len(NAMES)
    unit = 0.1 * float(fused.class_thresholds_.min())   # distances well within every class's threshold
    per_class = unit * np.array([1.0, 1.2, 3.0, 4.0, 5.0])   # the cloud puts class 0 first, the sum rule named 1
    saved = fused.confused_.copy()
    try:
        fused.confused_[:] = False
        match, best = fused._decide(per_class, 1)
        assert best == 1 and match.label == fused.classes_[1] and match.margin == pytest.approx(unit * (3.0 - 1.2))
        fused.confused_[0, 1] = fused.confused_[1, 0] = True   # a pair the codebook confuses: rejected
        match, _ = fused._decide(per_class, 1)
        assert match.label is None and match.rejected == 'margin' and match.margin < 0
        fused.confused_[:] = False   # a third class nearer still: still rejected
        match, _ = fused._decide(unit * np.array([1.0, 1.3, 1.1, 4.0, 5.0]), 1)
        assert match.label is None and match.margin < 0
        match, _ = fused._decide(np.full(n, np.nan), 1)   # unreadable distances fire nothing
        assert match.label is None
    finally:
        fused.confused_[:] = saved


def test_an_unknown_rule_is_refused():
    with pytest.raises(ValueError, match='disagreement'):
        FusedRecogniser(disagreement='never').fit(*codebook(np.random.default_rng(1), names=NAMES, per_class=2))
