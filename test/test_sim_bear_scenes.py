"""Stimuli for the virtual bear: envelopes, scripts, YAML timelines, the registry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap
from touch_graph.errors import ConfigError
from touch_sim.scenes import (
    BearScript,
    BearStimulus,
    BearTouch,
    IdleBear,
    IdlePatch,
    envelope,
    load_stimulus,
    register_stimulus,
    registered_stimuli,
    unregister_stimulus,
)

BODY = BodyMap.default()


def test_envelopes() -> None:
    assert envelope(-0.1, 1.0) == 0.0 and envelope(1.0, 1.0) == 0.0 and envelope(0.5, 1.0) == 1.0
    assert envelope(0.05, 1.0, ramp_s=0.1) == pytest.approx(0.5)  # soft onset
    sine = [envelope(u, 10.0, 'sine', freq_hz=2.0, ramp_s=0) for u in np.arange(0, 1, 0.125)]
    assert sine[0] == 0.0 and sine[2] == pytest.approx(1.0) and sine[4] == pytest.approx(0.0, abs=1e-12)
    pulse = [envelope(u, 10.0, 'pulse', freq_hz=1.0, duty=0.25, ramp_s=0) for u in (0.1, 0.3, 1.1)]
    assert pulse == [1.0, 0.0, 1.0]
    with pytest.raises(ValueError, match='envelope'):
        envelope(0.5, 1.0, 'square')


def test_script_takes_the_larger_of_overlapping_touches() -> None:
    script = BearScript([BearTouch(channels=(1, 2), start=0, duration=5, level=0.4, ramp_s=0),
                         BearTouch(channels=(2, 3), start=1, duration=1, level=0.9, ramp_s=0)])
    assert isinstance(script, BearStimulus) and script.duration == 5
    p = script.proximity(1.5)
    assert p.dtype == np.float32 and p.shape == (64,)
    assert p[[0, 1, 2, 3]].tolist() == pytest.approx([0, 0.4, 0.9, 0.9])
    assert script.proximity(3.0)[3] == 0
    with pytest.raises(ValueError, match=r'0\.\.63'):
        BearScript([BearTouch(channels=(64,), start=0, duration=1)])


def test_yaml_timeline(tmp_path: Path) -> None:
    path = tmp_path / 'scene.yaml'
    path.write_text('''\
sensor: bear
description: head pat then a foot rub (synthetic)
touches:
  - {sensors: [head1, head2, 5], start: 1.0, duration: 3.0, level: 1.0, envelope: pulse, freq_hz: 1.5}
  - {region: left_foot, start: 5.0, duration: 4.0, level: 0.8, envelope: sine, freq_hz: 1.0}
''')
    script = load_stimulus(path, sensor='bear')
    assert isinstance(script, BearScript)
    assert script.touches[0].channels == (0, 1, 5)
    assert script.touches[1].channels == tuple(s.channel for s in BODY.region('left_foot'))
    assert script.proximity(1.2)[1] == pytest.approx(1.0)
    assert script.proximity(6.5)[54] == pytest.approx(0.8) and script.proximity(6.5)[0] == 0


@pytest.mark.parametrize('body, message, line', [
    ('touches:\n  - {sensors: [head1, hed2], start: 0, duration: 1}\n', "did you mean 'head2'", 3),
    ('touches:\n  - {region: lft_foot, start: 0, duration: 1}\n', "did you mean 'left_foot'", 3),
    ('touches:\n  - {sensors: [head1], start: 0, duration: 1, levle: 1}\n', "did you mean 'level'", 3),
    ('touches:\n  - {sensors: [head1], start: 0, duration: 1, level: 2}\n', 'level must be in 0..1', 3),
    ('touches:\n  - {sensors: [head1], start: 0, duration: 0}\n', 'duration > 0', 3),
    ('touches:\n  - {sensors: [head1], start: 0, duration: 1, envelope: sin}\n', "did you mean 'sine'", 3),
    ('touches:\n  - {start: 0, duration: 1}\n', 'needs sensors', 3),
    ('panels: []\n', 'patch scene', 2),
])
def test_yaml_errors_name_the_line(tmp_path: Path, body: str, message: str, line: int) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text('sensor: bear\n' + body)
    with pytest.raises(ConfigError, match=message) as err:
        load_stimulus(path, sensor='bear')
    assert err.value.line == line and err.value.path == str(path)


def test_registry_and_builtins(tmp_path: Path) -> None:
    assert isinstance(load_stimulus('idle', sensor='bear'), IdleBear)
    assert isinstance(load_stimulus('idle', sensor='patch'), IdlePatch)
    stim = BearScript([])
    register_stimulus('scene-a', stim)
    try:
        assert load_stimulus('scene-a', sensor='bear') is stim and 'scene-a' in registered_stimuli()
        with pytest.raises(ConfigError, match='not a patch stimulus'):
            load_stimulus('scene-a', sensor='patch')
    finally:
        unregister_stimulus('scene-a')
    with pytest.raises(ConfigError, match='no registered stimulus'):
        load_stimulus('scene-a')
    with pytest.raises(TypeError, match='proximity'):
        register_stimulus('x', object())
    path = tmp_path / 'p.yaml'
    path.write_text('sensor: patch\n')
    with pytest.raises(ConfigError, match='for the patch, not the bear'):
        load_stimulus(path, sensor='bear')
    with pytest.raises(ConfigError, match='file not found'):
        load_stimulus(tmp_path / 'missing.yaml')
