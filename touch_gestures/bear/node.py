"""``bear_gestures``: the Sensate Bear's recognisers on the graph (knight2009 V.C-V.E, Fig. 5).

Subscribes to ``frame`` (``BearFrame`` from ``bear_driver``) and wraps
:class:`~.pipeline.BearRecogniser`:

- ``/touch/sensor_level`` (``SensorLevel``): the active sensors, every cycle (V.C);
- ``/touch/subtype`` (``TouchSubtype``): a sensor's subtype changed, with its buffer features (V.D);
- ``/touch/symbolic`` (``SymbolicGesture``): CANDIDATE, WITHDRAWN, START, END (V.E, :mod:`.symbolic`).

Time is the frame's header stamp. Faulty and unfitted channels read as untouched. A frame with
levels NaN or outside [0, 1], wrong array sizes or a stamp not after the previous one is counted in
:attr:`BearGesturesNode.skipped`. When time jumps back or no frame arrives for ``max_gap_s``, the
node ends what is under way and starts afresh. Frames of another publisher are screened out
(:attr:`BearGesturesNode.screen`) and reported on ``/diagnostics``.

With ``publish_symbolic: false`` the gesture file is not read; with ``publish_subtypes: false`` as
well, or when no gesture needs a subtype, no features are computed and no classifier runs.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_driver.bear.protocol import REAL_RATE_HZ
from touch_graph.compat import Node, ParameterDescriptor, get_message, sensor_data_qos
from touch_graph.errors import ParameterError
from touch_graph.node_health import NodeHealth
from touch_graph.node_main import run_node
from touch_graph.paths import share_file
from touch_graph.yamlconf import did_you_mean

from ..model_card import card_log_line
from .features import MIN_COMPONENT
from .gate import NoTouchGate
from .pipeline import BearRecogniser
from .sensor_level import ACTIVATION_THRESHOLD, BUFFER_LEN, N_CHANNELS
from .subtype import PaperRuleClassifier, SubtypePredictor
from .subtype_model import SubtypeModel
from .symbolic import END, WITHDRAWN, GestureLibrary

__all__ = ['DEFAULT_MODEL', 'BearGesturesNode', 'main']

BearFrame = get_message('social_touch_msgs/msg/BearFrame')
SensorLevel = get_message('social_touch_msgs/msg/SensorLevel')
SensorState = get_message('social_touch_msgs/msg/SensorState')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TimeMsg = get_message('builtin_interfaces/msg/Time')
Point = get_message('geometry_msgs/msg/Point')
_NO_POSITION = (math.nan, math.nan, math.nan)

#: The shipped subtype model, relative to the package's share directory (see config/bear_subtype_model.md).
DEFAULT_MODEL = ('config', 'bear_subtype_model.npz')
CLASSIFIERS = ('model', 'rule')
_NS = 1_000_000_000
#: Frames after a (re)start over which the arrival rate is compared with ``rate_hz`` once.
RATE_CHECK_FRAMES = 20
#: The paper rule's constants, from :class:`PaperRuleClassifier` (knight2009 V.D); ``amplitude_threshold``
#: is the node's ``threshold``.
_RULE_DEFAULTS = {k: v for k, v in PaperRuleClassifier().get_params().items()
                  if k not in ('amplitude_threshold', 'tune_cutoffs')}


def default_model_path() -> Path:
    """The package's trained subtype model (may be missing in a stripped install)."""
    return share_file(*DEFAULT_MODEL)


def _time_msg(ns: int) -> Any:
    sec, nanosec = divmod(int(ns), _NS)
    return TimeMsg(sec=sec, nanosec=nanosec)


class BearGesturesNode(Node):
    """Sensor level, touch subtypes and symbolic gestures of the bear, from its driver's frames.

    Attributes:
        recogniser: the wrapped :class:`BearRecogniser`.
        frames: frames processed.
        skipped: reason -> frames skipped for it.
        resets: times the recogniser was started afresh (time went back, or frames stopped).
        classifier_kind: ``'model'`` or ``'rule'``, what actually classifies subtypes (None: nothing does).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('bear_gestures', **kwargs)
        self.classifier_kind: str | None = None
        self.loaded_files: list[str] = []       # config files read, for the start-up log line
        p = self._declare()
        self.publish_subtypes = p['publish_subtypes']
        self.publish_symbolic = p['publish_symbolic']
        self.max_gap_ns = round(p['max_gap_s'] * _NS)
        self.recogniser = self._build_recogniser(p)
        body = self.recogniser.body_map
        self._names = {s.channel: s.name for s in body.sensors}
        self._channels = {s.name: s.channel for s in body.sensors}
        self._positions = {s.channel: Point(**dict(zip('xyz', s.position or _NO_POSITION, strict=True)))
                           for s in body.sensors}
        self._levels = np.zeros(N_CHANNELS, dtype=np.float32)  # this cycle's levels, for the centroids
        self.frames = 0
        self.skipped: Counter[str] = Counter()
        self.resets = 0
        self._t0_ns: int | None = None        # stamp of the first frame since the last reset
        self._last_ns: int | None = None      # stamp of the latest frame
        self._last_header: Any = None
        self._last_receipt_ns = 0             # node clock when the latest frame arrived
        self._fitted_warned = False
        self._rate_checked = False

        self.level_pub = self.create_publisher(SensorLevel, '/touch/sensor_level', 10)
        self.subtype_pub = self.create_publisher(TouchSubtype, '/touch/subtype', 50) if self.publish_subtypes else None
        self.symbolic_pub = (self.create_publisher(SymbolicGesture, '/touch/symbolic', 20)
                             if self.publish_symbolic else None)
        # Frames lost when this node falls behind, and callbacks that raised: its log and /diagnostics.
        self.health = NodeHealth(self)
        self.create_subscription(BearFrame, 'frame', self.health.guard(self._on_frame, 'frame'), sensor_data_qos(10))
        self.drops = self.health.drops
        self.screen = self.health.screen(self.resolve_topic_name('frame'))
        self.create_timer(p['max_gap_s'] / 2, self._watchdog)   # ends things within 1.5 max_gap_s
        outputs = (('subtypes', self.publish_subtypes), ('symbolic gestures', self.publish_symbolic))
        what = [name for name, on in outputs if on]
        self.get_logger().info(
            f'{self.recogniser.rate_hz:g} Hz, buffer {self.recogniser.buffer.buffer_len} cycles, threshold '
            f'{self.recogniser.threshold:g}; sensor level{"".join(", " + w for w in what)}'
            f'{"; subtypes by the " + self.classifier_kind if self.classifier_kind else ""}')
        self.get_logger().info('loaded ' + ', '.join(self.loaded_files))

    # ------------------------------------------------------------------ parameters
    def _param(self, name: str, default: Any, description: str) -> Any:
        # Read-only: no process in the domain can change them after start (docs/network.md).
        return self.declare_parameter(name, default, ParameterDescriptor(description=description,
                                                                         read_only=True)).value

    def _declare(self) -> dict[str, Any]:
        """Declare every parameter and check the values; ParameterError says which, what and how to fix."""
        p = {
            'rate_hz': self._param('rate_hz', REAL_RATE_HZ, 'scan rate of the bear, cycles/s: 3.4 real (knight2009 '
                                                        'VI.B), 25 ideal (IV.D); must match the driver'),
            'buffer_len': self._param('buffer_len', BUFFER_LEN, 'cycles per sensor buffer (knight2009 V.A: 20)'),
            'threshold': self._param('threshold', ACTIVATION_THRESHOLD,
                                     'activation threshold on the level 0..1 (knight2009 V.A: 0.3)'),
            'detrend': self._param('detrend', 'constant', "feature detrending before the FFT: 'constant' or 'linear'"),
            'min_component': self._param('min_component', MIN_COMPONENT,
                                         'smallest sinusoid amplitude (level units) that counts as a frequency'),
            'gestures': self._param('gestures', '', 'symbolic gesture YAML (default: config/bear_gestures.yaml)'),
            'body_map': self._param('body_map', '', 'body map YAML (default: config/bear_body.yaml)'),
            'subtype_classifier': self._param('subtype_classifier', 'model',
                                              "'model' (trained, Table I's eight subtypes) or 'rule' (knight2009 V.D)"),
            'subtype_model': self._param('subtype_model', '',
                                         'trained model .npz (default: config/bear_subtype_model.npz; when that '
                                         'is missing the rule is used, with a warning)'),
            'publish_subtypes': self._param('publish_subtypes', True, 'publish /touch/subtype'),
            'publish_symbolic': self._param('publish_symbolic', True,
                                            'publish /touch/symbolic (false: no symbolic work at all)'),
            'dwell_s': self._param('dwell_s', -1.0, 'dwell for gestures without their own; < 0: the gesture '
                                                    "file's default (2 s, knight2009 V.E)"),
            'gap_s': self._param('gap_s', -1.0, "tolerated dropout for gestures without their own; < 0: the file's"),
            'lift_s': self._param('lift_s', -1.0, 'seconds a lift before START may last without restarting the '
                                                  "dwell, for gestures without their own; < 0: the file's default"),
            'max_gap_s': self._param('max_gap_s', 5.0, 'no frame for this long (s): end what is under way, start '
                                                       'afresh'),
        }
        for key, default in _RULE_DEFAULTS.items():
            p[f'rule.{key}'] = self._param(f'rule.{key}', float(default),
                                           f'paper rule constant {key} (knight2009 V.D; see PaperRuleClassifier)')
        fqn = self.get_fully_qualified_name()

        def bad(name: str, expected: str, fix: str = '') -> ParameterError:
            return ParameterError(f"parameter '{name}' of {fqn} must be {expected}; got {p[name]!r}{fix}")

        if not (p['rate_hz'] > 0 and math.isfinite(p['rate_hz'])):
            raise bad('rate_hz', 'a positive number of scans per second (3.4 for the real bear)')
        if p['buffer_len'] < 2:
            raise bad('buffer_len', 'an integer >= 2 cycles (the paper uses 20)')
        if not 0.0 < p['threshold'] <= 1.0:
            raise bad('threshold', 'in (0, 1], a level fraction (the paper uses 0.3)')
        if p['detrend'] not in ('constant', 'linear'):
            raise bad('detrend', "'constant' or 'linear'")
        if not 0.0 <= p['min_component'] < 1.0:
            raise bad('min_component', 'in [0, 1), level units')
        if p['subtype_classifier'] not in CLASSIFIERS:
            raise bad('subtype_classifier', "'model' or 'rule'", did_you_mean(p['subtype_classifier'], CLASSIFIERS))
        for name in ('dwell_s', 'gap_s', 'lift_s'):
            if not math.isfinite(p[name]):
                raise bad(name, 'a number of seconds (< 0: keep the gesture file\'s default)')
        if not (p['max_gap_s'] > 0 and math.isfinite(p['max_gap_s'])):
            raise bad('max_gap_s', 'a positive number of seconds')
        for key in _RULE_DEFAULTS:
            if not math.isfinite(p[f'rule.{key}']) or p[f'rule.{key}'] < 0:
                raise bad(f'rule.{key}', 'a finite number >= 0')
        for name in ('gestures', 'body_map', 'subtype_model'):
            if p[name] and not Path(p[name]).is_file():
                raise bad(name, 'the path of an existing file (or empty for the package default)',
                          f'; no such file (relative paths start at {Path.cwd()})')
        return p

    def _build_recogniser(self, p: dict[str, Any]) -> BearRecogniser:
        body_map = BodyMap.load(p['body_map']) if p['body_map'] else BodyMap.default()
        self.loaded_files.append(f'body map {body_map.source}')
        if p['publish_symbolic']:
            library = GestureLibrary.load(p['gestures'], body_map) if p['gestures'] else \
                GestureLibrary.default(body_map)
            self.loaded_files.append(f'gestures {library.source}')
            library = _with_default_timing(library, p['dwell_s'], p['gap_s'], p['lift_s'])
        else:
            library = GestureLibrary([], source='(publish_symbolic is false)')
        need_classifier = p['publish_subtypes'] or (p['publish_symbolic'] and any(g.subtypes for g in
                                                                                   library.detectable))
        classifier = self._classifier(p) if need_classifier else None
        return BearRecogniser(p['rate_hz'], p['buffer_len'], p['threshold'], classifier=classifier, library=library,
                              body_map=body_map, detrend=p['detrend'], min_component=p['min_component'],
                              subtypes=p['publish_subtypes'], symbolic=p['publish_symbolic'], classify=need_classifier)

    def _classifier(self, p: dict[str, Any]) -> SubtypePredictor:
        rule = PaperRuleClassifier(amplitude_threshold=p['threshold'],
                                   **{k: p[f'rule.{k}'] for k in _RULE_DEFAULTS})
        self.classifier_kind = 'rule'
        if p['subtype_classifier'] == 'rule':
            return rule
        explicit = bool(p['subtype_model'])
        path = Path(p['subtype_model']) if explicit else default_model_path()
        if not path.is_file():
            self.get_logger().warning(f'no trained subtype model at {path}; using the paper rule (knight2009 V.D) '
                                      'instead. Train one: social-touch train bear --out '
                                      'config/bear_subtype_model.npz')
            return rule
        fqn = self.get_fully_qualified_name()
        try:
            model = SubtypeModel.load(path)
        except (ValueError, OSError) as err:
            raise ParameterError(f"parameter 'subtype_model' of {fqn}: cannot load {path}: {err}") from err
        trained = (model.trained_rate_hz_, model.trained_buffer_len_)
        if (trained[0] is not None and not math.isclose(trained[0], p['rate_hz'], rel_tol=1e-6)) or \
                (trained[1] is not None and trained[1] != p['buffer_len']):
            problem = (f'{path} was trained at {trained[0]} Hz with a {trained[1]}-cycle buffer; this node runs at '
                       f"{p['rate_hz']} Hz with {p['buffer_len']} cycles (its features differ)")
            if explicit:
                raise ParameterError(f"parameter 'subtype_model' of {fqn}: {problem}; retrain: python -m "
                                     f"touch_lab.bear.train --rate {p['rate_hz']} --buffer {p['buffer_len']} "
                                     '--out FILE')
            self.get_logger().warning(f'{problem}; using the paper rule (knight2009 V.D) instead')
            return rule
        self.classifier_kind = 'model'
        self.loaded_files.append(f'subtype model {path}')
        self.get_logger().info(card_log_line(path))
        return NoTouchGate(model, p['threshold'])    # no false taps from the short buffers of a (re)start

    # ------------------------------------------------------------------ frames
    def _skip(self, reason: str, detail: str) -> None:
        self.skipped[reason] += 1
        if reason != 'repeated_stamp':   # a repeat passed the screen: it is the driver's
            self.screen.malformed(reason)
        self.get_logger().warning(f'skipped a frame: {detail} ({sum(self.skipped.values())} skipped so far)',
                                  throttle_duration_sec=5.0)

    def _on_frame(self, msg: Any) -> None:
        levels = np.asarray(msg.level, dtype=np.float32)
        faults = np.asarray(msg.faults)
        fitted = np.asarray(msg.fitted, dtype=bool)
        shapes = (levels.shape, faults.shape, fitted.shape)
        if any(shape != (N_CHANNELS,) for shape in shapes):
            self._skip('wrong_size', f'level, faults and fitted must hold {N_CHANNELS} values each; got shapes '
                                     f'{list(shapes)}')
            return
        if not np.isfinite(levels).all():
            self._skip('non_finite', f'{int((~np.isfinite(levels)).sum())} NaN/inf levels (a calibrated frame '
                                     'never has any)')
            return
        if (levels < 0.0).any() or (levels > 1.0).any():
            # The driver clips levels to [0, 1] (its calibrated range); anything else is not a reading.
            self._skip('out_of_range', f'{int(((levels < 0) | (levels > 1)).sum())} levels outside [0, 1] '
                                       f'(max {float(levels.max()):.3g}; a calibrated level is in [0, 1])')
            return
        for frame in self.screen.admit(msg):   # another publisher's frames on the topic are screened out
            self._on_own_frame(frame)

    def _on_own_frame(self, msg: Any) -> None:
        levels = np.asarray(msg.level, dtype=np.float32)
        faults = np.asarray(msg.faults)
        fitted = np.asarray(msg.fitted, dtype=bool)
        stamp_ns = msg.header.stamp.sec * _NS + msg.header.stamp.nanosec
        if self._last_ns is not None:
            if stamp_ns == self._last_ns:
                self._skip('repeated_stamp', f'stamp {stamp_ns * 1e-9:.3f} s repeats the previous frame\'s')
                return
            if stamp_ns < self._last_ns:
                self.get_logger().warning(f'time went back by {(self._last_ns - stamp_ns) * 1e-9:.3f} s (a looped '
                                          'bag or a restarted clock?): starting afresh')
                self._restart()
            elif stamp_ns - self._last_ns > self.max_gap_ns:
                self.get_logger().warning(f'no frame for {(stamp_ns - self._last_ns) * 1e-9:.1f} s: starting afresh')
                self._restart()
        if self._t0_ns is None:
            self._t0_ns = stamp_ns
        self._last_ns = stamp_ns
        self._last_header = msg.header
        self._last_receipt_ns = self.get_clock().now().nanoseconds
        rec = self.recogniser
        if not self._fitted_warned and not np.array_equal(fitted, rec.fitted):
            self._fitted_warned = True
            self.get_logger().warning(f'the driver reports {int(fitted.sum())} fitted channels, this body map '
                                      f'{int(rec.fitted.sum())}: do driver and recogniser use the same body map? '
                                      'Channels either side calls unfitted are ignored')
        excluded = (faults != 0) | ~fitted
        if not self._rate_checked and rec.buffer.count == RATE_CHECK_FRAMES:
            self._check_rate(stamp_ns)
        self.frames += 1
        self._levels = np.where(excluded, np.float32(0.0), levels)
        self._recognise_and_publish((stamp_ns - self._t0_ns) / _NS, levels, excluded, msg.header)

    def _recognise_and_publish(self, t: float, levels: np.ndarray, excluded: np.ndarray, header: Any) -> None:
        out = self.recogniser.update(t, levels, excluded)      # only what the parameters ask for
        sensors, events = out.active_sensors, out.symbolic_events
        changes = [named.change for named in out.subtype_changes]
        positions = self._positions
        self.level_pub.publish(SensorLevel(header=header, sensors=[
            SensorState(channel=s.channel, name=s.name, location=s.location, region=s.region, level=s.level,
                        position=positions[s.channel])
            for s in sensors], **self._centroid([s.channel for s in sensors], weighted=True)))
        names = self._names
        for c in changes:
            f = c.features
            self.subtype_pub.publish(TouchSubtype(
                header=header, channel=c.channel, sensor=names[c.channel], subtype=c.subtype, previous=c.previous,
                confidence=c.confidence, peak_amplitude=float(f[0]), base_frequency_hz=float(f[1]),
                spectral_spread=float(f[2]), duration_s=float(f[3])))
        for e in events:
            self.symbolic_pub.publish(SymbolicGesture(
                header=header, gesture=e.gesture, state=e.state, onset=_time_msg(self._t0_ns + round(e.onset * _NS)),
                duration_s=e.duration_s, sensors=list(e.sensors), confidence=e.confidence, **self._centroid(
                    [self._channels[n] for n in e.sensors if n in self._channels], weighted=False)))

    def _centroid(self, channels: list[int], weighted: bool) -> dict[str, Any]:
        """The centroid fields of a SensorLevel or SymbolicGesture (see their .msg), from this cycle's levels.

        ``weighted``: by level only (a sensor level message names active sensors); otherwise by level,
        or unweighted when none of ``channels`` is touched now (a gesture that ended: where it was).
        """
        body = self.recogniser.body_map
        point = body.centroid(channels, self._levels[channels]) if channels else None
        if point is None and channels and not weighted:
            point = body.centroid(channels, np.ones(len(channels)))
        if point is None:
            return {'has_centroid': False, 'frame_id': body.frame_id}
        return {'has_centroid': True, 'centroid': Point(x=point[0], y=point[1], z=point[2]),
                'frame_id': body.frame_id}

    def _check_rate(self, stamp_ns: int) -> None:
        """Warn once when frames arrive at a rate far from ``rate_hz`` (the features assume it)."""
        self._rate_checked = True
        measured = RATE_CHECK_FRAMES / ((stamp_ns - self._t0_ns) / _NS)
        if not 0.7 < measured / self.recogniser.rate_hz < 1.0 / 0.7:
            self.get_logger().warning(f'frames arrive at {measured:.2f} Hz but rate_hz is {self.recogniser.rate_hz:g}: '
                                      'frequencies and durations will be wrong; set rate_hz to the driver\'s rate')

    # ------------------------------------------------------------------ endings
    def _restart(self) -> None:
        """End whatever is under way at the latest frame's time, then forget all history."""
        rec = self.recogniser
        header, last_ns = self._last_header, self._last_ns
        if header is not None and last_ns is not None and self._t0_ns is not None:
            t = (last_ns - self._t0_ns) / _NS
            if self.publish_symbolic:
                for name, onset in rec.symbolic.active_gestures().items():
                    self.symbolic_pub.publish(SymbolicGesture(
                        header=header, gesture=name, state=END, onset=_time_msg(self._t0_ns + round(onset * _NS)),
                        duration_s=t - onset, sensors=[], confidence=1.0, **self._centroid([], weighted=False)))
                for name, onset in rec.symbolic.announced_gestures().items():
                    self.symbolic_pub.publish(SymbolicGesture(
                        header=header, gesture=name, state=WITHDRAWN,
                        onset=_time_msg(self._t0_ns + round(onset * _NS)), duration_s=t - onset, sensors=[],
                        confidence=0.0, **self._centroid([], weighted=False)))
            if self.publish_subtypes:
                for channel, subtype in rec.tracker.labels().items():
                    self.subtype_pub.publish(TouchSubtype(header=header, channel=channel, sensor=self._names[channel],
                                                          subtype='none', previous=subtype, confidence=1.0))
        rec.reset()
        self.resets += 1
        self._t0_ns = self._last_ns = self._last_header = None

    def _watchdog(self) -> None:
        """Frames stopped (driver unplugged, bag ended): end what is under way once ``max_gap_s`` has passed."""
        if self._last_ns is None:
            return
        if self.get_clock().now().nanoseconds - self._last_receipt_ns > self.max_gap_ns:
            self.get_logger().warning(f'no frame for over {self.max_gap_ns / _NS:g} s: ending what was under way')
            self._restart()


def _with_default_timing(library: GestureLibrary, dwell_s: float, gap_s: float, lift_s: float) -> GestureLibrary:
    """``library`` with the default dwell / gap / lift replaced (values < 0 keep the file's)."""
    if gap_s >= 0:
        library = library.with_default_gap(gap_s)
    if lift_s >= 0:
        library = library.with_default_lift(lift_s)
    if dwell_s >= 0:
        gestures = [replace(g, dwell_s=dwell_s) if g.dwell_s == library.default_dwell_s else g
                    for g in library.gestures]
        library = GestureLibrary(gestures, library.source, dwell_s, library.default_gap_s, library.default_lift_s)
    return library


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch bear_gestures`` / the ``bear_gestures`` console script."""
    return run_node(BearGesturesNode, args)

