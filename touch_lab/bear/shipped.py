"""Score a given subtype model on recorded sessions without retraining (``eval bear --bags ... --model FILE``).

The model classifies every trial as it ships (behind the ``NoTouchGate``), the paper's rule beside it;
the symbolic gestures run through the real :class:`~touch_gestures.bear.symbolic.SymbolicRecogniser` fed the
model's subtype codes. Per symbolic gesture ``g``, pooled over all trials of all people:

- *detected*: trials of ``g`` during which ``g`` STARTed (up to :func:`~.evaluate.start_grace_s` after
  their end), over the trials of ``g``;
- *false starts*: STARTs of ``g`` no trial of ``g`` explains (another gesture's trial, a subtype trial of
  another subtype than ``g``'s, or outside every trial); ``false_starts_by_cause`` splits them;
- *latency*: trial start to ``g``'s first START, s; ``median_latency_s`` over detected trials.
"""

from __future__ import annotations

from collections.abc import Callable

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.subtype import PaperRuleClassifier
from touch_gestures.bear.subtype_labels import SUBTYPES
from touch_gestures.bear.symbolic import GestureLibrary
from touch_lab.bear.evaluate import percent_text, seconds_text

from .false_starts import runs_gesture_starts as score_symbolic_starts
from .false_starts import summarise
from .sessions import BearTrials, pool_scores, score_trials
from .suggest import _run_library, trial_codes

__all__ = ['STATISTICS', 'format_scores', 'score_model', 'score_symbolic_starts']

#: What each pooled figure of :func:`score_model` is, in words (the JSON carries it).
STATISTICS = {
    'accuracy': 'correct trials / trials, over all trials of all people',
    'median_latency_s': 'median over all detected trials of all people (not a median of per-person medians)',
    'p90_latency_s': '90th percentile over all detected trials of all people',
    'per_person': 'accuracy over each person\'s own trials',
    'detected': 'trials of the gesture during which it STARTed, over all trials of all people',
    'false_starts': 'STARTs of the gesture no trial of it explains, summed over all sessions',
}


def score_model(runs: list[BearTrials], model, library: GestureLibrary, body_map: BodyMap | None = None,
                progress: Callable[[str], None] | None = None, fold_models: dict | None = None) -> dict:
    """Scores of ``model`` (a ``SubtypeClassifier``, as it ships) on every person of ``runs``, and of the rule.

    ``fold_models`` (person -> model), when given, classifies each person's sessions instead of ``model``
    (leave-one-person-out). Returns ``people``, ``model`` and ``rule`` (pooled subtype scores of
    :func:`~.sessions.score_trials`), ``per_person`` (model accuracy), ``symbolic`` (detections, false
    starts and latency per gesture with the model's codes) and ``statistics`` (what each figure is).
    """
    say = progress or (lambda _m: None)
    body_map = body_map or BodyMap.default()
    people = sorted({lab.person for run in runs for lab in (*run.labels, *run.gestures)})
    subtype, rule, starts = {}, {}, []
    runs_in_order = []
    for person in people:
        mine = [r for r in runs if any(lab.person == person for lab in (*r.labels, *r.gestures))]
        predictor = NoTouchGate((fold_models or {}).get(person, model))
        subtype[person] = score_trials(mine, predictor)
        rule[person] = score_trials(mine, NoTouchGate(PaperRuleClassifier()))
        for run in mine:
            if any(run is r for r in runs_in_order):
                continue
            say(f'symbolic gestures over {run.session.path}')
            starts.append(_run_library(run, trial_codes(run, predictor), library, body_map))
            runs_in_order.append(run)
    symbolic = summarise(score_symbolic_starts(runs_in_order, starts, library))
    return {'people': people, 'model': pool_scores(subtype), 'rule': pool_scores(rule),
            'per_person': {p: subtype[p]['accuracy'] for p in people},
            'symbolic': symbolic, 'statistics': STATISTICS}


def format_scores(result: dict, synthetic: bool) -> str:
    """The text report of :func:`score_model` (with the ``method`` line the command adds)."""
    m, r, sym = result['model'], result['rule'], result['symbolic']
    data = 'SYNTHETIC: simulated people' if synthetic else 'recorded sessions'
    lines = [f"Sensate Bear on {len(result['people'])} people ({data})", f"method: {result['method']}",
             f"{'':44s} {'subtype model':>14s} {'paper rule':>12s}",
             f"{'subtype accuracy (over all trials)':44s} {percent_text(m['accuracy']):>14s} "
             f"{percent_text(r['accuracy']):>12s}",
             f"{'trials':44s} {m['trials']:>14d} {r['trials']:>12d}",
             f"{'median detection latency (over all trials)':44s} {seconds_text(m['median_latency_s']):>14s} "
             f"{seconds_text(r['median_latency_s']):>12s}",
             '', 'per person (subtype model): ' + ', '.join(f'{p} {percent_text(a).strip()}'
                                                          for p, a in result['per_person'].items()),
             '', 'subtype confusion (model; rows true, columns predicted)',
             '  ' + ' '.join(f'{s[:6]:>6s}' for s in ['', *SUBTYPES])]
    for name, row in zip(SUBTYPES, m['confusion'], strict=True):
        if row.sum():
            lines.append('  ' + f'{name[:6]:>6s} ' + ' '.join(f'{int(v):6d}' for v in row))
    lines += ['', f"symbolic gestures ({result.get('gestures', '')}): detected {sym['detected']} / {sym['trials']} "
              f"({percent_text(sym['detected_fraction']).strip()}), false starts {sym['false_starts']}, median latency "
              f"{seconds_text(sym['median_latency_s'])} (over all detected trials)",
              f"  {'gesture':13s} {'detected':>10s} {'false starts':>13s} {'(other gesture / subtype / outside)':>36s} "
              f"{'latency':>8s}"]
    for name, g in sym['per_gesture'].items():
        if not g['trials'] and not g['false_starts']:
            continue
        c = g['false_starts_by_cause']
        lines.append(f"  {name:13s} {g['detected']:>4d} / {g['trials']:<3d} {g['false_starts']:>13d} "
                     f"{c['other_gesture']:>17d} / {c['subtype_trial']:>3d} / {c['outside_trials']:>3d}      "
                     f"{seconds_text(g['median_latency_s']):>8s}")
    return '\n'.join(lines)
