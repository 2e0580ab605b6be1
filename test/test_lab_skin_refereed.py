"""The cloud refereed by $N on its near ties (touch_lab.skin.recognisers.refereed), on synthetic symbols."""

from __future__ import annotations

import numpy as np
import pytest
from test_skin_multistroke import codebook

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.early import ordered_recogniser
from touch_lab.skin.recognisers import load_codebook, save_codebook
from touch_lab.skin.recognisers.refereed import RefereedRecogniser

NAMES = ('X', 'plus', 'H', 'T', 'Z')


@pytest.fixture(scope='module')
def fitted():
    gestures, labels = codebook(np.random.default_rng(0), names=NAMES, per_class=10)
    return RefereedRecogniser().fit(gestures, labels), CloudRecogniser().fit(gestures, labels)


def held_out():
    return codebook(np.random.default_rng(5), names=NAMES, per_class=4)


def test_it_fires_the_commands_the_cloud_fires_and_names_one_of_its_two_nearest(fitted):
    refereed, cloud = fitted
    gestures, labels = held_out()
    for g in gestures:
        mine, its = refereed.predict(g), cloud.predict(g)
        assert mine.label == its.label          # a tie stays a tie for the rejection rule
        top_two = cloud.classes_[np.argsort(cloud.class_distances(g))[:2]]
        assert mine.nearest in top_two
    assert np.mean([refereed.predict(g).nearest == y for g, y in zip(gestures, labels, strict=True)]) >= 0.9


class _Referee:
    """Stands in for $N: prefers class 1, and counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def class_distances_among(self, gesture, classes):
        self.calls += 1
        return np.array([2.0, 1.0, 3.0, 3.0, 3.0])[list(classes)]


def test_the_referee_is_asked_only_when_the_two_nearest_tie_by_the_margin_rule(fitted):
    refereed, _ = fitted
    judge, g = _Referee(), held_out()[0][0]
    saved = refereed.ndollar_
    try:
        refereed.ndollar_ = judge
        tie = np.array([1.0, 1.0 + 0.5 * refereed.min_margin, 3.0, 4.0, 5.0])
        assert refereed._nearest(g, tie, None) == 1 and judge.calls == 1
        clear = np.array([1.0, 1.0 + 2 * refereed.min_margin, 3.0, 4.0, 5.0])
        assert refereed._nearest(g, clear, None) == 0 and judge.calls == 1
        # The rival is the nearest class the evidence allows: here class 2, too far to tie.
        allowed = np.array([True, False, True, True, True])
        assert refereed._nearest(g, tie, allowed) == 0 and judge.calls == 1
        assert refereed._nearest(g, tie, np.array([True, False, False, False, False])) == 0   # no rival
    finally:
        refereed.ndollar_ = saved


def test_a_refereed_codebook_file_loads_with_both_parts_and_ends_gestures_by_its_cloud(fitted, tmp_path):
    refereed, _ = fitted
    loaded = load_codebook(save_codebook(tmp_path / 'symbols.npz', refereed, vocabulary='symbols'))
    assert isinstance(loaded, RefereedRecogniser) and ordered_recogniser(loaded) is loaded.cloud_
    for g in held_out()[0]:
        assert loaded.predict(g) == refereed.predict(g)
    with pytest.raises(ValueError, match='n_points'):
        RefereedRecogniser(n_points=1).fit(*codebook(np.random.default_rng(1), names=NAMES, per_class=2))
    with pytest.raises(ValueError, match='side by side'):
        RefereedRecogniser().set_codebook(refereed.templates_[:, :10], refereed.classes_[refereed.template_labels_])


def test_a_refit_after_set_params_makes_templates_of_the_new_sizes():
    gestures, labels = codebook(np.random.default_rng(2), names=NAMES, per_class=6)
    refit = RefereedRecogniser().fit(gestures, labels).set_params(n_points=16).fit(gestures, labels)
    fresh = RefereedRecogniser(n_points=16).fit(gestures, labels)
    np.testing.assert_array_equal(refit.templates_, fresh.templates_)
    assert all(refit.predict(g) == fresh.predict(g) for g in held_out()[0])
