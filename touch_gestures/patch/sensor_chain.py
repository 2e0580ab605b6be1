"""Render a simulated patch scene through the sensor chain into activation frames (SYNTHETIC).

The evaluation must see what the robot would: stimulus -> virtual device (wire bytes) ->
frame decoder -> calibration (eq. 1-2) -> activation maps. :func:`render_session` does that
with the driver's classes (``touch_sim.patch.device.PatchDevice``,
``touch_driver.patch.protocol.PatchDecoder``, ``touch_driver.patch.calibration.PatchCalibrator``
and ``PanelCalibrator``) when they are installed (``chain='driver'``), and otherwise with a
stand-in (``chain='simple'``): the 100 Hz scans averaged five at a time to 20 Hz
(sympartner2018 6.1), Gaussian noise, and eq. (2) with the floor k and a gain that gives
full activation at 4 N/cm^2 (the end of the sensor's useful range, 5.3). ``chain='graph'``
runs the robot's own graph instead (:mod:`.graph_chain`): the virtual device opened by its
``patchsim://`` URL and read by the ``patch_driver`` node in simulated time, activations
taken from its ``/patch/frame`` messages; the same seed gives the same activations as the
driver chain.

Panels (item 4 of issue 5): the panel signals travel in every wire frame, so contact is
known as soon as one frame arrives. With the virtual patch's default raw stream (every
100 Hz scan, id 0x51) that is one scan, 10 ms, plus the panel calibrator's threshold (no
averaging is needed for a threshold on signal minus quiescent value); with the paper's
20 Hz averaged firmware (id 0x50) it is 50 ms. The driver chain here thresholds the panels
on every scan; ``panel_contact`` is reported per 20 Hz frame only to line up with the
activations. A "being handled" publisher should not wait for the 20 Hz frame.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from touch_lab.patch.datasets import Session
from touch_sim.patch.people import N_PANELS, PatchScene

__all__ = ['ChainOutput', 'driver_available', 'render_scene', 'render_session']

#: Internal scan rate and rate to the PC, Hz (sympartner2018 6.1).
SCAN_RATE_HZ = 100.0
FRAME_RATE_HZ = 20.0


@dataclass
class ChainOutput:
    """Frames of a rendered scene.

    Attributes:
        activations: (T, 16, 16) float32 activation maps at 20 Hz, unitless in [k, 1].
        panel_contact: (T, 11) bool panel contact per frame.
        chain: 'driver', 'graph' or 'simple', what produced them.
        stats: counters of the chain (frames, decoder errors, ...).
    """

    activations: np.ndarray
    panel_contact: np.ndarray
    chain: str
    stats: dict


def driver_available() -> bool:
    """True when the driver's device and calibration modules can be imported."""
    try:
        importlib.import_module('touch_sim.patch.device')
        importlib.import_module('touch_driver.patch.calibration')
    except ImportError:
        return False
    return True


def render_scene(scene: PatchScene, seed: int = 0, chain: str = 'auto', k: float = 0.08,
                 full_scale: float = 4.0, noise: float = 0.01) -> ChainOutput:
    """Frames the robot would see of ``scene``, at 20 Hz.

    Args:
        scene: the stimulus.
        seed: sensor noise seed.
        chain: 'driver', 'graph', 'simple' or 'auto' (the driver when available).
        k, full_scale, noise: the stand-in's floor, N/cm^2 at activation 1, and noise std
            (activation units); unused by the driver and graph chains.
    """
    if chain == 'auto':
        chain = 'driver' if driver_available() else 'simple'
    if chain == 'driver':
        return _render_driver(scene, seed)
    if chain == 'graph':
        from .graph_chain import render_graph
        return render_graph(scene, seed)
    if chain != 'simple':
        raise ValueError(f"chain must be 'auto', 'driver', 'graph' or 'simple'; got {chain!r}")
    return _render_simple(scene, seed, k, full_scale, noise)


def _render_simple(scene: PatchScene, seed: int, k: float, full_scale: float, noise: float) -> ChainOutput:
    rng = np.random.default_rng(seed)
    per_frame = round(SCAN_RATE_HZ / FRAME_RATE_HZ)
    n = int(scene.duration_s * FRAME_RATE_HZ)
    acts = np.empty((n, *scene.grid), dtype=np.float32)
    panels = np.zeros((n, N_PANELS), dtype=bool)
    for f in range(n):
        scans = [scene.pressure((f * per_frame + s) / SCAN_RATE_HZ) for s in range(per_frame)]
        p = np.mean(scans, axis=0)
        r = p / full_scale + rng.normal(0.0, noise, p.shape)
        acts[f] = np.clip(r, k, 1.0)
        panels[f] = scene.panels(f / FRAME_RATE_HZ) >= 0.5
    return ChainOutput(acts, panels, 'simple', {'frames': n})


def _render_driver(scene: PatchScene, seed: int, panel_every_scan: bool = True) -> ChainOutput:
    from touch_driver.patch.calibration import PanelCalibrator, PatchCalibrator
    from touch_driver.patch.protocol import PatchDecoder
    from touch_sim.patch.device import PatchDevice

    device = PatchDevice(scene, seed=seed)              # raw 100 Hz scans on the wire (id 0x51)
    decoder = PatchDecoder()
    calibrator = PatchCalibrator()                      # default outline, gain, tau, k
    panel_cal = PanelCalibrator.from_yaml(rate_hz=1.0 / device.frame_period)
    n_wire = int(scene.duration_s / device.frame_period)
    acts, panels = [], []
    contact = np.zeros(N_PANELS, dtype=bool)
    for index in range(n_wire):
        for scan in decoder.feed(device.frame_bytes(index, index * device.frame_period)):
            # Panels are thresholded on every scan: contact is known 10 ms after it happens.
            contact = np.asarray(panel_cal.update(scan.panels).contact, dtype=bool)
            out = calibrator.update_scan(scan.cells) if scan.raw_scan else calibrator.update(scan.cells)
            if out is None:  # a raw scan that does not complete a 20 Hz frame
                continue
            acts.append(out.activation)
            panels.append(contact)
    stats = {'frames': len(acts), 'wire_frames': n_wire, 'checksum_errors': decoder.stats.checksum_errors,
             'dropped_bytes': decoder.stats.dropped_bytes, 'sequence_gaps': decoder.stats.sequence_gaps}
    if not acts:
        return ChainOutput(np.zeros((0, *scene.grid), np.float32), np.zeros((0, N_PANELS), bool), 'driver', stats)
    return ChainOutput(np.stack(acts), np.stack(panels), 'driver', stats)


def render_session(scene: PatchScene, subject: str, gesture: str, seed: int = 0, chain: str = 'auto') -> Session:
    """A labelled :class:`Session` (SYNTHETIC) of ``scene`` with its ground-truth events."""
    out = render_scene(scene, seed=seed, chain=chain)
    events = [(e.onset_s, e.offset_s) for e in scene.events]
    return Session(subject=subject, gesture=gesture, activations=out.activations, rate_hz=FRAME_RATE_HZ,
                   events=events, source=f'simulated ({out.chain} chain)', synthetic=True,
                   panels=out.panel_contact)
