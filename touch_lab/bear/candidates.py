"""Count how often each symbolic CANDIDATE is confirmed, for ``config/bear_candidates.yaml``.

    social-touch train bear-candidates -o config/bear_candidates.yaml

Runs a scene of simulated people (**synthetic**; by default the evaluation's training people, seed
1000, not its test people, seed 0) through the bear's graph and recogniser with the shipped subtype
model, and counts, per gesture and evidence level (:mod:`touch_gestures.bear.candidates`), the
CANDIDATEs and those confirmed by a START before any WITHDRAWN.
"""

from __future__ import annotations

import argparse
import sys

from touch_gestures.bear.candidates import MAX_LEVEL, CandidateConfidence
from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.node import default_model_path
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.sensor_level import ACTIVATION_THRESHOLD
from touch_gestures.bear.subtype_model import SubtypeModel
from touch_gestures.bear.symbolic import CANDIDATE, START, WITHDRAWN, GestureLibrary
from touch_graph.cli.options import add_output, positive_int, seed
from touch_graph.files import write_text
from touch_lab.bear.evaluate import EvalConfig, bear_cycles, family_scene, run_scene

__all__ = ['COMMAND', 'add_arguments', 'count_candidates', 'measure', 'run']

#: The command that writes the table.
COMMAND = 'social-touch train bear-candidates'


def count_candidates(events: list, library: GestureLibrary, data: str = '') -> CandidateConfidence:
    """The table of ``events`` (time order), keyed by each CANDIDATE's evidence level."""
    counts = {g.name: [[0, 0] for _ in range(MAX_LEVEL + 1)] for g in library.detectable}
    open_: dict[str, int] = {}            # gesture -> evidence level of its CANDIDATE out
    for e in events:
        if e.gesture not in counts:
            continue
        if e.state == CANDIDATE:
            level = e.evidence
            counts[e.gesture][level][1] += 1
            open_[e.gesture] = level
        elif e.state in (START, WITHDRAWN) and e.gesture in open_:
            level = open_.pop(e.gesture)
            counts[e.gesture][level][0] += e.state == START
    return CandidateConfidence({k: [tuple(p) for p in v] for k, v in counts.items()}, data=data)


def measure(n_people: int = 8, seed: int = 1000, family: str = 'script', rate_hz: float = 3.4,
            progress=None) -> CandidateConfidence:
    """Run the scene and count (module doc)."""
    config = EvalConfig(rate_hz=rate_hz, family=family)
    scene = family_scene(family, n_people, seed, 2, 2)
    classifier = NoTouchGate(SubtypeModel.load(default_model_path()), ACTIVATION_THRESHOLD)
    rec = BearRecogniser(rate_hz, classifier=classifier, candidate_confidence=CandidateConfidence())
    run = run_scene(scene, bear_cycles(scene, config, seed), {'model': rec}, progress=progress)
    data = (f'synthetic: {n_people} simulated people of the {family!r} family (seed {seed}) at {rate_hz:g} Hz, '
            f'the shipped subtype model; {COMMAND}')
    return count_candidates(run.events['model'], rec.symbolic.library, data)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch train bear-candidates``."""
    add_output(parser, 'the YAML file to write (config/bear_candidates.yaml)', required=True)
    parser.add_argument('--people', type=positive_int, default=8, help='simulated people to count on (8)')
    parser.add_argument('--seed', type=seed, default=1000,
                        help="scene seed (1000: the evaluation's training people, not its test people)")
    parser.add_argument('--family', choices=('script', 'hands'), default='script',
                        help='family of simulated people (script)')


def run(args: argparse.Namespace) -> int:
    """Count the candidates and write the table; progress on stderr."""
    table = measure(args.people, args.seed, args.family,
                    progress=lambda m: print(f'[candidates] {m}', file=sys.stderr, flush=True))
    write_text(args.output, f'# Generated: {COMMAND} -o {args.output}\n' + table.dumps())
    print(args.output)
    return 0
