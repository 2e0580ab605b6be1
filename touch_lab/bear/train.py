"""``social-touch train bear``: train the eight-subtype model on simulated people and write it as .npz (no pickle).

    social-touch train bear --out config/bear_subtype_model.npz [--rate 3.4] [--buffer 20] [--people 8]

The model is tied to the scan rate and buffer length it was trained at (its features are); both are
stored in the file (``trained_rate_hz_`` and ``trained_buffer_len_`` after ``SubtypeClassifier.load``),
so a node can refuse a model trained for another rate. The training data is synthetic (simulated
people, knight2009 Table II statistics); retrain on labelled recordings of the real bear when there
are some.
"""

from __future__ import annotations

import argparse
import sys

from .cli import positive_float, positive_int
from .evaluate import EvalConfig, stderr_progress, train_subtype_model

__all__ = ['HELP', 'add_arguments', 'run']

HELP = 'train the Sensate Bear subtype model on simulated people (synthetic) and write it as .npz'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch train bear``."""
    parser.add_argument('--out', required=True, help='the .npz file to write')
    parser.add_argument('--rate', type=positive_float, default=3.4, help='scan rate, Hz (3.4)')
    parser.add_argument('--buffer', type=positive_int, default=20, help='cycles per sensor buffer (20)')
    parser.add_argument('--people', type=positive_int, default=8, help='simulated people to train on (8)')
    parser.add_argument('--seed', type=int, default=0, help='training scene seed is seed + 1000 (0)')


def run(args: argparse.Namespace) -> int:
    """Train and write the model; progress on stderr."""
    config = EvalConfig(rate_hz=args.rate, buffer_len=args.buffer, train_people=args.people, seed=args.seed)
    model = train_subtype_model(config, progress=stderr_progress)
    model.save(args.out, rate_hz=args.rate, buffer_len=args.buffer)
    print(f'wrote {args.out}: classes {", ".join(model.classes_)}; trained at {args.rate} Hz, buffer {args.buffer} '
          f'on {args.people} simulated people (synthetic)', file=sys.stderr)
    return 0
