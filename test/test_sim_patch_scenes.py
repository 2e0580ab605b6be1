"""Stimuli for the virtual patch: pressure blobs, moving touches, panels, YAML timelines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from touch_graph.errors import ConfigError
from touch_sim.scenes import PanelTouch, PatchScript, PatchStimulus, PatchTouch, load_stimulus


def test_pressure_blob_moves_and_adds_up() -> None:
    script = PatchScript([PatchTouch(at=(8, 2), to=(8, 12), radius=1.0, pressure=2.0, start=0, duration=1, ramp_s=0),
                          PatchTouch(at=(3, 3), radius=0.5, pressure=1.0, start=0, duration=1, ramp_s=0)])
    assert isinstance(script, PatchStimulus)
    p = script.pressure(0.5)
    assert p.dtype == np.float32 and p.shape == (16, 16)
    assert np.unravel_index(np.argmax(p), p.shape) == (8, 7)
    assert p[8, 7] == pytest.approx(2.0) and p[3, 3] == pytest.approx(1.0)
    assert p[0, 15] == 0 and (p >= 0).all()  # a finger presses a patch, not the whole matrix
    assert np.unravel_index(np.argmax(script.pressure(0.9)), p.shape) == (8, 11)
    assert not script.pressure(1.5).any()


def test_panels() -> None:
    script = PatchScript(panel_touches=[PanelTouch(panels=(0, 3), start=1, duration=2, level=0.7, ramp_s=0),
                                        PanelTouch(panels=(3,), start=1.5, duration=1, level=1.0, ramp_s=0)])
    assert script.panels(0.5).tolist() == [0.0] * 11
    q = script.panels(2.0)
    assert q.dtype == np.float32 and q[0] == pytest.approx(0.7) and q[3] == 1.0 and q[1] == 0
    with pytest.raises(ValueError, match=r'panels are 0\.\.10'):
        PatchScript(panel_touches=[PanelTouch(panels=(11,), start=0, duration=1)])


def test_yaml_timeline(tmp_path: Path) -> None:
    path = tmp_path / 'patch.yaml'
    path.write_text('''\
sensor: patch
touches:
  - {at: [8, 3], to: [8, 12], radius: 1.5, pressure: 2.5, start: 1.0, duration: 1.5}
  - {at: [4, 6], pressure: 4, start: 3, duration: 2, envelope: pulse, freq_hz: 3}
panels:
  - {panels: [0, 1], start: 6.0, duration: 2.0, level: 1.0}
''')
    script = load_stimulus(path, sensor='patch')
    assert len(script.touches) == 2 and script.touches[0].to == (8.0, 12.0)
    assert script.duration == 8.0
    assert script.pressure(1.1).max() > 0 and script.panels(7.0)[1] == 1.0
    path.write_text('sensor: patch\ntouches:\n  - {at: [8], start: 0, duration: 1}\n')
    with pytest.raises(ConfigError, match=r'at must be \[row, col\]') as err:
        load_stimulus(path)
    assert err.value.line == 3
    path.write_text('sensor: patch\npanels:\n  - {panels: [12], start: 0, duration: 1}\n')
    with pytest.raises(ConfigError, match=r'panel numbers 0\.\.10'):
        load_stimulus(path)
    path.write_text('sensor: patch\ntouches:\n  - {at: [1, 1], start: 0, duration: 1, presure: 3}\n')
    with pytest.raises(ConfigError, match="did you mean 'pressure'"):
        load_stimulus(path)
    path.write_text('sensor: skin\n')
    with pytest.raises(ConfigError, match="'bear' or 'patch'"):
        load_stimulus(path)
