"""``social-touch collect bear|patch|skin``: record labelled sessions, one bag per person.

    social-touch collect patch --person ada --out sessions/patch_ada      # live, with the scene launched
    social-touch collect patch --simulate 8 --out sessions/patch          # SYNTHETIC, simulated time
    social-touch collect bear --simulate 6 --symbolic --out sessions/bear # + the symbolic gestures

Each bag holds the sensor driver's topics and ``/touch/label`` (``social_touch_msgs/msg/TouchLabel``),
which ``train`` and ``eval SENSOR --bags`` read. The protocol asks for every gesture in every variant
``--repetitions`` times, shuffled per person. The bear's ``--symbolic`` labels are
``symbolic/<gesture>``. A live session is :mod:`touch_lab.collect.live`; ``--simulate N`` runs the
protocol with N simulated people on the virtual device and the real driver node, writing
``OUT/<sensor>_pNN`` for each.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

from touch_gestures.bear.symbolic import GestureLibrary
from touch_graph.cli.options import add_output, non_negative_seconds, positive_int, rate_hz, seed
from touch_sim.bear.people import symbolic_label

from .live import LiveSessionError, live_session
from .protocol import DEFAULT_GESTURES, SENSORS, Protocol
from .simulate import person_name, simulate_session

__all__ = ['add_arguments', 'run']


def _names(text: str) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(',') if v.strip())
    if not names:
        raise argparse.ArgumentTypeError(f'expected comma-separated names such as stroke,slap; got {text!r}')
    return names


def _gesture_names(text: str) -> tuple[str, ...]:
    from touch_sim.skin.synthetic import VOCABULARIES, gesture_list  # lazy: --help stays fast
    names = tuple(gesture_list(text))
    if not names:
        raise argparse.ArgumentTypeError(f'expected comma-separated names such as stroke,slap or a vocabulary '
                                         f'({", ".join(VOCABULARIES)}); got {text!r}')
    return names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch collect``."""
    parser.add_argument('sensor', choices=SENSORS, help='the sensor whose topics are recorded')
    add_output(parser, 'the bag to write (live), or the directory of one bag per person (--simulate)', required=True)
    parser.add_argument('--simulate', metavar='N', type=positive_int,
                        help='run the protocol with N simulated people on the virtual device (SYNTHETIC data)')
    parser.add_argument('--gestures', type=_gesture_names,
                        help='comma-separated classes to prompt, or a vocabulary of the skin: digits, letters '
                        '(default: ' +
                        '; '.join(f'{s}: {",".join(g)}' for s, g in DEFAULT_GESTURES.items()) + ')')
    parser.add_argument('--symbolic', nargs='?', const='all', type=str, metavar='GESTURES',
                        help="bear: also prompt symbolic gestures of config/bear_gestures.yaml, labelled "
                        "symbolic/NAME (alone: every gesture touch can tell; or comma-separated names)")
    parser.add_argument('--variants', type=_names, default=('normal',),
                        help='comma-separated ways of performing each, e.g. gentle,normal,rough as in CoST '
                        '(default normal)')
    parser.add_argument('--repetitions', type=positive_int, default=3, help='trials per gesture and variant (3)')
    parser.add_argument('--pause-s', type=non_negative_seconds, default=4.0, help='pause between trials, s (4)')
    parser.add_argument('--seed', type=seed, default=0, help='order of the trials and the simulated people (0)')
    parser.add_argument('--person', help='the name of the person performing (live sessions; required there)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing bag --out (live sessions)')
    parser.add_argument('--synthetic', action='store_true',
                        help='mark the live bag synthetic: the running scene plays a virtual device, not a person')
    parser.add_argument('--wait', type=non_negative_seconds, default=5.0, metavar='SECONDS',
                        help="how long a live session waits for the sensor's publisher and first frame (5)")
    parser.add_argument('--rate', type=rate_hz, help='bear scan rate of the virtual bear, Hz (--simulate; 3.4)')


def run(args: argparse.Namespace) -> int:
    """Record the session(s); progress on stderr."""
    def say(msg: str) -> None:
        print(f'[collect {args.sensor}] {msg}', file=sys.stderr, flush=True)

    try:
        gestures = tuple(args.gestures or DEFAULT_GESTURES[args.sensor])
        if getattr(args, 'symbolic', None):
            gestures += _symbolic(args.sensor, args.symbolic)
        protocol = Protocol(gestures, args.variants, args.repetitions, args.pause_s, args.seed)
    except ValueError as err:
        raise SystemExit(f'collect {args.sensor}: {err}') from None
    if args.simulate is None:
        return _live(args, protocol, say)
    out = Path(args.output)
    bags = [out / f'{args.sensor}_{person_name(i)}' for i in range(args.simulate)]
    taken = [b for b in bags if b.exists()]
    if taken:
        raise SystemExit(f'collect {args.sensor}: {taken[0]} exists already; choose another --out or remove it')
    options = {'rate': str(args.rate)} if args.rate and args.sensor == 'bear' else {}
    try:
        for i, bag in enumerate(bags):
            simulate_session(args.sensor, protocol, i, args.simulate, bag, seed=args.seed, device_options=options,
                             progress=say)
    except ValueError as err:   # an unknown gesture for this sensor, a bad device option
        raise SystemExit(f'collect {args.sensor}: {err}') from None
    say(f'{len(bags)} sessions in {out} (SYNTHETIC: simulated people)')
    return 0


def _symbolic(sensor: str, text: str) -> tuple[str, ...]:
    """The bear's symbolic gestures to prompt, as session labels ``symbolic/NAME`` (ValueError otherwise)."""
    if sensor != 'bear':
        raise ValueError('--symbolic is for the bear (its symbolic gestures of config/bear_gestures.yaml)')
    known = [g.name for g in GestureLibrary.default().detectable]
    names = known if text == 'all' else list(_names(text))
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f'--symbolic: unknown gestures {", ".join(unknown)}; the gestures touch can tell are: '
                         f'{", ".join(known)}')
    return tuple(symbolic_label(n) for n in names)


def _live(args: argparse.Namespace, protocol: Protocol, say: Callable[[str], None]) -> int:
    """A live session of ``args.person`` on the running graph (:mod:`.live`)."""
    person = (args.person or '').strip()
    if not person:
        raise SystemExit(f'collect {args.sensor}: name the person performing with --person NAME '
                         '(it goes into every label; train and eval leave one person out)')
    out = Path(args.output)
    if out.exists():
        if not args.overwrite:
            raise SystemExit(f'collect {args.sensor}: {out} exists already; choose another --out, or pass '
                             '--overwrite to replace it')
        if not out.is_dir() or not (out / 'metadata.yaml').exists():
            raise SystemExit(f'collect {args.sensor}: {out} is not a bag; not overwritten')
        shutil.rmtree(out)
    try:
        result = live_session(args.sensor, protocol, person, out, wait_s=args.wait, synthetic=args.synthetic,
                              say=lambda text: print(text, flush=True))
    except LiveSessionError as err:
        raise SystemExit(f'collect {args.sensor}: {err}') from None
    say(f"wrote {out}: {result['kept']} labelled trials, {result['frames']} frames"
        + (' (SYNTHETIC: marked --synthetic)' if args.synthetic else ''))
    return 0
