"""``haptic_commands``: commands traced on the optoelectronic skin, on the graph (cirillo2017 3.2, Fig. 5).

Subscribes to ``frame`` (``SkinFrame`` from ``skin_driver``) and, on every touch:

1. segments it (:class:`~.frames.SkinFrameStream`, :class:`~.segmentation.GestureSegmenter`),
   time from the header stamps;
2. screens it (:func:`~.screening.screen_gesture`): two fingers, a touch cut at ``max_duration_s``,
   too few points or smaller than ``min_extent_mm`` is no command;
3. recognises it against the codebook, with its rejection rule (:mod:`.base`);
4. while it is traced, every ``candidate_period_s``, publishes the best candidate so far
   (:class:`~.early.PrefixMatcher`) on ``candidate`` (``SkinCandidate``);
5. publishes every frame in contact on ``contact`` (``SkinContact``: point in m, force in N, rise
   rate) and a ``SkinCollision`` on ``collision`` when the normal force or rise rate crosses
   ``collision_force_n`` / ``collision_rate_n_s`` (:class:`~.collisions.CollisionDetector`); the
   gesture under way is then no command (outcome ``'collision'``);
6. publishes an accepted gesture that has a command on ``/touch/haptic_command``
   (``HapticCommand``; stamp: the end of the gesture, frame_id ``skin``).

Everything else is logged at debug level and counted in :attr:`HapticCommandsNode.outcomes`. Bad
frames (wrong size, NaN) are counted in ``stream.skipped``; frames of another publisher are screened
out (:class:`~touch_graph.frame_screen.FrameScreen`, :attr:`HapticCommandsNode.screen`) and reported
on ``/diagnostics``.

Parameters (read once at start, except ``max_distance``, ``auto_scale``, ``auto_quantile``,
``min_margin`` and ``min_extent_mm``, which apply from the next gesture):

- ``codebook``: the ``.npz`` codebook (default ``config/skin_codebook.npz``, SYNTHETIC:
  ``config/skin_codebook.md``); ``commands``: the gesture -> command map (default
  ``config/skin_commands.yaml``; a gesture the codebook does not know stops the node at start);
- ``recogniser``: must match the codebook's (empty: the codebook's);
- segmentation: ``gap_s`` (default: the codebook's), ``wait_s``, ``max_duration_s``, ``min_frames``,
  ``map_threshold``, ``map_relative``, ``merge_gap_taxels``, ``min_multi_frames``, ``multi_fraction``
  (:class:`~.segmentation.GestureSegmenter`), ``max_gap_s`` (frames stopped this long: the gesture
  under way is dropped);
- rejection (defaults from the codebook file): ``max_distance`` (-1: per-class thresholds, a number
  >= 0: one for all), ``auto_scale``, ``auto_quantile``, ``min_margin``.

Any process in the DDS domain can set the rejection, screening and collision parameters, so their
descriptors carry ranges that keep each check meaningful (:data:`SAFETY_RANGES`), refused as rclpy
refuses; every change after start is logged at WARN and counted on ``/diagnostics``.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import math
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from touch_graph.compat import (
    FloatingPointRange,
    IntegerRange,
    Node,
    ParameterDescriptor,
    SetParametersResult,
    get_message,
    sensor_data_qos,
)
from touch_graph.errors import ConfigError, ParameterError
from touch_graph.node_health import NodeHealth
from touch_graph.node_main import run_node
from touch_graph.paths import share_file

from ..model_card import card_log_line
from .base import Match, TemplateRecogniser
from .codebook import load_codebook
from .collisions import COLLISION_FORCE_N, COLLISION_RATE_N_S, CollisionDetector
from .commands import COMMAND_TOPIC, CommandMap, haptic_command, load_command_map
from .early import PrefixMatcher
from .ending import GestureEnd, vocabulary_ending
from .frames import SkinFrameStream
from .gesture import GRID, TouchGesture
from .screening import MIN_EXTENT_MM, gesture_extent_mm, screen_gesture
from .segmentation import GestureSegmenter

__all__ = ['CODEBOOK_COMMAND', 'DEFAULT_CODEBOOK', 'DEFAULT_COMMANDS', 'HapticCommandsNode', 'main']

SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
SkinCandidate = get_message('social_touch_msgs/msg/SkinCandidate')
SkinContact = get_message('social_touch_msgs/msg/SkinContact')
SkinCollision = get_message('social_touch_msgs/msg/SkinCollision')
TimeMsg = get_message('builtin_interfaces/msg/Time')

#: The shipped codebook and command map, relative to the package's share directory.
DEFAULT_CODEBOOK = ('config', 'skin_codebook.npz')
DEFAULT_COMMANDS = ('config', 'skin_commands.yaml')
#: How the shipped codebook is made (config/skin_codebook.md).
CODEBOOK_COMMAND = ('social-touch codebook record --simulate 10 --seed 2026 --repetitions 30 '
                    '-o config/skin_codebook.npz')
_NS = 1_000_000_000
#: Frames the subscription holds: one second of the driver's 150 Hz. A gesture needs every frame of its touch,
#: and a driver whose reads were held up (the node's start, a busy machine) publishes the frames it read at once.
FRAME_QUEUE = 150
#: GestureSegmenter's parameters that are node parameters, with its defaults and what they mean.
_SEGMENTER_DOC = {
    'gap_s': "a lift must last this long (s) to end a gesture; shorter lifts separate its strokes (default: the "
             "codebook's vocabulary's, 0.15 s single-stroke, 1 s multi-stroke with wait_s; not in cirillo2017)",
    'max_duration_s': 'a touch is cut after this long (s) and gives no command (a hand resting on the skin)',
    'min_frames': 'contacts with fewer frames are dropped as taps or noise',
    'map_threshold': 'pressure (1 = full scale) a taxel must reach to enter the map (cirillo2017 3.1)',
    'map_relative': 'and this fraction of the frame\'s highest pressure',
    'merge_gap_taxels': 'blobs at most this many empty taxels apart are one finger',
    'min_multi_frames': 'frames with two blobs needed to call a gesture two-finger...',
    'multi_fraction': '...and the fraction of its frames they must make up',
}
_SEGMENTER_DEFAULTS = {name: p.default for name, p in inspect.signature(GestureSegmenter).parameters.items()
                       if name in _SEGMENTER_DOC}
#: Rejection parameters every TemplateRecogniser has (touch_gestures.skin.base).
_REJECTION = ('max_distance', 'auto_scale', 'auto_quantile', 'min_margin')
#: (low, high) of the parameters that can switch a safety check off, and why the bound: a value outside
#: makes the check a formality. ``max_distance``'s upper bound is the codebook's (:func:`max_distance_bound`).
SAFETY_RANGES: dict[str, tuple[float, float, str]] = {
    'auto_scale': (0.5, 5.0, 'more than 5 x the spread of a class accepts shapes of other classes'),
    'auto_quantile': (0.5, 1.0, 'the thresholds rest on the typical spread of a class, not its tightest pairs'),
    'min_margin': (0.02, 2.0, 'below 2 % a near tie between two gestures gives a command'),
    'min_extent_mm': (0.0, 47.0, 'the skin is 47 mm across'),
    'collision_force_n': (0.5, 30.0, 'above 30 N an impact is never a collision'),
    'collision_rate_n_s': (10.0, 1000.0, 'above 1000 N/s no impact rises fast enough to be one'),
    'rate_frames': (1, 30, 'the rise rate is measured within 0.2 s at 150 Hz'),
}


def default_codebook_path() -> Path:
    return share_file(*DEFAULT_CODEBOOK)


def default_commands_path() -> Path:
    return share_file(*DEFAULT_COMMANDS)


def max_distance_bound(model: TemplateRecogniser) -> float:
    """Largest meaningful ``max_distance``: the largest distance from a codebook template to the nearest
    template of another class (a threshold beyond it accepts a shape as far from its class as the codebook's
    gestures are from each other); for a one-class codebook, 10 x the largest distance within it."""
    within, between = model._loo_distances()
    for distances, scale in ((between, 1.0), (within, 10.0)):
        finite = distances[np.isfinite(distances)]
        if finite.size:
            return float(scale * finite.max())
    return 1.0


def _bad_frame(msg: Any) -> str | None:
    """Why ``msg`` cannot be a skin frame (the stream's reasons: ``'wrong_size'``, ``'non_finite'``), or None."""
    pressure = np.asarray(msg.pressure, dtype=np.float32)
    if pressure.size != GRID * GRID:
        return 'wrong_size'
    return None if np.isfinite(pressure).all() else 'non_finite'


def _time_msg(ns: int) -> Any:
    sec, nanosec = divmod(int(ns), _NS)
    return TimeMsg(sec=sec, nanosec=nanosec)


class HapticCommandsNode(Node):
    """Haptic commands from the skin driver's frames (see the module doc).

    Attributes:
        recogniser: the loaded codebook (a fitted :class:`~.base.TemplateRecogniser`).
        commands: the :class:`~.commands.CommandMap`.
        stream: frames -> gestures; ``stream.frames``, ``stream.skipped`` (bad frames by reason),
            ``stream.interrupted``, ``stream.restarts``, ``stream.segmenter.stats``.
        outcomes: what became of each gesture: ``'published'``, ``'unmapped'``, ``'rejected_distance'``,
            ``'rejected_margin'``, ``'rejected_strokes'``, ``'rejected_duration'``, ``'rejected_unusable'``, or
            a screening reason (``'multi_contact'``, ``'truncated'``, ``'too_few_points'``, ``'too_small'``).
        last_match: the recogniser's answer for the latest gesture it saw (None before any).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('haptic_commands', **kwargs)
        self._fqn = self.get_fully_qualified_name()
        self.recogniser = self._load_codebook()
        self.recogniser_name = self.recogniser.name
        self.commands = self._load_commands()
        self._configure_rejection()
        self.stream = self._make_stream()
        self.min_extent_mm = self._param('min_extent_mm', float(MIN_EXTENT_MM),
                                         'touches whose trajectory is smaller than this (mm, longer side of its '
                                         'box) give no command: a press, a tap (not in cirillo2017; default two '
                                         'taxel pitches)')
        if not (math.isfinite(self.min_extent_mm) and self.min_extent_mm >= 0):
            raise self._bad('min_extent_mm', self.min_extent_mm, 'a size >= 0 mm')
        self.outcomes: Counter[str] = Counter()
        self.last_match: Match | None = None
        self._setup_candidates()
        self._setup_collisions()
        self.command_pub = self.create_publisher(HapticCommand, COMMAND_TOPIC, 20)
        self.health = NodeHealth(self)   # a frame callback that raises: ERROR on /diagnostics; dropped frames: WARN
        self.create_subscription(SkinFrame, 'frame', self.health.guard(self._on_frame, 'frame'),
                                 sensor_data_qos(FRAME_QUEUE))
        self.drops = self.health.drops
        self.screen = self.health.screen(self.resolve_topic_name('frame'))   # another publisher's frames
        self.add_on_set_parameters_callback(self._on_set_parameters)
        classes = [str(c) for c in self.recogniser.classes_]
        unmapped = [c for c in classes if c not in self.commands.commands]
        origin = self.recogniser.description_ or 'a codebook without a description'
        self.get_logger().info(
            f'{self.codebook_path} ({origin}): vocabulary {getattr(self.recogniser, "vocabulary_", "?")}, '
            f'{len(self.recogniser.templates_)} templates of {len(classes)} '
            f'gestures, recogniser {self.recogniser_name}; {len(self.commands.commands)} commands from '
            f'{self.commands_path}'
            + (f'; recognised without a command: {", ".join(unmapped)}' if unmapped else ''))
        self.get_logger().info(card_log_line(self.codebook_path))

    # ------------------------------------------------------------------ parameters
    #: Parameters applied at once when set: rejection and screening. The others are read at start (read-only).
    LIVE_PARAMETERS = (*_REJECTION, 'min_extent_mm')

    def _param(self, name: str, default: Any, description: str, bounds: tuple[Any, Any, str] | None = None) -> Any:
        """Declare ``name``; ``bounds`` (low, high, why) become the descriptor's range (default: SAFETY_RANGES)."""
        bounds = bounds or SAFETY_RANGES.get(name)
        descriptor = ParameterDescriptor(description=description, read_only=name not in self.LIVE_PARAMETERS)
        if bounds is not None:
            low, high, why = bounds
            descriptor.additional_constraints = f'in [{low}, {high}]: {why}'
            if isinstance(default, int):
                descriptor.integer_range = [IntegerRange(from_value=low, to_value=high, step=1)]
            else:
                descriptor.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high),
                                                                      step=0.0)]
        return self.declare_parameter(name, default, descriptor).value

    def _bad(self, name: str, value: Any, expected: str) -> ParameterError:
        return ParameterError(f"parameter '{name}' of {self._fqn} must be {expected}; got {value!r}")

    def _load_codebook(self) -> TemplateRecogniser:
        given = self._param('codebook', '', "skin codebook .npz (default: the package's config/skin_codebook.npz, "
                                            'recorded from simulated performers)')
        wanted = self._param('recogniser', '', "the codebook's recogniser must be this one (empty: whichever "
                                               'the codebook was made with)')
        self.codebook_path = Path(given) if given else default_codebook_path()
        try:
            return load_codebook(self.codebook_path, recogniser=wanted or None)
        except ConfigError as err:
            if not given:
                how = f'; it is the package default, made with `{CODEBOOK_COMMAND}`; or set codebook:=FILE'
            elif not self.codebook_path.exists():
                how = f' (relative paths start at {Path.cwd()})'
            elif wanted:
                how = f'; record one with `social-touch codebook record --recogniser {wanted} -o FILE`'
            else:
                how = ''
            raise ParameterError(f"parameter 'codebook' of {self._fqn}: {err}{how}") from err

    def _load_commands(self) -> CommandMap:
        given = self._param('commands', '', 'gesture -> command map YAML (default: config/skin_commands.yaml)')
        path = Path(given) if given else default_commands_path()
        self.commands_path = path
        try:
            return load_command_map(path, gestures=[str(c) for c in self.recogniser.classes_])
        except ConfigError as err:
            how = (f' (relative paths start at {Path.cwd()})' if given and not path.exists() else
                   f'; the codebook {self.codebook_path} knows {", ".join(map(str, self.recogniser.classes_))}')
            raise ParameterError(f"parameter 'commands' of {self._fqn}: {err}{how}") from err

    def _configure_rejection(self) -> None:
        """Rejection parameters default to the codebook's; other values recompute its class thresholds."""
        stored = self.recogniser.get_params()
        md = stored['max_distance']
        stored_md = -1.0 if md == 'auto' else math.inf if md is None else float(md)
        bound = max_distance_bound(self.recogniser)
        given = {
            'max_distance': self._param('max_distance', stored_md,
                                        'rejection distance: -1 = per class from the codebook (auto_scale x the '
                                        'auto_quantile quantile of its own spread), >= 0 = one for all',
                                        (-1.0, math.ceil(bound * 1e4) / 1e4,
                                         "at most the codebook's largest distance between a template and the "
                                         'nearest template of another class')),
            'auto_scale': self._param('auto_scale', float(stored['auto_scale']), 'see max_distance'),
            'auto_quantile': self._param('auto_quantile', float(stored['auto_quantile']), 'see max_distance'),
            'min_margin': self._param('min_margin', float(stored['min_margin']),
                                      'no command when the runner-up class is closer than (1 + min_margin) x '
                                      'the best distance'),
        }
        self.recogniser = self._with_rejection(self.recogniser, given)

    def _with_rejection(self, model: TemplateRecogniser, given: dict[str, float]) -> TemplateRecogniser:
        """``model``, or a copy with these rejection values and its class thresholds recomputed."""
        value = given['max_distance']
        if not (value == -1.0 or value >= 0):   # NaN fails too
            raise self._bad('max_distance', value, '-1 (per-class, from the codebook), a distance >= 0 or .inf')
        new = {**given, 'max_distance': 'auto' if value == -1.0 else None if math.isinf(value) else value}
        stored = model.get_params()
        if all(new[k] == stored[k] for k in _REJECTION):
            return model  # the thresholds in force hold
        model = copy.deepcopy(model)  # the one in use stays whole if these values are refused
        try:
            model.set_params(**new)
            # The codebook's evidence (strokes, durations, paths) stays: only the thresholds are recomputed.
            model.set_codebook(model.templates_, model.classes_[model.template_labels_],
                               template_strokes=getattr(model, 'template_strokes_', None),
                               template_contact_s=getattr(model, 'template_contact_s_', None),
                               template_paths=getattr(model, 'template_paths_', None))
        except ValueError as err:
            raise ParameterError(f'rejection parameters of {self._fqn}: {err}') from err
        self.get_logger().info(f'rejection {new} (was {({k: stored[k] for k in _REJECTION})}): class thresholds '
                               'recomputed')
        return model

    def _on_set_parameters(self, params: list[Any]) -> Any:
        """Rejection and ``min_extent_mm`` apply from the next gesture; the others are read at start (read-only)."""
        values = {name: self.get_parameter(name).value for name in self.LIVE_PARAMETERS}
        values.update({p.name: p.value for p in params if p.name in values})
        extent = values.pop('min_extent_mm')
        if not (math.isfinite(extent) and extent >= 0):
            return SetParametersResult(successful=False, reason=str(self._bad('min_extent_mm', extent,
                                                                                'a size >= 0 mm')))
        try:
            recogniser = self._with_rejection(self.recogniser, values)
        except ParameterError as err:
            return SetParametersResult(successful=False, reason=str(err))
        self.recogniser, self.min_extent_mm = recogniser, extent
        return SetParametersResult(successful=True)

    def _make_stream(self) -> SkinFrameStream:
        # The end of a gesture is the vocabulary's: in a multi-stroke one the codebook tells a whole gesture
        # from the beginning of a longer one (touch_gestures.skin.ending); otherwise the codebook file's gap.
        gap_s, wait_s, rule = vocabulary_ending(self.recogniser)
        wait = self._param('wait_s', wait_s or 0.0, 'longest lift (s) that continues strokes the codebook calls the '
                           'beginning of a longer gesture (default: 3 s in a multi-stroke vocabulary read by cloud or '
                           'trace; 0: every gesture ends at gap_s; see touch_gestures.skin.ending)')
        if wait > 0 and rule is None:
            try:
                rule = GestureEnd(self.recogniser)
            except ValueError as err:
                raise ParameterError(f'wait_s of {self._fqn}: {err}') from err
        if not wait > 0:   # no waiting: the codebook file's gap ends every gesture
            gap_s, rule = float(getattr(self.recogniser, 'gap_s_', gap_s)), None
        defaults = {**_SEGMENTER_DEFAULTS, 'gap_s': gap_s}
        seg = {name: self._param(name, default, f'{_SEGMENTER_DOC[name]} (see GestureSegmenter)')
               for name, default in defaults.items()}
        max_gap_s = self._param('max_gap_s', 0.5, 'no frame for this long (s): the gesture under way is dropped')
        try:
            return SkinFrameStream(GestureSegmenter(**seg, wait_s=wait if rule is not None else None,
                                                    is_complete=rule), max_gap_s=max_gap_s)
        except ValueError as err:
            raise ParameterError(f'segmentation parameters of {self._fqn}: {err}') from err

    # ------------------------------------------------------------------ frames
    def health_counters(self) -> dict[str, int]:
        """Counters for /diagnostics (:class:`~touch_graph.node_health.NodeHealth`): what became of each
        gesture (``outcome_*``) and the segmenter's (``segmenter_*``: waits for a next stroke, gestures
        ended at the bound or cut at the longest duration, bad frames)."""
        stats = dataclasses.asdict(self.stream.segmenter.stats)
        return {**{f'outcome_{k}': v for k, v in sorted(self.outcomes.items())},
                **{f'segmenter_{k}': v for k, v in stats.items()}}

    def _on_frame(self, msg: Any) -> None:
        bad = _bad_frame(msg)
        if bad is not None:   # counted by the stream as before, and by the screen for /diagnostics
            self.screen.malformed(bad)
            self._on_own_frame(msg)
            return
        for frame in self.screen.admit(msg):
            self._on_own_frame(frame)

    def _on_own_frame(self, msg: Any) -> None:
        stream = self.stream
        skipped, restarts = sum(stream.skipped.values()), stream.restarts
        gestures = stream.update(msg)
        if stream.frames and sum(stream.skipped.values()) == skipped:   # a frame the stream took
            self._contact(msg)
        if sum(stream.skipped.values()) != skipped:
            self.get_logger().warning(f'skipped a frame: its pressure must be 144 finite values; frames skipped so '
                                      f'far: {dict(stream.skipped)}', throttle_duration_sec=5.0)
        if stream.restarts != restarts:
            self.get_logger().warning('time went back (a looped bag or a restarted driver?): the touch under way '
                                      'is dropped, starting afresh')
        for gesture in gestures:
            self._on_gesture(gesture)
            self._next_candidate_t = -math.inf
        self._publish_candidate(msg)

    def _setup_candidates(self) -> None:
        self.candidate_period_s = self._param('candidate_period_s', 0.1, 'publish the candidate for a gesture under '
                                              'way this often, s (0: never)')
        if not (math.isfinite(self.candidate_period_s) and self.candidate_period_s >= 0):
            raise self._bad('candidate_period_s', self.candidate_period_s, 'a period >= 0 s')
        self.prefix_matcher: PrefixMatcher | None = None
        if self.candidate_period_s > 0:
            try:
                self.prefix_matcher = PrefixMatcher(self.recogniser)
            except ValueError as err:   # a recogniser without ordered points (the paper's maps)
                self.get_logger().info(f'no early candidates: {err}')
        self.candidate_pub = self.create_publisher(SkinCandidate, 'candidate', 20)
        self._next_candidate_t = -math.inf
        self.candidates_published = 0

    def _setup_collisions(self) -> None:
        force = self._param('collision_force_n', COLLISION_FORCE_N, 'normal force (N) from which a contact is a '
                            'collision (.inf: never)')
        rate = self._param('collision_rate_n_s', COLLISION_RATE_N_S, 'normal force rise (N/s) from which a contact '
                           'is a collision (.inf: never)')
        frames = self._param('rate_frames', 3, 'the force rise rate is measured over this many frames (150 Hz)')
        try:
            self.collisions = CollisionDetector(force, rate, frames)
        except ValueError as err:
            raise ParameterError(f'collision parameters of {self._fqn}: {err}') from err
        self.contact_pub = self.create_publisher(SkinContact, 'contact', 50)
        self.collision_pub = self.create_publisher(SkinCollision, 'collision', 20)
        self._collision_in_gesture = False

    def _contact(self, msg: Any) -> None:
        """Contact state and collision of one frame (the detector counts NaN forces as 0)."""
        t = int(msg.header.stamp.sec) + int(msg.header.stamp.nanosec) / _NS
        point = (float(msg.contact_x), float(msg.contact_y))
        state = self.collisions.update(bool(msg.contact), point, np.asarray(msg.force, dtype=np.float64), t)
        if state is None:
            return
        fx, fy, fz = (float(v) for v in state.force_n)
        self.contact_pub.publish(SkinContact(
            header=copy.copy(msg.header), start=state.start, end=state.end, x_m=state.x_m, y_m=state.y_m, z_m=0.0,
            fx_n=fx, fy_n=fy, fz_n=fz, force_rate_n_s=state.force_rate_n_s, duration_s=state.duration_s))
        if state.collision is None:
            return
        self._collision_in_gesture = True
        self.collision_pub.publish(SkinCollision(
            header=copy.copy(msg.header), reason=state.collision, x_m=state.x_m, y_m=state.y_m, z_m=0.0,
            fx_n=fx, fy_n=fy, fz_n=fz, force_rate_n_s=state.force_rate_n_s, frames_since_start=state.frames))
        self.get_logger().warning(f'collision ({state.collision}): {fz:.1f} N, rising {state.force_rate_n_s:.0f} '
                                  f'N/s, at ({1000 * state.x_m:.0f}, {1000 * state.y_m:.0f}) mm')

    def _publish_candidate(self, msg: Any) -> None:
        """The best candidate for the gesture under way, at most every candidate_period_s of its time."""
        seg = self.stream.segmenter
        if self.prefix_matcher is None or not seg.active:
            self._next_candidate_t = -math.inf
            return
        partial = seg.partial()
        if partial is None or partial.times[-1] < self._next_candidate_t:
            return
        if self._next_candidate_t == -math.inf:  # a new gesture: its first candidate one period in
            self._next_candidate_t = partial.start_s + self.candidate_period_s
            if partial.times[-1] < self._next_candidate_t:
                return
        self._next_candidate_t = partial.times[-1] + self.candidate_period_s
        cand = self.prefix_matcher.candidate(partial)
        self.candidates_published += 1
        self.candidate_pub.publish(SkinCandidate(
            header=copy.copy(msg.header), gesture=cand.label or '', confidence=cand.confidence,
            distance=cand.distance if math.isfinite(cand.distance) else -1.0, progress=cand.progress,
            elapsed_s=float(partial.times[-1] - partial.start_s), strokes=partial.strokes))

    def _on_gesture(self, gesture: TouchGesture) -> None:
        log = self.get_logger()
        if self._collision_in_gesture or self.collisions.in_collision:
            self._collision_in_gesture = False
            self.outcomes['collision'] += 1   # an impact is never a gesture
            log.debug(f'no command: a collision during {gesture!r}')
            return
        reason = screen_gesture(gesture, self.min_extent_mm)
        if reason is not None:
            self.outcomes[reason] += 1
            log.debug(f'no command: {reason} ({gesture!r}, {gesture_extent_mm(gesture):.1f} mm across)')
            return
        match = self.recogniser.predict(gesture)
        self.last_match = match
        if match.rejected is not None:
            self.outcomes[f'rejected_{match.rejected}'] += 1
            log.debug(f'no command: rejected ({match.rejected}); nearest {match.nearest} at distance '
                      f'{match.distance:.3f}, margin {match.margin:.3f}, threshold '
                      f'{self._threshold(match.nearest):.3f}')
            return
        stamp = _time_msg(self.stream.end_stamp_ns(gesture))
        msg = haptic_command(match, gesture, self.commands, self.recogniser_name, stamp)
        if msg is None:
            self.outcomes['unmapped'] += 1
            log.debug(f"no command: gesture '{match.label}' has none in the command map")
            return
        self.outcomes['published'] += 1
        log.debug(f"command '{msg.command}' from '{match.label}' (distance {match.distance:.3f}, margin "
                  f'{match.margin:.3f})')
        self.command_pub.publish(msg)

    def _threshold(self, name: str | None) -> float:
        classes = [str(c) for c in self.recogniser.classes_]
        return float(self.recogniser.class_thresholds_[classes.index(name)]) if name in classes else math.nan


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch haptic_commands`` / the ``haptic_commands`` console script."""
    return run_node(HapticCommandsNode, args)
