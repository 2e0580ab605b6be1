"""Adapt a deployed model to one person from a few labelled examples (a short ``collect`` run).

The deployed model is the prior; the update moves it towards the person:

- **patch** (Gaussian mixtures): MAP adaptation of the component means (Reynolds, Quatieri and Dunn
  2000): ``a_k = n_k / (n_k + r)``, the mean becomes ``a_k m_k + (1 - a_k) mu_k`` (``n_k`` the summed
  responsibilities, ``m_k`` the weighted mean of the new frames, ``r`` the relevance in frames).
- **bear** (logistic regression): the new rows' cross-entropy plus ``lam / 2 * ||W - W0||^2`` (L-BFGS).
- **skin** (codebook): the person's touches are added as templates.

The adapted file's card names the model it started from and the examples it took.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize
from scipy.special import logsumexp

from touch_gestures.bear.subtype_labels import SUBTYPES
from touch_gestures.bear.subtype_model import _transform
from touch_gestures.model_card import attach_card, make_card, read_card
from touch_gestures.patch.classifier import precision_cholesky
from touch_gestures.patch.features import window_features
from touch_gestures.patch.model_io import load_model, save_model
from touch_gestures.skin.codebook import load_codebook, save_codebook
from touch_graph.cli.options import non_negative_float, positive_float
from touch_graph.errors import SocialTouchError
from touch_lab.bear.sessions import load_runs, train_rows
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.collect.coverage import read_checked
from touch_lab.patch.session_bags import trial_sessions
from touch_lab.patch.training import PatchGestureClassifier
from touch_lab.skin.sessions import fit_codebook, load_trials, usable

__all__ = ['adapt_bear', 'adapt_patch', 'add_arguments', 'run']


def adapt_patch(clf, X: np.ndarray, y: np.ndarray, relevance: float = 16.0):
    """A new ``PatchGestureClassifier`` whose component means are MAP-adapted to ``X`` (n, d) labelled ``y``."""
    if not relevance > 0:
        raise ValueError(f'relevance must be > 0 frames; got {relevance}')
    p = clf.params_
    Z = (np.asarray(X, dtype=np.float64) - p.feature_mean) / p.feature_scale
    means = p.means.copy()
    chol = precision_cholesky(p.covariances)          # (K, d, d)
    for ci, name in enumerate(p.classes):
        rows = Z[np.asarray(y) == name]
        rows = rows[np.isfinite(rows).all(axis=1)]
        if not len(rows):
            continue
        comps = np.flatnonzero(p.component_class == ci)
        # log w_k + log N(z | mu_k, Sigma_k), in the log domain (d = 12: no underflow games)
        log_p = np.empty((len(rows), len(comps)))
        for j, k in enumerate(comps):
            u = (rows - p.means[k]) @ chol[k]
            log_p[:, j] = (np.log(p.weights[k]) + np.log(np.diag(chol[k])).sum()
                           - 0.5 * (u * u).sum(axis=1) - 0.5 * rows.shape[1] * np.log(2 * np.pi))
        gamma = np.exp(log_p - logsumexp(log_p, axis=1, keepdims=True))   # (n, k) responsibilities
        n_k = gamma.sum(axis=0)
        m_k = (gamma.T @ rows) / np.maximum(n_k, 1e-12)[:, None]
        alpha = (n_k / (n_k + relevance))[:, None]
        means[comps] = alpha * m_k + (1 - alpha) * p.means[comps]
    return PatchGestureClassifier.from_params(replace(p, means=means), threshold=clf.threshold)


def adapt_bear(model, X: np.ndarray, y: np.ndarray, lam: float = 1.0, max_iter: int = 200):
    """A new ``SubtypeClassifier``: ``model``'s weights moved towards rows ``X`` with codes ``y`` (module doc).

    Classes of ``y`` the model does not know are left out (a few examples cannot found a class).
    """
    if not lam > 0:
        raise ValueError(f'lam must be > 0; got {lam}')
    names = list(model.classes_)
    index = {n: i for i, n in enumerate(names)}
    labels = [SUBTYPES[int(c)] for c in y]
    keep = np.array([name in index for name in labels])
    if not keep.any():
        return model
    relative = getattr(model, 'relative', False)
    Zs = (_transform(np.asarray(X)[keep], relative).astype(np.float64) - model.mean_) / model.scale_
    t = np.array([index[n] for n, k in zip(labels, keep, strict=True) if k])
    W0 = np.concatenate([model.coef_, model.intercept_[:, None]], axis=1).astype(np.float64)   # (C, d + 1)
    A = np.concatenate([Zs, np.ones((len(Zs), 1))], axis=1)
    onehot = np.eye(len(names))[t]
    n = len(A)

    def loss(w_flat: np.ndarray) -> tuple[float, np.ndarray]:
        W = w_flat.reshape(W0.shape)
        z = A @ W.T
        log_p = z - logsumexp(z, axis=1, keepdims=True)
        diff = W - W0
        value = -(onehot * log_p).sum() / n + 0.5 * lam * (diff * diff).sum()
        grad = ((np.exp(log_p) - onehot).T @ A) / n + lam * diff
        return float(value), grad.ravel()

    w = minimize(loss, W0.ravel(), jac=True, method='L-BFGS-B', options={'maxiter': max_iter}).x.reshape(W0.shape)
    out = SubtypeClassifier(C=model.C, class_weight=model.class_weight, max_iter=model.max_iter, relative=relative)
    out._set(names, model.mean_, model.scale_, w[:, :-1], w[:, -1])
    for attr in ('trained_rate_hz_', 'trained_buffer_len_'):
        setattr(out, attr, getattr(model, attr, None))
    return out


# ----------------------------------------------------------------------------- command
def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch adapt``."""
    parser.add_argument('sensor', choices=('bear', 'patch', 'skin'))
    parser.add_argument('--model', required=True, help='the deployed model (bear, patch) or codebook (skin)')
    parser.add_argument('--bags', nargs='+', required=True, metavar='BAG',
                        help="the person's session bags (social-touch collect SENSOR --repetitions 3)")
    parser.add_argument('--output', '-o', required=True, help='the adapted file to write')
    parser.add_argument('--relevance', type=positive_float, default=16.0,
                        help='patch: MAP relevance factor, frames (16)')
    parser.add_argument('--lam', type=non_negative_float, default=1.0,
                        help='bear: pull towards the deployed weights (1)')


def run(args: argparse.Namespace) -> int:
    """Adapt and write; 2 with one line on stderr on bad input."""
    def say(msg: str) -> None:
        print(f'[adapt {args.sensor}] {msg}', file=sys.stderr, flush=True)

    try:
        taken = _ADAPT[args.sensor](args, say)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch adapt {args.sensor}: error: {err}', file=sys.stderr)
        return 2
    prior = read_card(args.model) or {}
    kind = {'bear': 'bear_subtype_model', 'patch': 'patch_gesture_model', 'skin': 'skin_codebook'}[args.sensor]
    attach_card(args.output, make_card(kind, data={
        'synthetic': bool(prior.get('data', {}).get('synthetic')) or taken['synthetic'],
        'adapted_from': str(args.model), 'adapted_from_card': prior.get('data', {}),
        'people': len(taken['people']), 'adapted_to': taken['people'], 'bags': list(args.bags),
        'trials_per_class': taken['per_class']}))
    say(f'wrote {args.output}: adapted to {", ".join(taken["people"])} from {sum(taken["per_class"].values())} trials')
    return 0


def _taken(labels, synthetic: bool) -> dict:
    rows = list(labels)
    return {'people': sorted({p for p, _ in rows}), 'per_class': dict(sorted(Counter(c for _, c in rows).items())),
            'synthetic': synthetic}


def _adapt_patch(args: argparse.Namespace, say) -> dict:
    deployed = load_model(args.model)
    sessions = trial_sessions(read_checked(args.bags, 'patch', say), say)
    X = np.concatenate([window_features(s.activations, deployed.window) for s in sessions])
    y = np.concatenate([[s.gesture] * s.n_frames for s in sessions])
    clf = adapt_patch(deployed.classifier, X, y, args.relevance)
    save_model(args.output, replace(deployed, classifier=clf))
    return _taken(((s.subject, s.gesture) for s in sessions), any(s.synthetic for s in sessions))


def _adapt_bear(args: argparse.Namespace, say) -> dict:
    model = SubtypeClassifier.load(args.model)
    runs = load_runs(args.bags, model.trained_rate_hz_ or 3.4, model.trained_buffer_len_ or 20, say)
    X, y = train_rows(runs)
    adapted = adapt_bear(model, X, y, args.lam)
    adapted.save(args.output, rate_hz=model.trained_rate_hz_, buffer_len=model.trained_buffer_len_)
    return _taken(((lab.person, lab.gesture) for r in runs for lab in r.labels), any(r.session.synthetic for r in runs))


def _adapt_skin(args: argparse.Namespace, say) -> dict:
    base = load_codebook(args.model)
    trials, synthetic = load_trials(args.bags, say)
    save_codebook(args.output, fit_codebook(trials, base.name, base=base),
                  description=f'{args.model} adapted to new people (see its model card)')
    return _taken(((t.label.person, t.label.gesture) for t in usable(trials)), synthetic)


_ADAPT = {'bear': _adapt_bear, 'patch': _adapt_patch, 'skin': _adapt_skin}
