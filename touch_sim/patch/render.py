"""A patch stimulus as the robot perceives it: virtual patch -> ``patch_driver`` node -> ``/patch/frame`` (synthetic).

:func:`render_scene` plays a stimulus on a virtual patch (raw 100 Hz scans, id 0x51) read by the
real ``patch_driver`` node in the :class:`~touch_sim.harness.Harness` (simulated time,
deterministic) and gathers the 20 Hz activation maps from ``/patch/frame``, each with the panel
contact the driver publishes just before it (same header).

>>> from touch_sim.patch.people import make_people, simulate_session
>>> slap = simulate_session(make_people(1)[0], 'slap', n_events=1, seed=2, lead_s=(1.0, 1.0), pause_s=(4.0, 4.0))
>>> out = render_scene(slap, seed=4)
>>> out.activations.shape, out.panel_contact.shape, out.stats['checksum_errors']
((113, 16, 16), (113, 11), 0)
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from touch_driver.patch.protocol import GRID, N_PANELS
from touch_sim.harness import DeviceRun

__all__ = ['FRAME_RATE_HZ', 'GraphFrame', 'PatchFrames', 'Rendered', 'render_scene']

#: Frames to the PC, Hz (sympartner2018 6.1): what the driver publishes on /patch/frame.
FRAME_RATE_HZ = 20.0


@dataclass(frozen=True, slots=True)
class GraphFrame:
    """One ``/patch/frame`` message of the graph.

    Attributes:
        t: header stamp, s since the driver started (graph time).
        activation: (16, 16) float32 activation of eq. (2), unitless in [k, 1], 0 outside the outline.
        panel_contact: (11,) bool contact per capacitive panel at the scan that completed the frame.
    """

    t: float
    activation: np.ndarray
    panel_contact: np.ndarray


@dataclass
class Rendered:
    """The 20 Hz frames of a rendered scene.

    Attributes:
        activations: (T, 16, 16) float32 activation maps, unitless in [k, 1].
        panel_contact: (T, 11) bool panel contact per frame.
        stats: the driver's counters (frames, wire frames, dropped bytes, checksum errors, ...) and
            ``stamps_s``, the (T,) frame stamps.
    """

    activations: np.ndarray
    panel_contact: np.ndarray
    stats: dict


class PatchFrames:
    """Virtual patch -> ``patch_driver`` node -> ``/patch/frame`` and ``/patch/panels``, in simulated time.

    Args:
        stimulus: a ``PatchStimulus`` (``pressure(t)``, ``panels(t)``).
        seed: the device's seed (the URL's ``seed``): sensor constants and noise.
        url_options: more ``patchsim://`` options (``noise``, ``drift``, ``dead``, ``garbage``, ``mode``...;
            see ``touch_sim.urlhandlers.protocol_patchsim``), values as strings.
        driver_parameters: ``patch_driver`` parameters (``gain``, ``tau``, ``k``, ``poll_rate_hz``, ...).

    Attributes:
        counters: after :meth:`frames` has run: the driver's counters (see :class:`~touch_sim.harness.DeviceRun`).
    """

    def __init__(self, stimulus: Any, seed: int = 0, url_options: dict[str, str] | None = None,
                 driver_parameters: dict[str, Any] | None = None) -> None:
        if not (callable(getattr(stimulus, 'pressure', None)) and callable(getattr(stimulus, 'panels', None))):
            raise TypeError(f'stimulus must have pressure(t) and panels(t); got {type(stimulus).__name__}')
        self.run = DeviceRun('patch', stimulus, seed=seed, url_options=url_options,
                             driver_parameters=driver_parameters)
        self.counters: dict[str, int] = {}

    def frames(self, duration_s: float) -> Iterator[GraphFrame]:
        """The 20 Hz frames completed by the wire frames of device time [0, ``duration_s``): wire frames
        ``0 .. int(duration_s / period) - 1`` (frames lost on the virtual wire are missing, not padded)."""
        if not (duration_s >= 0 and np.isfinite(duration_s)):
            raise ValueError(f'duration_s must be a finite number of seconds >= 0; got {duration_s}')
        contact = np.zeros(N_PANELS, dtype=bool)
        topics = [('/patch/panels', 'PanelContact'), ('/patch/frame', 'PatchFrame')]
        # Panels first: the driver publishes a frame's PanelContact just before the frame.
        for topic, msg, t in self.run.messages(lambda period: int(duration_s / period), topics):
            if topic == '/patch/panels':
                contact = np.array(msg.contact, dtype=bool)
            else:
                yield GraphFrame(t, np.asarray(msg.activation, dtype=np.float32).reshape(GRID), contact)
        self.counters = self.run.counters


def render_scene(scene: Any, seed: int = 0, **options: Any) -> Rendered:
    """The 20 Hz frames the robot's graph makes of ``scene`` over its ``duration_s`` (module doc);
    ``options`` are :class:`PatchFrames`'s (``url_options``, ``driver_parameters``)."""
    source = PatchFrames(scene, seed=seed, **options)
    frames = list(source.frames(float(scene.duration_s)))
    stats: dict[str, Any] = {**source.counters, 'frames': len(frames),
                             'stamps_s': np.array([f.t for f in frames], dtype=np.float64)}
    if not frames:
        return Rendered(np.zeros((0, *GRID), np.float32), np.zeros((0, N_PANELS), bool), stats)
    return Rendered(np.stack([f.activation for f in frames]), np.stack([f.panel_contact for f in frames]), stats)
