"""Regenerate docs/bear-evaluation.md and docs/bear-rates.md from measurements (synthetic people).

    social-touch report bear                 # full report, several minutes on one core
    social-touch report bear --quick         # fewer people and configurations, for a look

Everything measured here runs through the robot's graph (virtual bear -> ``bear_driver`` node, its
decoder and calibrator -> recognisers, :class:`~touch_sim.bear.render.BearCycles`) on simulated
people; every table says so.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Collection
from pathlib import Path

import numpy as np

from touch_gestures.bear.features import FEATURE_NAMES
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.subtype import PaperRuleClassifier
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES
from touch_gestures.bear.symbolic import GestureLibrary
from touch_graph.cli.options import add_output, seed
from touch_graph.files import write_text
from touch_graph.paths import share_file
from touch_lab.bear.bench import bench_cycle
from touch_lab.bear.evaluate import (
    EvalConfig,
    bear_cycles,
    collect_training_rows,
    evaluate,
    run_scene,
    score_symbolic,
    stderr_progress,
)
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.bear.transfer import cross_population
from touch_sim.bear.people import BearScene, Contact, make_scene

__all__ = ['add_arguments', 'alias_table', 'compare_models', 'gap_sweep', 'populations_md', 'run',
           'speed_error_table']


SYNTHETIC = ('All figures: **synthetic** data (simulated people: drawn from knight2009 Table II statistics, and, '
             'where said, the second family of hands over plates; on a virtual bear read by the bear_driver node: '
             'its decoder and calibrator), not recordings of real people.')


def _fmt(value, digits: int = 2) -> str:
    if value is None:
        return 'n/a'
    if isinstance(value, float):
        return f'{value:.{digits}f}'
    return str(value)


def _matrix_md(labels: list[str], matrix: list[list[int]]) -> str:
    head = '| true \\ predicted | ' + ' | '.join(labels) + ' |'
    rule = '|---' * (len(labels) + 1) + '|'
    rows = [f'| {name} | ' + ' | '.join(str(v) for v in row) + ' |' for name, row in zip(labels, matrix, strict=True)]
    return '\n'.join([head, rule, *rows])


# ---------------------------------------------------------------------------------------------- measurements
def speed_error_table(rates=(3.4, 10.0, 25.0), buffers=(10, 20, 40), n_people: int = 4, train_people: int = 6,
                      seed: int = 0, progress=None) -> list[dict]:
    """Accuracy against detection latency and compute, over scan rate and buffer length."""
    rows = []
    for rate in rates:
        for buffer_len in buffers:
            if progress:
                progress(f'speed/error: {rate} Hz, buffer {buffer_len}')
            config = EvalConfig(rate_hz=rate, buffer_len=buffer_len, n_people=n_people, train_people=train_people,
                                seed=seed)
            result = evaluate(config)
            bench = bench_cycle(buffer_len=buffer_len, rate_hz=rate, repeats=5, cycles=300)
            recalls = {s: result['model']['subtype']['per_class'][s]['recall'] for s in TOUCH_SUBTYPES}
            rule_recalls = {s: result['rule']['subtype']['per_class'][s]['recall'] for s in TOUCH_SUBTYPES}
            rows.append({'rate_hz': rate, 'buffer_len': buffer_len, 'span_s': buffer_len / rate,
                         'subtype_accuracy': result['subtype_accuracy'],
                         'rule_subtype_accuracy': result['rule_subtype_accuracy'],
                         'symbolic_accuracy': result['symbolic_accuracy'],
                         'symbolic_latency_s': result['median_detection_latency_s'],
                         'subtype_latency_s': result['median_subtype_latency_s'],
                         'frame_accuracy': result['model']['subtype']['frame_accuracy'],
                         'us_per_cycle': bench['us_per_cycle'], 'recall': recalls, 'rule_recall': rule_recalls})
    return rows


def alias_table(rates=(3.4, 10.0, 25.0), freqs=(0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0), buffer_len: int = 20,
                seed: int = 0) -> list[dict]:
    """Measured base frequency of a periodic touch (a stroke whose level dips at ``f`` Hz) per scan rate,
    next to the folded (aliased) frequency sampling theory predicts."""
    out = []
    for f in freqs:
        row = {'true_hz': f, 'measured': {}, 'predicted': {}}
        for rate in rates:
            contact = Contact(channel=1, start_s=4.0, end_s=40.0, subtype='pet', amplitude=0.95, frequency_hz=f,
                              depth=0.6)
            scene = BearScene([contact], [], 40.0, 'synthetic: one periodic touch on head2')
            config = EvalConfig(rate_hz=rate, buffer_len=buffer_len)
            rec = BearRecogniser(rate, buffer_len, named_outputs=False)
            seen = []
            for cycle in bear_cycles(scene, config, seed).cycles(scene.duration_s):
                result = rec.update(cycle.t, cycle.levels, cycle.faulty)
                if 10.0 <= cycle.t < 39.0:
                    seen.append(float(result.features.base_frequency_hz[1]))
            row['measured'][rate] = float(np.median(seen))
            row['predicted'][rate] = float(abs(f - rate * round(f / rate)))
        out.append(row)
    return out


def _rows(config: EvalConfig, seed: int, people: int) -> tuple[np.ndarray, np.ndarray]:
    scene = make_scene(n_people=people, seed=seed, subtype_reps=config.subtype_reps + 1, gesture_reps=1)
    rec = BearRecogniser(config.rate_hz, config.buffer_len, named_outputs=False)
    run = run_scene(scene, bear_cycles(scene, config, seed), {'f': rec}, keep_features=True)
    return collect_training_rows(run, rec.fitted, seed=seed)


def compare_models(rate_hz: float = 3.4, buffer_len: int = 20, train_people: int = 8, test_people: int = 6,
                   seed: int = 0, only: Collection[str] | None = None) -> list[dict]:
    """Frame-level accuracy of candidate subtype models on held-out people, and their predict cost.

    ``only``: names of the candidates to run (default: all of them).
    """
    from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestClassifier
    from sklearn.metrics import accuracy_score, balanced_accuracy_score
    from sklearn.naive_bayes import GaussianNB
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    config = EvalConfig(rate_hz=rate_hz, buffer_len=buffer_len)
    Xtr, ytr = _rows(config, seed + 1000, train_people)
    Xte, yte = _rows(config, seed, test_people)
    candidates = {
        'logistic regression (ours, SubtypeClassifier)': SubtypeClassifier(),
        'paper rule (Table II defaults)': PaperRuleClassifier(),
        'paper rule (cutoffs tuned)': PaperRuleClassifier(tune_cutoffs=True),
        'Gaussian naive Bayes': GaussianNB(),
        'random forest (100 trees)': RandomForestClassifier(100, min_samples_leaf=3, class_weight='balanced',
                                                            random_state=0, n_jobs=1),
        'gradient boosting (hist)': HistGradientBoostingClassifier(class_weight='balanced', random_state=0),
        'MLP (32 hidden)': make_pipeline(StandardScaler(), MLPClassifier((32,), max_iter=500, random_state=0)),
    }
    out = []
    sample = Xte[:56]
    for name, model in candidates.items():
        if only is not None and name not in only:
            continue
        model.fit(Xtr, ytr)
        if hasattr(model, 'predict_codes'):
            pred = model.predict_codes(Xte)[0]
            predict = model.predict_codes
        else:
            pred = model.predict(Xte)
            predict = model.predict
        times = []
        for _ in range(50):
            t0 = time.perf_counter_ns()
            predict(sample)
            times.append((time.perf_counter_ns() - t0) / 1e3)
        out.append({'model': name, 'accuracy': float(accuracy_score(yte, pred)),
                    'balanced_accuracy': float(balanced_accuracy_score(yte, pred)),
                    'us_per_56_sensors': float(np.median(times))})
    return out


def gap_sweep(gaps=(0.5, 1.0, 1.5, 2.0), rates=(3.4, 25.0), n_people: int = 6, seed: int = 5) -> list[dict]:
    """Symbolic recall per gesture against the tolerated dropout ``gap_s`` (rule subtypes)."""
    library = GestureLibrary.default()
    scene = make_scene(n_people=n_people, seed=seed, subtype_reps=1, gesture_reps=2)
    out = []
    for rate in rates:
        recs = {}
        for gap in gaps:
            recs[gap] = BearRecogniser(rate, 20, library=library.with_default_gap(gap), named_outputs=False)
        run = run_scene(scene, bear_cycles(scene, EvalConfig(rate_hz=rate), seed), recs)
        for gap, rec in recs.items():
            score = score_symbolic(scene, run, run.events[gap], rec.symbolic.library)
            out.append({'rate_hz': rate, 'gap_s': gap, 'accuracy': score['accuracy'],
                        'false_alarms': score['false_alarms'],
                        'recall': {k: v['recall'] for k, v in score['per_class'].items() if k != 'none'}})
    return out


# ---------------------------------------------------------------------------------------------- documents
def populations_md(cross: dict, shipped_name: str) -> list[str]:
    """Lines of the section on the shipped model across populations (:func:`~.transfer.cross_population`)."""
    fams = cross['families']
    lines = [
        '## The shipped model on people it never met',
        '',
        'Two families of simulated people (both **synthetic**): `script` (touch_sim/bear/people.py: per-contact '
        'level waveforms with knight2009 Table II statistics, the people the project started with) and `hands` '
        '(touch_sim/bear/hand_people.py: hands moving over plates, written independently from knight2009 alone: '
        'contact size by palm or fingertip, coupling falling off with distance and height, per-person hand size, '
        'pressure, tempo, persistence, rhythm and aim, per-channel drift and glitches, cross-talk within a '
        'Midplane board, clock error and dropped frames). Every model is measured on held-out people of each '
        f"family ({cross['config']['n_people']} per family, seed {cross['config']['seed']}; training scenes: "
        f"{cross['config']['train_people']} other people per family). `{shipped_name}` is the file that ships "
        '(config/bear_subtype_model.npz), scored as it is, without retraining. Measured by '
        '`social-touch eval bear --cross --model config/bear_subtype_model.npz`.',
        '',
        '| model | ' + ' | '.join(f'{f}: subtypes | {f}: lowest class | {f}: symbolic detected | '
                                   f'{f}: symbolic false alarms' for f in fams) + ' |',
        '|---' * (1 + 4 * len(fams)) + '|',
    ]
    for name, per in cross['scores'].items():
        lines.append(f'| {name} | ' + ' | '.join(
            f"{_fmt(per[f]['subtype_accuracy'])} | {_fmt(per[f]['lowest_class_recall'])} | "
            f"{_fmt(per[f]['symbolic_detected'])} | {per[f]['symbolic_false_alarms']}" for f in fams) + ' |')
    shipped = cross['scores'][shipped_name]
    for f in fams:
        s = shipped[f]
        lines += ['', f'### Shipped model on the `{f}` family: subtypes per interaction', '',
                  _matrix_md(s['labels'], s['confusion']), '',
                  'Share of each subtype\'s interactions whose sensor read at or above the 30 % activation threshold '
                  'in at least one scan cycle (the most any model behind the no-touch gate can name; the rest the '
                  '3.4 Hz scan never saw): ' + ', '.join(f'{k} {_fmt(v)}' for k, v in
                                                         s.get('reached_threshold', {}).items()) + '.', '',
                  f"Median subtype latency (over all detected interactions): {_fmt(s['median_subtype_latency_s'])} s.",
                  '', f'Symbolic gestures on the `{f}` family (shipped model\'s subtypes): detections and false '
                  'starts (STARTs in pauses or during another gesture) per gesture; STARTs during single-sensor '
                  f"subtype touches are counted apart ({s['symbolic_starts_during_subtype_touches']} in all).", '',
                  '| gesture | labelled | recall | false starts |', '|---|---|---|---|',
                  *[f"| {g} | {s['symbolic_labelled_by_gesture'][g]} | {_fmt(s['symbolic_recall'][g])} | "
                    f"{s['symbolic_false_alarms_by_gesture'][g]} |" for g in s['symbolic_recall']],
                  f"| all | {s['symbolic_labelled']} | {_fmt(s['symbolic_detected'])} | "
                  f"{s['symbolic_false_alarms']} |"]
    return [*lines, '']


def first_word_md(main_result: dict, figure: list[str]) -> list[str]:
    """The section on the first word (CANDIDATE before START, :mod:`touch_lab.bear.first_word`)."""
    fw = main_result['model'].get('first_word')
    if not fw:
        return []
    taus = fw['taus_s']
    at = [k for k, t in enumerate(taus) if t in (0.3, 0.6, 1.0, 2.0, 3.0, 4.0)]
    rows = [f"| {taus[k]:.1f} | {_fmt(fw['said_accuracy'][k])} | {_fmt(fw['decided_accuracy'][k])} |" for k in at]
    outcomes = [f"| {g} | {v['candidates']} | {v['confirmed']} | {v['withdrawn']} |"
                for g, v in fw['candidates'].items() if v['candidates']]
    return [
        '## Symbolic gestures: the first word',
        '',
        'A CANDIDATE is published on the first cycle one of a gesture\'s filter sensors is touched, with its '
        'confidence (config/bear_candidates.yaml: the fraction of such candidates confirmed on the training people, '
        '`social-touch train bear-candidates`), then START (confirmed) or WITHDRAWN. Scoring: '
        '`touch_lab/bear/first_word.py`.',
        '',
        f"- median first message of the labelled gesture (its CANDIDATE or START) from the gesture's start: "
        f"**{_fmt(fw['median_first_message_s'])} s** ({_fmt(fw['first_message_rate'])} of the {fw['labelled']} "
        f"gestures got one); of any gesture: {_fmt(fw['median_first_any_message_s'])} s;",
        f"- the decision (START): {_fmt(main_result['model']['symbolic']['median_latency_s'])} s, accuracy "
        f"{_fmt(main_result['model']['symbolic']['accuracy'])}, {main_result['model']['symbolic']['false_alarms']} "
        'false alarms (as above: candidates change none of them).',
        '',
        'What the bear says at a time since the gesture\'s start, against the label: "said" is the latest START, '
        'else the most confident open CANDIDATE; "decided" is STARTs alone (what code that waits for the '
        'decision knows).',
        '',
        '| time since start, s | said accuracy | decided accuracy |',
        '|---|---|---|',
        *rows,
        *figure,
        '',
        '| gesture | candidates | confirmed | withdrawn |',
        '|---|---|---|---|',
        *outcomes,
        '',
    ]


def evaluation_md(main_result: dict, bench: dict, sweep: list[dict], models: list[dict], gaps: list[dict],
                  command: str, figures: dict[str, str] | None = None, populations: list[str] | None = None) -> str:
    """The Markdown of docs/bear-evaluation.md; ``figures``: key -> image line (touch_lab.figures.bear);
    ``populations``: the lines of :func:`populations_md`."""
    m, r = main_result['model'], main_result['rule']
    fig = {k: ['', v] for k, v in (figures or {}).items()}
    cfg = main_result['config']
    lines = [
        '# Sensate Bear recognisers: evaluation',
        '',
        f'Regenerate with `{command}`. {SYNTHETIC}',
        '',
        f"Main configuration: {cfg['rate_hz']} Hz scan (the real bear, knight2009 VI.B), buffer {cfg['buffer_len']} "
        f"cycles (V.A), {cfg['n_people']} test people and {cfg['train_people']} other training people, "
        f"{main_result['cycles']} cycles ({main_result['scene_s']:.0f} s of scene). The \"trained model\" is the "
        'shipped file config/bear_subtype_model.npz, scored as it is (`social-touch eval bear --model '
        'config/bear_subtype_model.npz`). Scoring rules: see the docstring of `touch_lab/bear/evaluate.py`.',
        '',
        '## Summary',
        '',
        '| | trained model | paper rule (V.D) |',
        '|---|---|---|',
        f"| subtype accuracy, per interaction (8 subtypes) | {_fmt(m['subtype']['accuracy'])} | "
        f"{_fmt(r['subtype']['accuracy'])} |",
        f"| subtype accuracy, per sensor-cycle (incl. none) | {_fmt(m['subtype']['frame_accuracy'], 3)} | "
        f"{_fmt(r['subtype']['frame_accuracy'], 3)} |",
        f"| median subtype latency from touch start, s | {_fmt(m['subtype']['median_latency_s'])} | "
        f"{_fmt(r['subtype']['median_latency_s'])} |",
        f"| symbolic accuracy (detected / labelled) | {_fmt(m['symbolic']['accuracy'])} | "
        f"{_fmt(r['symbolic']['accuracy'])} |",
        f"| symbolic false alarms (in pauses / other gestures) | {m['symbolic']['false_alarms']} | "
        f"{r['symbolic']['false_alarms']} |",
        f"| symbolic STARTs during single-sensor subtype touches | {m['symbolic']['starts_during_subtype_touches']} | "
        f"{r['symbolic']['starts_during_subtype_touches']} |",
        f"| median symbolic latency from gesture start (incl. 2 s dwell), s | "
        f"{_fmt(m['symbolic']['median_latency_s'])} | {_fmt(r['symbolic']['median_latency_s'])} |",
        f"| median us per cycle in the run (56 sensors, all features) | {_fmt(m['us_per_cycle'], 0)} | "
        f"{_fmt(r['us_per_cycle'], 0)} |",
        '',
        f"Driver counters: {main_result['driver']}.",
        '',
        *(populations or []),
        '## Touch subtypes, per interaction: trained model',
        '',
        _matrix_md(m['subtype']['labels'], m['subtype']['confusion']),
        *fig.get('subtype_confusion', []),
        '',
        '| subtype | precision | recall | median latency, s |',
        '|---|---|---|---|',
        *[f"| {s} | {_fmt(m['subtype']['per_class'][s]['precision'])} | {_fmt(m['subtype']['per_class'][s]['recall'])} "
          f"| {_fmt(m['subtype']['median_latency_by_subtype_s'][s])} |" for s in TOUCH_SUBTYPES],
        '',
        '## Touch subtypes, per interaction: paper rule (the baseline)',
        '',
        'The rule can only say none, poke, tickle, pet or hold; everything shorter than 3 s is a poke.',
        '',
        _matrix_md(r['subtype']['labels'], r['subtype']['confusion']),
        '',
        '## Symbolic gestures: trained-model subtypes',
        '',
        _matrix_md(m['symbolic']['labels'], m['symbolic']['confusion']),
        *fig.get('symbolic_confusion', []),
        '',
        '| gesture | precision | recall | median latency, s |',
        '|---|---|---|---|',
        *[f"| {g} | {_fmt(m['symbolic']['per_class'][g]['precision'])} | "
          f"{_fmt(m['symbolic']['per_class'][g]['recall'])} | {_fmt(m['symbolic']['median_latency_by_gesture_s'][g])} |"
          for g in m['symbolic']['labels'] if g != 'none'],
        '',
        'With the paper rule\'s subtypes instead (gestures that need a subtype, e.g. belly_tickle, depend on it):',
        '',
        _matrix_md(r['symbolic']['labels'], r['symbolic']['confusion']),
        '',
        *first_word_md(main_result, fig.get('first_word', [])),
        '## Table III shape (knight2009 VI.C), simulated people',
        '',
        '| gesture | activated on first try | activated with explanation | regional accuracy |',
        '|---|---|---|---|',
        *[f"| {g} | {_fmt(v['activated_first_try'])} | {_fmt(v['activated_with_explanation'])} | "
          f"{_fmt(v['regional_accuracy'])} |" for g, v in m['symbolic']['table_iii'].items()],
        '',
        'The paper (eleven children): head-pat 100/100/100 %, tickle 20/60/20 %, hug 40/80/80 %, '
        'foot-rub 100/100/100 %. '
        'Our people are not children; the point of the table is its shape and that it is computed, not the match.',
        '',
        '## Compute',
        '',
        f"`bench_cycle(buffer_len={bench['buffer_len']}, rate_hz={bench['rate_hz']}, repeats={bench['repeats']})`: "
        f"**{bench['us_per_cycle']:.0f} us per cycle** with the trained model, {bench['us_per_cycle_rule']:.0f} us "
        f"with the rule, {bench['us_features']:.0f} us for buffer + features alone (all 56 sensors, "
        f"{len(FEATURE_NAMES)} features, one core; goal {bench['goal_us']:.0f} us). Machines are shared: rerun "
        '`social-touch bench bear` to measure on yours.',
        '',
        '## Speed against error: scan rate and buffer length',
        '',
        'Accuracy against detection latency and compute; a longer buffer sees more periods but holds a finished '
        'touch longer (knight2009 V.A: "detection speed for new gestures is inversely proportional to the size of '
        'the buffer").',
        '',
        '| rate, Hz | buffer, cycles | span, s | subtype acc. (model) | subtype acc. (rule) | per-cycle acc. | '
        'symbolic acc. | symbolic latency, s | subtype latency, s | us/cycle |',
        '|---|---|---|---|---|---|---|---|---|---|',
        *[f"| {row['rate_hz']} | {row['buffer_len']} | {row['span_s']:.1f} | {_fmt(row['subtype_accuracy'])} | "
          f"{_fmt(row['rule_subtype_accuracy'])} | {_fmt(row['frame_accuracy'], 3)} | "
          f"{_fmt(row['symbolic_accuracy'])} | "
          f"{_fmt(row['symbolic_latency_s'])} | {_fmt(row['subtype_latency_s'])} | {row['us_per_cycle']:.0f} |"
          for row in sweep],
        *fig.get('speed_error', []),
        '',
        '## Choice of the subtype model',
        '',
        'Per sensor-cycle accuracy on held-out simulated people (rows: every touched sensor-cycle plus 2 % of idle '
        'ones), and the cost of one prediction for 56 sensors.',
        '',
        '| model | accuracy | balanced accuracy | us per prediction (56 sensors) |',
        '|---|---|---|---|',
        *[f"| {row['model']} | {row['accuracy']:.3f} | {row['balanced_accuracy']:.3f} | "
          f"{row['us_per_56_sensors']:.0f} |"
          for row in models],
        '',
        '## Tolerated dropout in locational filters (`gap_s`)',
        '',
        'Not in the paper. Pats and tickles drop below the 30 % threshold between contacts; without tolerance the '
        '2 s dwell restarts. Recall per gesture (rule subtypes), by rate:',
        '',
        '| rate, Hz | gap_s | accuracy | false alarms | head_pat | tickle | hug | foot_rub | shoulder_tap |',
        '|---|---|---|---|---|---|---|---|---|',
        *[f"| {row['rate_hz']} | {row['gap_s']} | {_fmt(row['accuracy'])} | {row['false_alarms']} | "
          + ' | '.join(_fmt(row['recall'].get(g)) for g in ('head_pat', 'tickle', 'hug', 'foot_rub', 'shoulder_tap'))
          + ' |' for row in gaps],
        '',
    ]
    return '\n'.join(lines)


RATES_INTRO = """# Sensate Bear: what each scan rate can and cannot tell apart

Regenerate with `{command}`. {synthetic}

The real bear reads its channels one at a time, 5 ms each: (58 sensors) x 5 ms = 0.29 s per scan,
**3.4 Hz** (knight2009 VI.B). Reading the eight Midplanes in parallel would take 8 x 5 ms = 40 ms, the
**ideal 25 Hz** (IV.D: "all sensors on the bear can be read in 40 milliseconds"). A scan rate `r` can
represent motion up to its Nyquist frequency `r / 2`; faster motion *aliases*: a periodic touch at `f`
appears at `|f - r * round(f / r)|`. A buffer of `N` cycles resolves frequencies in steps of `r / N` Hz
and spans `N / r` seconds.

| rate, Hz | Nyquist, Hz | frequency step with 20 cycles, Hz | 20 cycles span, s | scans inside a 0.25 s tap |
|---|---|---|---|---|
{basics}

## Measured: the base frequency the features report

A stroke whose level dips periodically at the true frequency, on one sensor, through the virtual
device (per-channel scan timing, noise), decoder, calibrator and the feature extractor (20 cycles);
median over 29 s. "Predicted" is the folded frequency from sampling theory.

{alias}

## Measured: per-subtype recall by rate (buffer 20 cycles, trained model / paper rule)

{recall}

## What this means

- **3.4 Hz (real bear)**: Nyquist 1.7 Hz. Pet (0.5-2 Hz) is at the edge; a 5-10 Hz tickle folds down to
  an arbitrary low frequency, so **tickle cannot be told from pet by base frequency** and the paper's rule,
  whose tickle cutoff sits between 2 and 5 Hz, never says tickle (it says pet; knight2009 VI.B feared
  "constant touch"). What survives aliasing is that the folded signal is irregular (spread, roughness),
  which the trained model uses. A 0.25 s tap is seen in at most one scan, often in none: **tap and poke
  cannot be told apart reliably, and taps are missed**. Shake (2-5 Hz) and rub (1.5-4 Hz) alias into the
  pet band.
- **10 Hz**: Nyquist 5 Hz: pats, rubs and shakes are resolved. Tickles above 5 Hz still fold: 5-8 Hz
  lands at 2-5 Hz, above pet's band, but 8-10 Hz lands at 0-2 Hz, inside it, so base frequency separates
  only part of the tickles from pets. Taps are seen in two or three scans.
- **25 Hz (ideal)**: Nyquist 12.5 Hz covers Table II's whole tickle band (5-10 Hz, sigma 5 Hz), so every
  subtype's base frequency is measured as it is. The cost is that 20 cycles now span only 0.8 s with a
  1.25 Hz frequency step: pet at 0.5-1 Hz needs 40-80 cycles of buffer to be resolved (see the
  speed-against-error table in docs/bear-evaluation.md).
"""


def rates_md(sweep: list[dict], aliases: list[dict], command: str) -> str:
    rates = sorted({row['rate_hz'] for row in sweep} | {r for row in aliases for r in row['measured']})
    basics = '\n'.join(f'| {r} | {r / 2:.2f} | {r / 20:.3f} | {20 / r:.1f} | {0.25 * r:.2f} |' for r in rates)
    alias_rates = sorted({r for row in aliases for r in row['measured']})
    alias = ['| true frequency, Hz | ' + ' | '.join(f'{r} Hz measured / predicted' for r in alias_rates) + ' |',
             '|---' * (len(alias_rates) + 1) + '|']
    for row in aliases:
        alias.append(f"| {row['true_hz']} | " + ' | '.join(
            f"{row['measured'][r]:.2f} / {row['predicted'][r]:.2f}" for r in alias_rates) + ' |')
    by_rate = [row for row in sweep if row['buffer_len'] == 20]
    recall = ['| subtype | ' + ' | '.join(f"{row['rate_hz']} Hz" for row in by_rate) + ' |',
              '|---' * (len(by_rate) + 1) + '|']
    for s in TOUCH_SUBTYPES:
        recall.append(f'| {s} | ' + ' | '.join(f"{_fmt(row['recall'][s])} / {_fmt(row['rule_recall'][s])}"
                                               for row in by_rate) + ' |')
    return RATES_INTRO.format(command=command, synthetic=SYNTHETIC, basics=basics, alias='\n'.join(alias),
                              recall='\n'.join(recall))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch report bear``."""
    add_output(parser, 'where to write the two .md files (default: docs/ of the source tree)', directory=True)
    parser.add_argument('--quick', action='store_true', help='fewer people and configurations (a preview)')
    parser.add_argument('--seed', type=seed, default=0)


def run(args: argparse.Namespace) -> int:
    """Measure everything and write docs/bear-evaluation.md and docs/bear-rates.md (about 15 minutes)."""
    out_dir = Path(args.output_dir) if args.output_dir else Path(__file__).resolve().parents[2] / 'docs'
    command = 'social-touch report bear' + (' --quick' if args.quick else '')
    say = stderr_progress
    people = 3 if args.quick else 6
    config = EvalConfig(n_people=people, train_people=people + 2, seed=args.seed)
    shipped = share_file('config', 'bear_subtype_model.npz')
    say(f'main evaluation at 3.4 Hz, buffer 20: the shipped model {shipped}')
    main_result = evaluate(config, progress=say, model=SubtypeClassifier.load(shipped))
    say('across populations')
    cross = cross_population(config, {'shipped model': SubtypeClassifier.load(shipped)}, progress=say)
    say('benchmark')
    bench = bench_cycle()
    rates = (3.4, 25.0) if args.quick else (3.4, 10.0, 25.0)
    buffers = (20,) if args.quick else (10, 20, 40)
    sweep = speed_error_table(rates, buffers, n_people=2 if args.quick else 4, train_people=4 if args.quick else 6,
                              seed=args.seed, progress=say)
    say('model comparison')
    models = compare_models(train_people=4 if args.quick else 8, test_people=3 if args.quick else 6, seed=args.seed)
    say('gap sweep')
    gaps = gap_sweep(n_people=3 if args.quick else 6)
    say('aliasing')
    aliases = alias_table(rates=rates)
    out_dir.mkdir(parents=True, exist_ok=True)
    say('figures')
    from touch_lab.figures.bear import bear_figures  # matplotlib: loaded only to write the report

    figures = bear_figures(out_dir, main_result, sweep, models, say)
    write_text(out_dir / 'bear-evaluation.md', evaluation_md(main_result, bench, sweep, models, gaps, command,
                                                            figures, populations_md(cross, 'shipped model')))
    write_text(out_dir / 'bear-rates.md', rates_md(sweep, aliases, command), encoding='utf-8')
    say(f'wrote {out_dir / "bear-evaluation.md"} and {out_dir / "bear-rates.md"}')
    return 0

