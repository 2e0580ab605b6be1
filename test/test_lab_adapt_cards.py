"""Model cards (in every model file, `model info`, `codebook` edits) and adapting a model to a new person."""

from __future__ import annotations

import json

import numpy as np
import pytest

from touch_gestures.model_card import attach_card, card_line, card_log_line, make_card, read_card
from touch_lab.cli.main import main as cli_main


def test_a_card_survives_the_file_and_the_loader_ignores_it(tmp_path):
    from touch_lab.bear.subtype_training import SubtypeClassifier
    rng = np.random.default_rng(0)
    from touch_gestures.bear.features import FEATURE_NAMES
    X = rng.random((200, len(FEATURE_NAMES))).astype(np.float32)
    y = np.where(X[:, 0] > 0.5, 'hold', 'poke')
    path = tmp_path / 'bear.npz'
    SubtypeClassifier().fit(X, y).save(path, rate_hz=3.4, buffer_len=20)
    assert read_card(path) is None and 'no model card' in card_log_line(path)
    card = make_card('bear_subtype_model', command='social-touch train bear --bags a b',
                     data={'synthetic': False, 'source': 'recorded', 'people': 2},
                     evaluation={'method': 'leave-one-person-out', 'subtype_accuracy': 0.8125})
    attach_card(path, card)
    assert read_card(path) == card
    loaded = SubtypeClassifier.load(path)   # the loader reads the model as before
    assert list(loaded.classes_) == ['poke', 'hold'] and loaded.trained_rate_hz_ == 3.4
    line = card_line(card)
    assert 'recorded data (recorded), 2 people' in line and 'subtype_accuracy 0.812' in line
    assert 'made by social-touch train bear --bags a b' in line
    with pytest.raises(ValueError, match='kind must be one of'):
        make_card('toaster')


def test_model_info_and_card_commands(tmp_path, capsys):
    from touch_gestures.bear.features import FEATURE_NAMES
    from touch_lab.bear.subtype_training import SubtypeClassifier
    X = np.random.default_rng(1).random((100, len(FEATURE_NAMES))).astype(np.float32)
    path = tmp_path / 'm.npz'
    SubtypeClassifier().fit(X, np.where(X[:, 1] > 0.5, 'pet', 'tap')).save(path, rate_hz=3.4, buffer_len=20)
    assert cli_main(['model', 'info', str(path)]) == 0
    assert 'no model card' in capsys.readouterr().out
    report = tmp_path / 'eval.json'
    report.write_text(json.dumps({'model': {'accuracy': 0.7, 'confusion': [[1]]}, 'synthetic': True}))
    assert cli_main(['model', 'card', str(path), '--evaluation', str(report), '--evaluation-command',
                     'social-touch eval bear --bags x']) == 0
    assert read_card(path)['evaluation']['model.accuracy'] == 0.7
    capsys.readouterr()
    assert cli_main(['model', 'info', str(path)]) == 0
    out = capsys.readouterr().out
    assert out.index('kind: bear_subtype_model') < out.index('evaluation:') and 'trained at 3.4 Hz' in out
    (tmp_path / 'junk.npz').write_bytes(b'not a zip')
    assert cli_main(['model', 'info', str(tmp_path / 'junk.npz')]) == 2
    assert 'not a readable .npz' in capsys.readouterr().err


def test_codebook_remove_and_merge_write_new_files_with_cards(tmp_path, capsys):
    from touch_gestures.skin.codebook import load_codebook, save_codebook
    from touch_gestures.skin.registry import make_recogniser
    rng = np.random.default_rng(2)
    model = make_recogniser('trace')
    d = 64
    model.set_codebook(rng.random((9, d)).astype(np.float32), ['a'] * 3 + ['b'] * 3 + ['c'] * 3)
    path = save_codebook(tmp_path / 'book.npz', model)
    try:
        model.set_codebook(rng.random((9, d)).astype(np.float32), ['a'] * 3 + ['b'] * 3 + ['c'] * 3)
    except ValueError:
        pytest.skip('the trace recogniser wants another feature size')
    assert cli_main(['codebook', 'remove', str(path), '--gestures', 'b', '-o', str(tmp_path / 'no_b.npz')]) == 0
    assert list(load_codebook(tmp_path / 'no_b.npz').classes_) == ['a', 'c']
    assert read_card(tmp_path / 'no_b.npz')['data']['synthetic'] is None   # the source did not say
    assert cli_main(['codebook', 'merge', str(path), str(tmp_path / 'no_b.npz'), '-o', str(tmp_path / 'm.npz')]) == 0
    assert len(load_codebook(tmp_path / 'm.npz').templates_) == 9 + 6
    assert cli_main(['codebook', 'remove', str(path), '--gestures', 'z', '-o', str(tmp_path / 'x.npz')]) == 2
    assert 'has no gesture z' in capsys.readouterr().err
    assert cli_main(['codebook', 'info', str(tmp_path / 'm.npz')]) == 0
    assert 'kind: skin_codebook' in capsys.readouterr().out


def test_patch_adaptation_moves_the_means_towards_the_new_person_by_the_evidence():
    from touch_lab.adapt import adapt_patch
    from touch_lab.patch.training import PatchGestureClassifier
    rng = np.random.default_rng(3)
    X = np.concatenate([rng.normal(0, 1, (400, 3)), rng.normal(4, 1, (400, 3))])
    y = np.array(['push'] * 400 + ['slap'] * 400)
    clf = PatchGestureClassifier(n_components=2, random_state=0).fit(X, y)
    new = rng.normal(1.5, 1, (200, 3))   # this person pushes differently
    adapted = adapt_patch(clf, new, np.array(['push'] * 200))
    assert adapted.log_likelihood(new).mean() > clf.log_likelihood(new).mean()
    slap = clf.params_.component_class == 1
    np.testing.assert_array_equal(adapted.params_.means[slap], clf.params_.means[slap])   # no slap frames: unchanged
    barely = adapt_patch(clf, new, np.array(['push'] * 200), relevance=1e9)
    np.testing.assert_allclose(barely.params_.means, clf.params_.means, atol=1e-5)
    with pytest.raises(ValueError, match='relevance'):
        adapt_patch(clf, new, np.array(['push'] * 200), relevance=0)


def test_bear_adaptation_learns_the_new_rows_and_stays_near_the_model_with_a_strong_prior():
    from touch_gestures.bear.features import FEATURE_NAMES
    from touch_gestures.bear.subtype_labels import subtype_index
    from touch_lab.adapt import adapt_bear
    from touch_lab.bear.subtype_training import SubtypeClassifier
    rng = np.random.default_rng(4)
    X = rng.random((600, len(FEATURE_NAMES))).astype(np.float32)
    y = np.where(X[:, 0] > 0.5, 'hold', 'pet')
    model = SubtypeClassifier().fit(X, y)
    Xn = rng.random((60, len(FEATURE_NAMES))).astype(np.float32)
    yn = np.where(Xn[:, 0] > 0.5, subtype_index('pet'), subtype_index('hold'))   # this person's are the other way
    before = np.mean(model.predict_codes(Xn)[0] == yn)
    after = np.mean(adapt_bear(model, Xn, yn, lam=0.01).predict_codes(Xn)[0] == yn)
    assert after > before + 0.3
    stiff = adapt_bear(model, Xn, yn, lam=1e6)
    np.testing.assert_allclose(stiff.coef_, model.coef_, atol=1e-3)
