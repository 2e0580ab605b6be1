"""``python -m touch_lab.skin.compiled_report``: regenerate docs/skin-compiled-code.md (issue 24).

What the skin's compiled twins (``touch_gestures/skin/_cloud_accel.c`` and its feature files, chosen by
``SOCIAL_TOUCH_SKIN_ACCEL``) saved at the robot's real rates, measured before they were removed: the
deployed recognisers' cost per recognition and per early candidate (:mod:`.bench`, synthetic gestures)
and the time from the gap's end to the command through the nodes (:mod:`.latency`), each with the
extension and with numpy, in subprocesses of one run, alternating, medians over ``--rounds``. The cost
per second is converted to a share of one core at the most the node runs them: a person tracing one
gesture after another without a pause, each as long as the synthetic gestures' median and followed by
the vocabulary's gap (a touch within it would join the gesture): one recognition per gesture, and one
early candidate every ``candidate_period_s`` (0.1 s) while a gesture is traced.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from touch_gestures.skin.segmentation import ENDING_GAP_S, SINGLE_STROKE_GAP_S

__all__ = ['HELP', 'add_arguments', 'measure', 'run', 'write_report']

HELP = 'regenerate docs/skin-compiled-code.md: what the skin extension saves at real rates'
#: The deployed recognisers (touch_gestures.skin.registry's defaults) measured.
DEPLOYED = ('trace', 'fused')
#: The gap (s) that ends a gesture of each: a single-stroke vocabulary's, a multi-stroke one's with its end rule.
GAP_S = {'trace': SINGLE_STROKE_GAP_S, 'fused': ENDING_GAP_S, 'fused_3_strokes': ENDING_GAP_S}
#: Early candidates per second of tracing (the node's candidate_period_s: 0.1 s).
CANDIDATES_PER_S = 10.0
IMPLEMENTATIONS = ('c', 'python')
#: Compiled code stays only where it saves at least this % of a core (DESIGN.md).
KEEP_PCT = 0.5


def measure(repeats: int = 7) -> dict:
    """One measurement with the implementation this process imported: per deployed recogniser, CPU us per
    recognition and per early candidate (half a gesture), and the gap-to-command latency (ms)."""
    from touch_gestures.skin import cloud_accel
    from touch_gestures.skin.early import PrefixMatcher
    from touch_gestures.skin.gesture import TouchGesture
    from touch_gestures.skin.registry import make_recogniser
    from touch_lab.skin.bench import _median_us, bench_recognition, synthetic_codebook
    from touch_lab.skin.latency import bench_latency

    out: dict = {'implementation': cloud_accel.implementation(), 'recognisers': {}}
    bench = bench_recognition(list(DEPLOYED), repeats=repeats)
    gestures, labels = synthetic_codebook()
    probe, _ = synthetic_codebook(16, 4, 1)
    out['gesture_s'] = statistics.median(g.duration_s for g in probe)
    halves = [TouchGesture.from_trajectory(g.trajectory[:max(1, len(g.trajectory) // 2)],
                                           g.times[:max(1, len(g.times) // 2)]) for g in probe]
    for name in DEPLOYED:
        model = make_recogniser(name).fit(gestures, labels)
        candidate_cpu_us = _median_us(PrefixMatcher(model).candidate, halves, repeats)[1]
        latency = bench_latency(recogniser=name)
        out['recognisers'][name] = {
            'cpu_us_per_recognition': bench['recognisers'][name]['cpu_us_per_recognition'],
            'cpu_us_per_candidate': candidate_cpu_us,
            'latency_ms_median': latency['ms_median'], 'latency_ms_p99': latency['ms_p99'],
            'processing_ms_median': latency['processing_ms_median']}
    if 'fused_3_strokes' in bench:
        out['recognisers']['fused_3_strokes'] = {'cpu_us_per_recognition':
                                                 bench['fused_3_strokes']['cpu_us_per_recognition']}
    return out


def _measure_in(implementation: str, repeats: int) -> dict:
    """:func:`measure` in a subprocess with ``SOCIAL_TOUCH_SKIN_ACCEL=implementation`` (read once, at import)."""
    env = dict(os.environ, SOCIAL_TOUCH_SKIN_ACCEL=implementation)
    code = f'import json; from touch_lab.skin.compiled_report import measure; print(json.dumps(measure({repeats})))'
    done = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        raise RuntimeError(f'measuring with SOCIAL_TOUCH_SKIN_ACCEL={implementation} failed: {done.stderr[-2000:]}')
    result = json.loads(done.stdout.strip().splitlines()[-1])
    if result['implementation'] != implementation:
        raise RuntimeError(f'asked for {implementation}, measured {result["implementation"]} (extension not built?)')
    return result


def _medians(runs: list[dict]) -> dict:
    """Per recogniser and figure, the median over ``runs``."""
    names = runs[0]['recognisers']
    return {name: {key: statistics.median(r['recognisers'][name][key] for r in runs) for key in names[name]}
            for name in names}


def core_share(figures: dict, gesture_s: float, gap_s: float) -> float:
    """% of one core a deployed recogniser costs at the most the node runs it (module doc), from its per-call CPU
    us, for gestures of ``gesture_s`` s each followed by a gap of ``gap_s`` s."""
    period = gesture_s + gap_s
    us_per_s = figures['cpu_us_per_recognition'] / period
    us_per_s += figures.get('cpu_us_per_candidate', 0.0) * CANDIDATES_PER_S * gesture_s / period
    return 100.0 * us_per_s / 1e6


def write_report(out: str | Path = 'docs/skin-compiled-code.md', rounds: int = 3, repeats: int = 7) -> Path:
    """Measure both implementations ``rounds`` times, alternating, and write the Markdown file ``out``."""
    runs: dict[str, list[dict]] = {impl: [] for impl in IMPLEMENTATIONS}
    for _ in range(rounds):
        for impl in IMPLEMENTATIONS:
            runs[impl].append(_measure_in(impl, repeats))
    med = {impl: _medians(r) for impl, r in runs.items()}
    c, py = med['c'], med['python']
    gesture_s = statistics.median(r['gesture_s'] for impl in IMPLEMENTATIONS for r in runs[impl])

    def share(figures: dict, name: str) -> float:
        return core_share(figures, gesture_s, GAP_S[name])
    lines = ['# The skin without compiled code (generated)', '',
             'Generated by `python -m touch_lab.skin.compiled_report` (touch_lab/skin/compiled_report.py) at the '
             'last commit that still had the skin extension (`touch_gestures/skin/_cloud_accel.c`); do not edit. '
             'SYNTHETIC gestures (touch_sim.skin.synthetic), 16 gestures x 30 templates; medians of '
             f'{rounds} rounds, each measuring the extension (`SOCIAL_TOUCH_SKIN_ACCEL=c`) and numpy '
             '(`SOCIAL_TOUCH_SKIN_ACCEL=python`) in turn, in one run on one machine.', '',
             'Share of a core at the most the node runs this code: a person tracing one gesture after another '
             f'without a pause, each {gesture_s:.2f} s long (the median synthetic gesture) and followed by its '
             f"vocabulary's gap ({GAP_S['trace']} s single-stroke, {GAP_S['fused']} s multi-stroke; a touch within it "
             'would join the gesture): one recognition per gesture and '
             f'{CANDIDATES_PER_S:.0f} early candidates a second while a gesture is traced (`candidate_period_s` '
             '0.1 s); the frames themselves never reach this code.', '',
             '| recogniser | CPU us per recognition, C / numpy | CPU us per candidate, C / numpy '
             '| % of a core, C / numpy | saved by C, % of a core |',
             '|---|---|---|---|---|']
    for name in c:
        fc, fp = c[name], py[name]
        cand = (f"{fc['cpu_us_per_candidate']:.0f} / {fp['cpu_us_per_candidate']:.0f}"
                if 'cpu_us_per_candidate' in fc else 'n/a')
        lines.append(f"| {name} | {fc['cpu_us_per_recognition']:.0f} / {fp['cpu_us_per_recognition']:.0f} | {cand} "
                     f"| {share(fc, name):.3f} / {share(fp, name):.3f} | {share(fp, name) - share(fc, name):.3f} |")
    lines += ['', 'From the end of the gap to the command (`social-touch bench skin-latency --recogniser NAME`: the '
              'skin_driver and haptic_commands nodes in one simulated-time graph, frames at 150 Hz; goal 50 ms):', '',
              '| recogniser | median ms, C / numpy | 99th percentile ms, C / numpy '
              '| processing median ms, C / numpy |', '|---|---|---|---|']
    for name in DEPLOYED:
        fc, fp = c[name], py[name]
        lines.append(f"| {name} | {fc['latency_ms_median']:.1f} / {fp['latency_ms_median']:.1f} "
                     f"| {fc['latency_ms_p99']:.1f} / {fp['latency_ms_p99']:.1f} "
                     f"| {fc['processing_ms_median']:.2f} / {fp['processing_ms_median']:.2f} |")
    saved = max(share(py[n], n) - share(c[n], n) for n in DEPLOYED)
    slowest = max(py[n]['latency_ms_p99'] for n in DEPLOYED)
    verdict = ('under' if saved < KEEP_PCT else 'over') + f' the {KEEP_PCT} % for which the project keeps compiled code'
    lines += ['', f'The extension saves at most {saved:.3f} % of a core ({verdict}); with numpy the command comes '
              f'{slowest:.1f} ms after the gap at the 99th percentile (goal 50 ms).', '']
    out = Path(out)
    out.write_text('\n'.join(lines), encoding='utf-8')
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', default='docs/skin-compiled-code.md', help='the Markdown file to write')
    parser.add_argument('--rounds', type=int, default=3, help='measurements of each implementation, alternating')
    parser.add_argument('--repeats', type=int, default=7, help='repeats of each benchmark inside a measurement')


def run(args: argparse.Namespace) -> int:
    try:
        path = write_report(args.out, args.rounds, args.repeats)
    except (RuntimeError, OSError) as err:
        print(f'report skin-compiled: {err}', file=sys.stderr)
        return 2
    print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    _parser = argparse.ArgumentParser(description=HELP)
    add_arguments(_parser)
    sys.exit(run(_parser.parse_args()))
