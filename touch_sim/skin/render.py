"""Skin stimuli and trace samples through the skin into :class:`TouchGesture` objects (synthetic sensor).

:func:`graph_gestures` plays a skin stimulus on the virtual skin read by the real ``skin_driver``
node in the :class:`~touch_sim.harness.Harness` (simulated time, deterministic) and cuts
``/skin/frame`` into gestures with the skin node's :class:`~touch_gestures.skin.frames.SkinFrameStream`.
Each gesture comes with its start and end in scene time (the stimulus's ``t``); a frame's stamp is
when the driver's poll timer read it.

A trace sample goes one of two ways, so the cost of the sensor is visible:

- ``'sensor'``: the virtual skin, ``skin_driver`` and the node's frame handling (:func:`graph_gestures`);
- ``'direct'``: the same placement and timing, the segmenter fed the true finger position at
  150 Hz and a perfect pressure map (:func:`~touch_gestures.skin.gesture.ideal_frame`).

A sample becomes a :class:`TraceStimulus` (its bounding box scaled onto the active area);
samples already in mm (``placement='mm'``) keep their size and position. :func:`render_samples`
caches its output in an ``.npz`` file (no pickle) keyed by the samples' content and the settings.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from touch_driver.skin.protocol import FRAME_RATE_HZ
from touch_gestures.skin.frames import SkinFrameStream
from touch_gestures.skin.gesture import GRID, TouchGesture, ideal_frame
from touch_gestures.skin.segmentation import GestureSegmenter
from touch_graph.files import replacing
from touch_sim.harness import DeviceRun, stamp_ns, wire_frames_before
from touch_sim.skin.traces import TraceSample, TraceStimulus, clock_tick, traced_strokes

__all__ = ['RenderSettings', 'RenderedSample', 'TimedGesture', 'default_cache_dir', 'graph_gestures', 'render_sample',
           'render_samples']

_NS = 1_000_000_000
_CACHE_VERSION = 6  # bump when the segmenter or the sensor path changes what a sample renders to


@dataclass(frozen=True)
class RenderSettings:
    """How samples are traced; part of the cache key.

    Attributes:
        mode: ``'sensor'`` or ``'direct'`` (module doc).
        placement: ``'fit'`` (bounding box onto the active area) or ``'mm'`` (x, y are mm already).
        force_n, radius_mm: the finger (TraceStimulus defaults: 1.5 N, 4 mm).
        seed: noise seed of the first sample; sample i uses ``seed + i``.
        gap_s, max_duration_s, min_frames: the segmenter's (see GestureSegmenter).
    """

    mode: str = 'sensor'
    placement: str = 'fit'
    force_n: float = 1.5
    radius_mm: float = 4.0
    seed: int = 0
    gap_s: float = 0.15
    max_duration_s: float = 10.0
    min_frames: int = 3

    def __post_init__(self) -> None:
        if self.mode not in ('sensor', 'direct'):
            raise ValueError(f"mode must be 'sensor' or 'direct', got {self.mode!r}")
        if self.placement not in ('fit', 'mm'):
            raise ValueError(f"placement must be 'fit' or 'mm', got {self.placement!r}")

    def segmenter(self) -> GestureSegmenter:
        return GestureSegmenter(gap_s=self.gap_s, max_duration_s=self.max_duration_s,
                                min_frames=self.min_frames)


@dataclass(eq=False)
class RenderedSample:
    """A sample's key and the gestures the segmenter cut from its frames (normally one)."""

    subject: str
    variant: str
    label: str
    sample: str
    gestures: list[TouchGesture]


def _stimulus(sample: TraceSample, settings: RenderSettings):

    if settings.placement == 'fit':
        return TraceStimulus.from_points(sample.x, sample.y, sample.t_ms, sample.stroke, force_n=settings.force_n,
                                         radius_mm=settings.radius_mm)
    lead = 0.55  # untouched skin first (the calibrator tares on it), then the touch-down ramp
    t = lead + (sample.t_ms - sample.t_ms.min()) / 1000.0
    strokes = traced_strokes(t, sample.x, sample.y, sample.stroke, clock_tick(sample.t_ms, sample.stroke) / 1000.0)
    return TraceStimulus(strokes, force_n=settings.force_n, radius_mm=settings.radius_mm)


@dataclass(frozen=True, slots=True)
class TimedGesture:
    """A gesture cut from ``/skin/frame`` with its first and last contact in scene time (s)."""

    start_s: float
    end_s: float
    gesture: TouchGesture


def graph_gestures(stimulus: Any, duration_s: float | None = None, seed: int = 0,
                   stream: SkinFrameStream | None = None, url_options: dict[str, str] | None = None,
                   driver_parameters: dict[str, Any] | None = None,
                   wire_frames: int | None = None) -> Iterator[TimedGesture]:
    """The gestures the skin graph cuts from ``stimulus`` over ``duration_s`` (default: its own; module doc).

    Args:
        stimulus: a skin stimulus (``contacts(t)``).
        duration_s: scene seconds: the frames of device time before it are read.
        seed: the virtual skin's seed (baselines, noise, repeatability).
        stream: frames -> gestures (default: a :class:`SkinFrameStream` with the default segmenter);
            its counters tell the bad frames afterwards.
        url_options: more ``skinsim://`` options (``noise``, ``dead``, ``garbage``...), strings.
        driver_parameters: ``skin_driver`` parameters (``calibration``, ``poll_rate_hz``...).
        wire_frames: read exactly this many frames instead (frames ``0 .. n-1``).

    Raises:
        ValueError: a bad duration, or the driver cannot open the virtual skin.
    """
    if duration_s is None:
        duration_s = float(getattr(stimulus, 'duration_s', math.nan))
    if not (duration_s >= 0 and math.isfinite(duration_s)):
        raise ValueError(f'duration_s must be a finite number of seconds >= 0 (the stimulus has none of its own?); '
                         f'got {duration_s}')
    stream = stream if stream is not None else SkinFrameStream()
    run = DeviceRun('skin', stimulus, seed=seed, url_options=url_options, driver_parameters=driver_parameters)
    origin_ns = 0   # the graph time of the driver's start, from the first frame: stamp - (stamp - start)

    def timed(g: TouchGesture) -> TimedGesture:
        start, end = stream.stamp_ns(g.start_s), stream.end_stamp_ns(g)
        return TimedGesture((start - origin_ns) / _NS, (end - origin_ns) / _NS, g)

    frames = wire_frames if wire_frames is not None else wire_frames_before(duration_s)
    for _, msg, t in run.messages(frames, [('/skin/frame', 'SkinFrame')], slice_s=5.0):
        origin_ns = stamp_ns(msg) - round(t * _NS)
        yield from (timed(g) for g in stream.update(msg))
    yield from (timed(g) for g in stream.flush())


def render_sample(sample: TraceSample, settings: RenderSettings = RenderSettings(), seed: int | None = None
                  ) -> list[TouchGesture]:
    """The gestures the segmenter cuts from one sample traced across the skin (module doc)."""

    stim = _stimulus(sample, settings)
    if settings.mode == 'direct':
        seg = settings.segmenter()
        out: list[TouchGesture] = []
        n = int(stim.duration_s * FRAME_RATE_HZ) + 1
        times = np.arange(n) / FRAME_RATE_HZ
        xy, down = stim.truth(times)
        empty = np.zeros((GRID, GRID), dtype=np.float32)
        for t, p, d in zip(times, xy, down, strict=True):
            out += seg.update(ideal_frame(p, settings.radius_mm) if d else empty, bool(d), p, t)
        return out + seg.flush()
    # Frames 0 .. floor(duration * 150): the untouched lead, the trace and the lift.
    n = math.floor(stim.duration_s * FRAME_RATE_HZ + 1e-9) + 1
    timed = graph_gestures(stim, seed=settings.seed if seed is None else seed,
                           stream=SkinFrameStream(settings.segmenter()), wire_frames=n)
    return [g.gesture for g in timed]


# ----------------------------------------------------------------------------- cache
_SCALARS = ('frames', 'start_s', 'duration_s', 'strokes', 'multi_contact', 'truncated')


def default_cache_dir() -> Path:
    return Path.home() / '.cache' / 'social_touch' / 'skin_eval'


def _cache_key(samples: Sequence[TraceSample], settings: RenderSettings) -> str:
    h = hashlib.sha256()
    seg = settings.segmenter()
    seg_params = {k: v for k, v in vars(seg).items() if not k.startswith('_') and k != 'stats'}
    h.update(json.dumps([_CACHE_VERSION, asdict(settings), seg_params], sort_keys=True).encode())
    for s in samples:
        h.update('\x1f'.join(s.key).encode())
        for arr in (s.x, s.y, s.t_ms, s.stroke):
            h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()[:24]


def _save(path: Path, rendered: list[RenderedSample]) -> None:
    gestures = [g for r in rendered for g in r.gestures]
    counts = np.array([len(r.gestures) for r in rendered], dtype=np.int64)
    lengths = np.array([len(g.trajectory) for g in gestures], dtype=np.int64)
    data = {
        'version': np.array(_CACHE_VERSION),
        'keys': np.array([[r.subject, r.variant, r.label, r.sample] for r in rendered], dtype=str).reshape(-1, 4),
        'counts': counts, 'lengths': lengths,
        'binary_map': np.array([g.binary_map for g in gestures], dtype=bool).reshape(-1, GRID, GRID),
        'peak_map': np.array([g.peak_map for g in gestures], dtype=np.float32).reshape(-1, GRID, GRID),
        'trajectory': np.concatenate([g.trajectory for g in gestures] or [np.zeros((0, 2), np.float32)]),
        'times': np.concatenate([g.times for g in gestures] or [np.zeros(0)]),
        'stroke': np.concatenate([g.stroke for g in gestures] or [np.zeros(0, np.int16)]),
    }
    for name in _SCALARS:
        data[name] = np.array([getattr(g, name) for g in gestures])
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:
        np.savez_compressed(tmp, **data)


def _load(path: Path) -> list[RenderedSample] | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            if int(z['version']) != _CACHE_VERSION:
                return None
            d = {k: z[k] for k in z.files}
    except (OSError, ValueError, KeyError):
        return None  # unreadable cache: render again
    ends = np.cumsum(d['lengths'])
    gestures = []
    for i, end in enumerate(ends):
        start = end - d['lengths'][i]
        gestures.append(TouchGesture(
            binary_map=d['binary_map'][i], peak_map=d['peak_map'][i], trajectory=d['trajectory'][start:end],
            times=d['times'][start:end], stroke=d['stroke'][start:end], frames=int(d['frames'][i]),
            start_s=float(d['start_s'][i]), duration_s=float(d['duration_s'][i]), strokes=int(d['strokes'][i]),
            multi_contact=bool(d['multi_contact'][i]), truncated=bool(d['truncated'][i])))
    out, k = [], 0
    for key, count in zip(d['keys'], d['counts'], strict=True):
        out.append(RenderedSample(*[str(v) for v in key], gestures=gestures[k:k + count]))
        k += count
    return out


def render_samples(samples: Sequence[TraceSample], settings: RenderSettings = RenderSettings(),
                   cache_dir: Path | str | None = None, progress: Callable[[int, int], None] | None = None
                   ) -> list[RenderedSample]:
    """Render every sample (sample i with noise seed ``settings.seed + i``), using the cache.

    Args:
        cache_dir: where to keep rendered gestures; None disables caching.
        progress: called as ``progress(done, total)`` now and then (e.g. to print on stderr).
    """
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f'{settings.mode}-{_cache_key(samples, settings)}.npz'
        cached = _load(path) if path.is_file() else None
        if cached is not None and len(cached) == len(samples):
            return cached
    out = []
    for i, s in enumerate(samples):
        try:
            gestures = render_sample(s, settings, seed=settings.seed + i)
        except ValueError as err:  # e.g. a sample whose times do not increase: say which and go on
            print(f'skin render: sample {s.key} skipped: {err}', file=sys.stderr)
            gestures = []
        out.append(RenderedSample(s.subject, s.variant, s.gesture, s.sample, gestures))
        if progress is not None and ((i + 1) % 50 == 0 or i + 1 == len(samples)):
            progress(i + 1, len(samples))
    if path is not None:
        _save(path, out)
    return out
