"""``social-touch codebook record``: record a skin codebook, m repetitions of each gesture (cirillo2017 Fig. 5).

Two sources of touches:

- **the live skin** (default): joins the running graph, subscribes to ``/skin/frame``, cuts gestures as
  the skin node does and prompts on stderr (``u`` undo, ``s`` skip the gesture, ``q`` stop). Touches
  that are no gesture are refused with the reason. Stopped early, what was recorded goes to
  ``FILE.partial.npz`` and the command that resumes it (``--resume``) is printed.
- **--simulate PERFORMERS**: synthetic performers trace the gestures on a virtual skin read by the real
  ``skin_driver`` node in simulated time, through the same recorder (:func:`record_simulated`).
  SYNTHETIC data, and the file says so.

``--gap``: the lift (s) that ends a gesture, while recording and in the file (multi-stroke symbols need
about 1 s). ``--gestures`` defaults to those of the command map (``--commands``).
"""

from __future__ import annotations

import argparse
import bisect
import math
import queue
import sys
import threading
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from touch_gestures.model_card import attach_card, make_card
from touch_gestures.skin.codebook import CodebookRecorder
from touch_gestures.skin.commands import load_command_map
from touch_gestures.skin.frames import SkinFrameStream
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.node import default_commands_path
from touch_gestures.skin.registry import RECOGNISERS as RUNTIME_RECOGNISERS
from touch_gestures.skin.segmentation import GestureSegmenter
from touch_graph.cli.options import non_negative_seconds, positive_int, seed
from touch_graph.dds.tool import GraphTool
from touch_graph.errors import SocialTouchError
from touch_graph.messages import get_message
from touch_graph.node_main import StopSignals
from touch_graph.runtime import QoSProfile, ReliabilityPolicy
from touch_lab.skin.acceptance import calibrate, wrong_rate
from touch_lab.skin.recognisers import (
    DEFAULT_RECOGNISER,
    RECOGNISERS,
    AutoRecogniser,
    make_recogniser,
    save_codebook,
)
from touch_lab.skin.recording import load_recording, save_recording
from touch_sim.skin.people import traced_scene
from touch_sim.skin.render import graph_gestures
from touch_sim.skin.synthetic import SHAPES, synthetic_traces

__all__ = ['LiveSession', 'add_arguments', 'partial_path', 'record_simulated', 'run']


_HELP_KEYS = "u + Enter: undo the last one, s + Enter: skip this gesture, q + Enter: stop (Ctrl-C too)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``social-touch codebook record``."""
    parser.add_argument('-o', '--output', default='skin_codebook.npz', help='codebook file to write '
                        '(default skin_codebook.npz)')
    parser.add_argument('--gestures', help='comma-separated gesture names, in recording order, or a vocabulary: '
                        'digits, letters (default: those of the command map)')
    parser.add_argument('--commands', help="command map whose gestures to record (default: the package's "
                        'config/skin_commands.yaml)')
    parser.add_argument('--repetitions', '-m', type=positive_int, default=10,
                        help='repetitions per gesture, m of cirillo2017 3.2 (default 10)')
    parser.add_argument('--recogniser', default=DEFAULT_RECOGNISER,
                        help=f'recogniser the codebook is for: {", ".join(RECOGNISERS)} (default {DEFAULT_RECOGNISER})')
    parser.add_argument('--vocabulary', default='commands',
                        help='name of the vocabulary the codebook holds (default commands)')
    parser.add_argument('--gap', type=non_negative_seconds, metavar='S',
                        help='lift (s) that ends a gesture, while recording and in the file (default 0.15 s, gestures '
                        'of one stroke; about 1 s for symbols of several strokes)')
    parser.add_argument('--person', default='', metavar='NAME',
                        help='who traces (kept with each template, so the lab can choose the recogniser '
                        'leave-one-person-out; record each person with their own name, resuming the same file)')
    parser.add_argument('--max-wrong-rate', type=wrong_rate, metavar='RATE',
                        help='calibrate the rejection from the codebook, leave-one-person-out, for at most this share '
                        'of wrong commands on new people, e.g. 0.005 (needs two people or more; '
                        'touch_lab.skin.acceptance); default: the recogniser\'s own thresholds')
    parser.add_argument('--simulate', type=positive_int, metavar='PERFORMERS',
                        help='record synthetic performers on a virtual skin instead of the live skin')
    parser.add_argument('--seed', type=seed, default=0, help='with --simulate: performers and sensor noise')
    parser.add_argument('--resume', metavar='FILE', help='go on with a recording stopped early (FILE.partial.npz)')
    parser.add_argument('--topic', default='/skin/frame', help='live: the skin frames topic (default /skin/frame)')
    parser.add_argument('--wait', type=non_negative_seconds, default=5.0,
                        help='live: seconds to wait for the topic (default 5)')


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def partial_path(output: str | Path) -> Path:
    """Where a recording stopped early is saved: ``codebook.npz`` -> ``codebook.partial.npz``.

    >>> str(partial_path('config/skin_codebook.npz'))
    'config/skin_codebook.partial.npz'
    """
    output = Path(output)
    stem = output.name[:-4] if output.name.endswith('.npz') else output.name
    return output.with_name(stem + '.partial.npz')


def _gesture_names(args: argparse.Namespace) -> list[str]:
    if args.gestures:
        from touch_sim.skin.synthetic import gesture_list  # the vocabularies' names, not the simulation
        names = gesture_list(args.gestures)
        if not names:
            raise ValueError('--gestures needs at least one name')
        return names
    return list(load_command_map(args.commands or default_commands_path()).commands)


# ----------------------------------------------------------------------------- simulated
def record_simulated(gestures: Sequence[str], repetitions: int, performers: int, seed: int = 0,
                     recorder: CodebookRecorder | None = None, say: Callable[[str], None] = _say
                     ) -> tuple[CodebookRecorder, Counter[str]]:
    """Fill a recorder with gestures of synthetic performers traced through the skin graph (SYNTHETIC).

    Every performer traces each gesture ``ceil(m / performers) + 1`` times (one spare each), gesture
    after gesture, repetition after repetition, performer after performer; the skin graph
    (:func:`~touch_sim.skin.render.graph_gestures`) cuts the frames, each gesture is matched to the trace it
    came from by time, and the recorder takes them in order until it has ``repetitions`` of each.

    Returns: the recorder and counters: ``traced`` samples, ``kept``, ``refused`` by the recorder
    (with reasons as lines on ``say``), ``split`` (a trace that did not give exactly one gesture).

    Raises:
        ValueError: unknown shape names, bad counts, or too few usable traces for some gesture.
    """
    unknown = [g for g in gestures if g not in SHAPES]
    if unknown:
        raise ValueError(f'--simulate can trace only the synthetic shapes ({", ".join(SHAPES)}); unknown: '
                         f'{", ".join(unknown)}')
    if performers < 1 or repetitions < 1:
        raise ValueError(f'need performers >= 1 and repetitions >= 1; got {performers}, {repetitions}')
    rec = recorder if recorder is not None else CodebookRecorder(list(gestures), repetitions=repetitions)
    per = -(-repetitions // performers) + 1
    order = {g: i for i, g in enumerate(gestures)}
    samples = sorted(synthetic_traces(list(gestures), performers=performers, repetitions=per, seed=seed),
                     key=lambda s: (order[s.gesture], int(s.sample), s.subject))
    scene = traced_scene(samples, seed=seed)
    say(f'[codebook record] {len(samples)} synthetic traces by {performers} performers through the virtual skin '
        f'({scene.duration_s:.0f} s of simulated time) ...')
    starts = [e.start_s for e in scene.events]
    got: list[list[TouchGesture]] = [[] for _ in scene.events]
    for timed in graph_gestures(scene, seed=seed):
        k = bisect.bisect_right(starts, timed.start_s + 0.1) - 1  # contact begins in the 50 ms touch-down ramp
        if k >= 0 and timed.start_s <= scene.events[k].end_s + 0.1:
            got[k].append(timed.gesture)
    counts: Counter[str] = Counter(traced=len(samples))
    for event, gestures_of_trace in zip(scene.events, got, strict=True):
        if rec.current != event.label:
            continue  # this gesture is complete (or skipped): the spare traces are not needed
        if len(gestures_of_trace) != 1:
            counts['split'] += 1
            continue
        rec.person = event.person
        kept, line = rec.add(gestures_of_trace[0])
        counts['kept' if kept else 'refused'] += 1
        if not kept:
            say(f'[codebook record] {event.person}: {line}')
    short = [f'{g} ({rec.count(g)}/{repetitions})' for g in gestures if rec.count(g) < repetitions]
    if short:
        raise ValueError(f'too few usable traces for {", ".join(short)}; add performers (--simulate) or change '
                         'the seed')
    return rec, counts


# ----------------------------------------------------------------------------- live
class LiveSession:
    """The live recording without its I/O: frames and typed lines in, lines for the person out.

    Args:
        recorder: collects the gestures (possibly resumed from a file).
        stream: frames -> gestures (the skin node's segmentation).
        say: where the lines for the person go (stderr).
    """

    def __init__(self, recorder: CodebookRecorder, stream: SkinFrameStream | None = None,
                 say: Callable[[str], None] = _say) -> None:
        self.recorder = recorder
        self.stream = stream if stream is not None else SkinFrameStream()
        self.say = say
        self.stopped = False

    def prompt(self) -> None:
        """Ask for the next repetition (or say the codebook is complete)."""
        name = self.recorder.current
        if name is None:
            self.say('all gestures recorded')
        else:
            self.say(f"trace '{name}' ({self.recorder.count(name) + 1}/{self.recorder.repetitions})")

    def on_frame(self, msg: Any) -> None:
        """One ``SkinFrame``: a finished gesture is offered to the recorder and answered."""
        for gesture in self.stream.update(msg):
            if self.recorder.done:
                return
            kept, line = self.recorder.add(gesture)
            self.say(('kept ' if kept else 'not kept: ') + line)
            self.prompt()

    def on_line(self, text: str) -> None:
        """A line typed by the person: ``u`` undo, ``s`` skip, ``q`` stop."""
        command = text.strip().lower()
        if command == 'u':
            name = self.recorder.undo()
            self.say(f'undone: the last {name}' if name else 'nothing to undo')
        elif command == 's':
            name = self.recorder.skip()
            self.say(f'skipped {name}: it will not be in the codebook' if name else 'nothing to skip')
        elif command == 'q':
            self.stopped = True
            return
        elif command:
            self.say(f'unknown command {command!r}; {_HELP_KEYS}')
            return
        else:
            return
        self.prompt()


def _stdin_lines(out: queue.Queue) -> None:
    """Read lines from stdin into ``out`` (a daemon thread: the process may exit while it waits)."""
    try:
        for line in sys.stdin:
            out.put(line)
    except (OSError, ValueError):  # stdin closed or not readable: no commands, recording goes on
        pass


def live_stream(gap_s: float | None) -> SkinFrameStream:
    """Frames -> gestures for a live recording: the skin node's segmentation, with ``gap_s`` (s) as the
    lift that ends a gesture (None: the single-stroke default)."""
    if gap_s is None:
        return SkinFrameStream()
    if not (math.isfinite(gap_s) and gap_s >= 0):
        raise ValueError(f'--gap must be a lift of 0 s or more, got {gap_s}')
    return SkinFrameStream(GestureSegmenter(gap_s=gap_s))


def _record_live(args: argparse.Namespace, recorder: CodebookRecorder) -> bool:
    """Record from the running graph; True when the recorder is complete, False when stopped early."""
    type_name = 'social_touch_msgs/msg/SkinFrame'
    session = LiveSession(recorder, live_stream(args.gap))
    with GraphTool('codebook_record') as tool:
        info = tool.require_topic(args.topic, type_name, wait_s=args.wait)
        if not info.publishers:
            _say(f'[codebook record] nobody publishes {args.topic} yet (is skin_driver running?); waiting for frames')
        # Best effort matches the driver's sensor-data QoS and any reliable publisher too.
        frames = tool.node.create_subscription(get_message(type_name), args.topic, session.on_frame,
                                               QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT))
        _say(f'[codebook record] recording {", ".join(recorder.gestures)} from {args.topic}, '
             f'{recorder.repetitions} each; {_HELP_KEYS}')
        session.prompt()
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=_stdin_lines, args=(lines,), daemon=True, name='stdin').start()
        alone = False
        with StopSignals(tool.executor.wake) as stop:
            while not stop.requested and not session.stopped and not recorder.done:
                while not lines.empty():
                    session.on_line(lines.get())
                tool.executor.spin_once(0.1)
                if tool.discovery.remote_participant_count():
                    alone = False
                elif not alone:
                    alone = True
                    _say('[codebook record] the graph has gone away; waiting for it to come back (q + Enter or '
                         'Ctrl-C: stop and save what was recorded)')
        bad = Counter({'undecodable': frames._dds.undecodable}) if frames._dds is not None else Counter()
        skipped = {**session.stream.skipped, **+bad}
        if skipped:
            _say(f'[codebook record] frames skipped: {skipped}')
    return recorder.done


# ----------------------------------------------------------------------------- entry point
def run(args: argparse.Namespace) -> int:
    """Entry point of ``social-touch codebook record``; returns the exit status."""
    try:
        make_recogniser(args.recogniser)
        if args.repetitions < 1:
            raise ValueError(f'--repetitions must be >= 1, got {args.repetitions}')
        live_stream(args.gap)       # a bad --gap stops here, before any recording
        if not args.vocabulary.strip():
            raise ValueError('--vocabulary needs a name')
        if args.resume:
            recorder = load_recording(args.resume)
            _say(f'[codebook record] resuming {args.resume}: {len(recorder.samples)} repetitions of '
                 f'{", ".join(recorder.gestures)} kept ({recorder.repetitions} each wanted)')
        else:
            recorder = CodebookRecorder(_gesture_names(args), repetitions=args.repetitions)
        recorder.person = args.person.strip()
        if args.simulate is not None:
            recorder, counts = record_simulated(recorder.gestures, recorder.repetitions, args.simulate, args.seed,
                                                recorder=recorder)
            _say(f'[codebook record] {dict(counts)}')
            description = (f'SYNTHETIC: {args.simulate} simulated performers (touch_sim.skin.synthetic, seed '
                           f'{args.seed}) traced through the virtual skin, skin_driver and the segmenter, '
                           f'{recorder.repetitions} repetitions per gesture')
            complete = True
        else:
            description = f'recorded on the skin ({args.topic}), {recorder.repetitions} repetitions per gesture'
            try:
                complete = _record_live(args, recorder)
            except KeyboardInterrupt:
                complete = False
        if not complete:
            if not recorder.samples:
                _say('[codebook record] stopped; nothing was recorded, no file written')
                return 1
            path = save_recording(partial_path(args.output), recorder)
            _say(f'[codebook record] stopped after {len(recorder.samples)} repetitions; saved to {path}. Resume '
                 f'with: social-touch codebook record --resume {path} -o {args.output} --recogniser {args.recogniser}'
                 f' --vocabulary {args.vocabulary}' + ('' if args.gap is None else f' --gap {args.gap:g}'))
            return 1
        model = recorder.fit(make_recogniser(args.recogniser))
        if args.max_wrong_rate is not None:
            calibrate(model, args.max_wrong_rate, args.gap, _say)
        path = save_codebook(args.output, model, description=description, vocabulary=args.vocabulary,
                             gap_s=args.gap)
        people = f'{args.simulate} simulated performers (seed {args.seed})' if args.simulate is not None else None
        attach_card(path, make_card('skin_codebook', data={
            'synthetic': args.simulate is not None, 'source': description, 'recogniser': args.recogniser,
            **({'people': args.simulate} if args.simulate is not None
               else {'people': len(set(recorder.people) - {''})} if any(recorder.people) else {}),
            'trials_per_class': dict(sorted(Counter(recorder.labels).items())), 'templates': len(model.templates_)},
            notes=f'people: {people}' if people else ''))
    except (SocialTouchError, ValueError) as err:
        _say(f'codebook record: {err}')
        return 2
    left_out = f'; left out: {", ".join(recorder.skipped)}' if recorder.skipped else ''
    _say(f'[codebook record] wrote {path}: {len(model.templates_)} templates of {len(model.classes_)} gestures '
         f'({args.recogniser}){left_out}')
    saved = model.chosen_.name if isinstance(model, AutoRecogniser) else model.name
    if saved not in RUNTIME_RECOGNISERS:
        _say(f'[codebook record] note: {saved} is a lab recogniser; the robot (haptic_commands) loads codebooks '
             f'of {", ".join(RUNTIME_RECOGNISERS)} only')
    return 0

