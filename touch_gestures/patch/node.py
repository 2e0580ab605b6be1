"""``patch_gestures``: the textile patch's gesture recogniser on the graph (sympartner2018 6.2).

Subscribes to ``frame`` (``PatchFrame`` from ``patch_driver``) and per frame computes the window
features (:class:`~.features.WindowFeatures`), every class's log posterior from the stored mixtures,
and the event rule (:class:`~.classifier.EventDetector`). Publishes ``posteriors``
(``GesturePosteriors``, every frame) and ``/touch/gesture`` (``GestureEvent``: the frame's header,
the class, all posteriors, ``latency_s`` = this stamp minus the stamp of the window's first frame
with contact) when a class's posterior reaches the threshold and differs from the current class.

Parameters (read once at start, except ``threshold``, ``dwell_s`` and ``release``, which a parameter
set applies at once):

- ``model``: the ``.npz`` model file (default ``config/patch_gestures.npz``, SYNTHETIC:
  ``config/patch_gestures.md``); a missing or incompatible file stops the node at start;
- ``threshold``, ``dwell_s``, ``release``: the event rule, defaults from the model file (the old
  name ``hold_s`` is still read, with a WARN saying to rename it);
- ``window``: frames; only the model's value is accepted (another one says to retrain);
- ``max_gap_s``: frames further apart than this (s of header time) start a new window.

Bad input never stops the node: frames of the wrong size are counted in
:attr:`PatchGesturesNode.skipped`; NaN or infinite cells read as 0 and are counted in
``nonfinite_cells``; a stamp earlier than the previous one starts afresh; frames of another
publisher are screened out (:attr:`PatchGesturesNode.screen`) and reported on ``/diagnostics``.
``threshold`` and ``dwell_s`` carry descriptor ranges (:attr:`PatchGesturesNode.SAFETY_RANGES`);
every change after start is logged at WARN and counted.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from touch_graph.compat import (
    FloatingPointRange,
    Node,
    Parameter,
    ParameterDescriptor,
    SetParametersResult,
    get_message,
    sensor_data_qos,
)
from touch_graph.errors import ParameterError
from touch_graph.node_health import NodeHealth
from touch_graph.node_main import run_node
from touch_graph.paths import share_file

from ..model_card import card_log_line
from .classifier import EventDetector
from .model_io import ModelFileError, PatchModel, load_model

__all__ = ['DEFAULT_MODEL', 'PatchGesturesNode', 'default_model_path', 'main']

PatchFrame = get_message('social_touch_msgs/msg/PatchFrame')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
GesturePosteriors = get_message('social_touch_msgs/msg/GesturePosteriors')

#: The shipped model, relative to the package's share directory (see config/patch_gestures.md).
DEFAULT_MODEL = ('config', 'patch_gestures.npz')
#: How the shipped model is made (also in its metadata).
TRAIN_COMMAND = ('social-touch train patch --simulate 8 --seed 2026 --components 3 '
                 '--output config/patch_gestures.npz')
#: The patch's activation map, rows x cols (``PatchFrame.activation`` is float32[256], row-major).
PATCH_GRID = (16, 16)
_NS = 1_000_000_000
#: A measured frame rate this far from the model's (as a fraction) gets one warning.
RATE_TOLERANCE = 0.2


def default_model_path() -> Path:
    """The package's trained patch gesture model."""
    return share_file(*DEFAULT_MODEL)


class PatchGesturesNode(Node):
    """Gesture events of the textile patch from its driver's frames.

    Attributes:
        model: the loaded :class:`~.model_io.PatchModel`.
        features: the :class:`~.features.WindowFeatures` (its ``nonfinite_cells`` counts NaN/inf cells).
        detector: the :class:`~.classifier.EventDetector` (threshold, dwell, release in effect).
        frames: frames processed. events: GestureEvents published.
        skipped: reason -> frames skipped for it. resets: windows started afresh (time went back or a gap).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('patch_gestures', **kwargs)
        self.model = self._load_model()
        self._configure_event_rule()
        self.features = self.model.features()
        self.classifier = self.model.classifier
        self._classes = list(self.model.classes)
        self._n_cells = self.model.grid[0] * self.model.grid[1]
        # Stamps of the frames in the window, newest last: latency from the first contact frame.
        self._stamps: deque[int] = deque(maxlen=self.model.window)
        self._last_ns: int | None = None
        self._rate_checked = False
        self.frames = 0
        self.events = 0
        self.resets = 0
        self.skipped: Counter[str] = Counter()
        self.gesture_pub = self.create_publisher(GestureEvent, '/touch/gesture', 20)
        self.posteriors_pub = self.create_publisher(GesturePosteriors, 'posteriors', 20)
        # Frames lost when this node falls behind, and callbacks that raised: its log and /diagnostics.
        self.health = NodeHealth(self)
        self.create_subscription(PatchFrame, 'frame', self.health.guard(self._on_frame, 'frame'), sensor_data_qos(20))
        self.drops = self.health.drops
        self.screen = self.health.screen(self.resolve_topic_name('frame'))
        det = self.detector
        meta = self.model.metadata
        origin = ('SYNTHETIC data (simulated people)' if self.model.synthetic else
                  'recorded data' if 'synthetic' in meta else 'data the file does not describe')
        self.get_logger().info(
            f'{self.model_path}: {", ".join(self._classes)} from {origin}; window {self.model.window} frames '
            f'at {self.model.rate_hz:g} Hz, threshold {det.threshold:g}, dwell {det.dwell} frames, release '
            f'{det.release:g}')
        self.get_logger().info(card_log_line(self.model_path))

    # ------------------------------------------------------------------ parameters
    #: Parameters applied at once when set: the event rule. The others are read at start (read-only).
    LIVE_PARAMETERS = ('threshold', 'dwell_s', 'release')
    #: Renamed parameters, old name -> new: the old one is declared (read-only) so that parameter
    #: files written before the rename still work; a value given for it is used, with a WARN.
    RENAMED_PARAMETERS: ClassVar[dict[str, str]] = {'hold_s': 'dwell_s'}

    #: (low, high, why) of the parameters that switch event detection off when pushed far enough: their
    #: descriptors' ranges, refused outside as rclpy refuses (at start and on ``param set``).
    SAFETY_RANGES: ClassVar[dict[str, tuple[float, float, str]]] = {
        'threshold': (0.5, 1.0, 'below 0.5 two classes can pass at once; the paper uses 0.99'),
        'dwell_s': (0.0, 3.0, 'a longer dwell outlasts the 3 s window of sympartner2018 6.2'),
    }

    def _param(self, name: str, default: Any, description: str) -> Any:
        descriptor = ParameterDescriptor(description=description, read_only=name not in self.LIVE_PARAMETERS)
        if name in self.SAFETY_RANGES:
            low, high, why = self.SAFETY_RANGES[name]
            descriptor.additional_constraints = f'in [{low}, {high}]: {why}'
            descriptor.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
        return self.declare_parameter(name, default, descriptor).value

    def _bad(self, name: str, value: Any, expected: str) -> ParameterError:
        return ParameterError(f"parameter '{name}' of {self.get_fully_qualified_name()} must be {expected}; "
                              f'got {value!r}')

    def _load_model(self) -> PatchModel:
        given = self._param('model', '', 'patch gesture model .npz (default: the package\'s '
                                         'config/patch_gestures.npz, trained on simulated people)')
        self.model_path = Path(given) if given else default_model_path()
        try:
            return load_model(self.model_path, grid=PATCH_GRID)
        except ModelFileError as err:
            if not given:   # the package's own file: say how it is made
                how = f'; it is the package default, made with `{TRAIN_COMMAND}`; or set model:=FILE'
            elif not self.model_path.exists():
                how = f' (relative paths start at {Path.cwd()})'
            else:
                how = ''
            raise ParameterError(f"parameter 'model' of {self.get_fully_qualified_name()}: {err}{how}") from err

    def _configure_event_rule(self) -> None:
        m = self.model
        window = self._param('window', m.window, 'window length, frames; fixed by the model (sympartner2018 6.2: '
                                                 '3 s = 60 frames at 20 Hz)')
        if window != m.window:
            raise ParameterError(
                f"parameter 'window' of {self.get_fully_qualified_name()} is {window} frames, but {self.model_path} "
                f'was trained on {m.window}-frame windows ({m.window / m.rate_hz:g} s at {m.rate_hz:g} Hz); the '
                'features of another window length follow other distributions. Leave window unset, or retrain: '
                f'social-touch train patch ... --window-s {window / m.rate_hz:g}')
        threshold = self._param('threshold', float(m.classifier.threshold),
                                'posterior a class must reach for an event (sympartner2018 6.3: 0.99); default '
                                'from the model file')
        default_dwell_s = m.dwell / m.rate_hz
        dwell_s = self._param('dwell_s', default_dwell_s, 'time the class must stay above the threshold before '
                                                          'the event, s (one frame = the paper rule); default '
                                                          'from the model file')
        dwell_s = self._renamed('hold_s', dwell_s, default_dwell_s)
        release = self._param('release', float(min(m.release, threshold)),
                              'posterior below which the current class is forgotten; default from the model file')
        self.detector = self._event_detector(threshold, dwell_s, release)
        max_gap_s = self._param('max_gap_s', m.window / m.rate_hz,
                                'frames further apart than this (s) start a new window (default: the window length)')
        if not (max_gap_s > 0 and math.isfinite(max_gap_s)):
            raise self._bad('max_gap_s', max_gap_s, 'a positive number of seconds')
        self.max_gap_ns = round(max_gap_s * _NS)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _renamed(self, old: str, value: Any, default: Any) -> Any:
        """The value to use for the parameter ``old`` was renamed to: ``value``, or ``old``'s when only ``old``
        was given (the new parameter then reports it too; a new value equal to its default counts as not
        given, since parameters cannot tell). Either way a given ``old`` is WARNed about."""
        new = self.RENAMED_PARAMETERS[old]
        given = self._param(old, math.nan, f'deprecated: renamed {new}; read at start when {new} is not given')
        if isinstance(given, float) and math.isnan(given):
            return value
        if value != default:
            self.get_logger().warning(f"parameter '{old}' is deprecated and ignored, since '{new}' is given: "
                                      f"remove '{old}'")
            return value
        self.get_logger().warning(f"parameter '{old}' is deprecated: rename it '{new}' (using {old} = {given!r})")
        self.set_parameters([Parameter(new, value=given)])
        return given

    def _event_detector(self, threshold: float, dwell_s: float, release: float) -> EventDetector:
        """The event rule for these values; ParameterError says which one is wrong."""
        m = self.model
        if not (0.0 < threshold <= 1.0):
            raise self._bad('threshold', threshold, 'a posterior in (0, 1] (the paper uses 0.99)')
        if not (dwell_s >= 0 and math.isfinite(dwell_s)):
            raise self._bad('dwell_s', dwell_s, f'a number of seconds >= 0 (one frame is {1 / m.rate_hz:g} s)')
        if not (0.0 <= release <= threshold):
            raise self._bad('release', release, f'in [0, threshold = {threshold:g}]')
        dwell = max(1, round(dwell_s * m.rate_hz))
        return EventDetector(m.classes, threshold=threshold, release=release, rate_hz=m.rate_hz, dwell=dwell)

    def _on_set_parameters(self, params: list[Any]) -> Any:
        """A new threshold, dwell or release applies from the next frame; the class being reported is kept (no
        second event for it), the dwell count starts again."""
        values = {name: self.get_parameter(name).value for name in self.LIVE_PARAMETERS}
        values.update({p.name: p.value for p in params if p.name in values})
        if values == {name: self.get_parameter(name).value for name in self.LIVE_PARAMETERS}:
            return SetParametersResult(successful=True)
        try:
            detector = self._event_detector(values['threshold'], values['dwell_s'], values['release'])
        except ParameterError as err:
            return SetParametersResult(successful=False, reason=str(err))
        old = self.detector
        detector.current, detector.frame, detector.events = old.current, old.frame, old.events
        self.detector = detector
        self.get_logger().info(f'event rule now: threshold {detector.threshold:g}, dwell {detector.dwell} frames, '
                               f'release {detector.release:g}')
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ frames
    def _skip(self, reason: str, detail: str) -> None:
        self.skipped[reason] += 1
        self.get_logger().warning(f'skipped a frame: {detail} ({sum(self.skipped.values())} skipped so far)',
                                  throttle_duration_sec=5.0)

    def _restart(self, why: str) -> None:
        self.get_logger().warning(f'{why}: starting a new window')
        self.features.reset()
        self.detector.reset()
        self._stamps.clear()
        self._rate_checked = False
        self.resets += 1

    def _on_frame(self, msg: Any) -> None:
        activation = msg.activation
        if len(activation) != self._n_cells:
            rows, cols = self.model.grid
            self._skip('wrong_size', f'activation has {len(activation)} cells; the model is for {rows}x{cols} = '
                                     f'{self._n_cells} (is the driver configured for another sensor?)')
            self.screen.malformed('wrong_size')
            return
        for frame in self.screen.admit(msg):   # another publisher's frames on the topic are screened out
            self._on_own_frame(frame)

    def _on_own_frame(self, msg: Any) -> None:
        activation = msg.activation
        stamp_ns = msg.header.stamp.sec * _NS + msg.header.stamp.nanosec
        last = self._last_ns
        if last is not None:
            if stamp_ns < last:
                self._restart(f'time went back by {(last - stamp_ns) / _NS:.3f} s (a looped bag or a restarted '
                              'clock?)')
            elif stamp_ns - last > self.max_gap_ns:
                self._restart(f'no frame for {(stamp_ns - last) / _NS:.2f} s')
        self._last_ns = stamp_ns
        self.frames += 1
        features = self.features
        x = features.update(activation)        # NaN/inf cells read as 0 and are counted there
        self._stamps.append(stamp_ns)
        if not self._rate_checked and len(self._stamps) == self._stamps.maxlen:
            self._check_rate()
        age = features.onset_age
        log_posterior = self.classifier.log_posterior(x)
        self.posteriors_pub.publish(GesturePosteriors(header=msg.header, classes=self._classes,
                                                      posteriors=np.exp(log_posterior)))
        hit = self.detector.update(log_posterior, age, stamp_ns / _NS)
        if hit is None:
            return
        latency_s = (stamp_ns - self._stamps[-1 - age]) / _NS
        self.events += 1
        self.gesture_pub.publish(GestureEvent(
            header=msg.header, gesture=hit.gesture, probability=hit.probability, classes=self._classes,
            posteriors=np.asarray(hit.posteriors, dtype=np.float64), latency_s=latency_s))

    @property
    def nonfinite_cells(self) -> int:
        """NaN or infinite activation cells seen (read as 0, no contact)."""
        return self.features.nonfinite_cells

    def _check_rate(self) -> None:
        """Warn once when frames come at another rate than the model's: its window then spans another time."""
        self._rate_checked = True
        span_s = (self._stamps[-1] - self._stamps[0]) / _NS
        if span_s <= 0:
            return
        rate = (len(self._stamps) - 1) / span_s
        if abs(rate / self.model.rate_hz - 1.0) > RATE_TOLERANCE:
            self.get_logger().warning(
                f'frames arrive at {rate:.1f} Hz; {self.model_path.name} was trained at {self.model.rate_hz:g} Hz, so '
                f'its {self.model.window}-frame window spans {self.model.window / rate:.1f} s instead of '
                f'{self.model.window / self.model.rate_hz:g} s and its posteriors are off. Set the driver to '
                f'{self.model.rate_hz:g} Hz or train a model at this rate', once=True)


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch patch_gestures`` / the ``patch_gestures`` console script."""
    return run_node(PatchGesturesNode, args)
