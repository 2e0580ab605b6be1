"""The bear's body map: config/bear_body.yaml and its loader."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from touch_driver.bear.body_map import REGIONS, BodyMap, BodySensor, channel_of
from touch_graph.errors import ConfigError

SPEC = {  # the shared spec, midplane by midplane ('-' = unfitted)
    0: 'head1 head2 head3 head4 ear_left ear_right cheek_left cheek_right',
    1: 'snout mouth chin neck_front neck_back - - -',
    2: 'chest_left chest_right belly_upper belly_middle belly_lower belly_left belly_right -',
    3: 'back_upper back_middle back_lower side_left_upper side_left_lower side_right_upper side_right_lower bottom',
    4: 'shoulder_left upper_arm_left_outer upper_arm_left_inner forearm_left paw_left_back paw_left_palm - -',
    5: 'shoulder_right upper_arm_right_outer upper_arm_right_inner forearm_right paw_right_back paw_right_palm - -',
    6: 'hip_left thigh_left_outer thigh_left_inner knee_left shin_left foot_left_top foot_left_sole foot_left_toe',
    7: 'hip_right thigh_right_outer thigh_right_inner knee_right shin_right foot_right_top foot_right_sole '
       'foot_right_toe',
}


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / 'body.yaml'
    path.write_text(textwrap.dedent(text))
    return path


def test_default_map_matches_the_shared_spec() -> None:
    body = BodyMap.default()
    assert len(body) == 56
    for midplane, names in SPEC.items():
        for inp, name in enumerate(names.split()):
            channel = channel_of(midplane, inp)
            sensor = body.by_channel(channel)
            if name == '-':
                assert sensor is None
            else:
                assert sensor is not None and sensor.name == name
                assert body.by_name(name).channel == channel
    assert body.fitted_mask().sum() == 56 and body.fitted_mask().shape == (64,)
    assert [s.channel for s in body.sensors] == sorted(s.channel for s in body.sensors)


def test_attributes_are_consistent() -> None:
    body = BodyMap.default()
    assert {s.region for s in body} == set(REGIONS)
    for s in body:
        assert s.side in ('left', 'right', 'center') and s.size in ('small', 'large') and s.location
        if s.name.endswith('_left') or '_left_' in s.name:
            assert s.side == 'left', s
        if s.name.endswith('_right') or '_right_' in s.name:
            assert s.side == 'right', s
    assert body.by_name('foot_left_sole').location == 'left foot sole'
    assert body.by_name('head1').location == 'crown front'
    assert body.by_name('thigh_left_outer').size == 'large' and body.by_name('belly_middle').size == 'large'
    assert body.by_name('paw_left_palm').size == 'small'
    assert [s.name for s in body.region('head')][:4] == ['head1', 'head2', 'head3', 'head4']
    assert body.by_name('side_right_lower').region == 'side_right'
    assert body.by_name('neck_back').midplane == 1 and body.by_name('neck_back').input == 4


def test_lookups_and_did_you_mean() -> None:
    body = BodyMap.default()
    assert body.channels(['head2', 'foot_right_sole']).tolist() == [1, 62]
    assert body.channels([]).shape == (0,)
    with pytest.raises(ConfigError, match="did you mean 'head2'"):
        body.by_name('hed2')
    with pytest.raises(ConfigError, match='unknown bear sensor'):
        body.channels(['head1', 'tail'])
    with pytest.raises(ConfigError, match="did you mean 'left_foot'"):
        body.region('left_fot')
    assert body.by_channel(63).name == 'foot_right_toe'
    assert body.by_channel(13) is None and body.by_channel(99) is None
    assert not body.fitted_mask().flags.writeable


def test_load_reports_file_and_line(tmp_path: Path) -> None:
    path = write(tmp_path, '''\
        sensors:
          - {channel: 0, name: head1, location: crown, region: head, side: center, size: small}
          - {channel: 1, name: head2, location: crown, region: haed, side: center, size: small}
        ''')
    with pytest.raises(ConfigError, match="did you mean 'head'") as err:
        BodyMap.load(path)
    assert err.value.path == str(path) and err.value.line == 3


@pytest.mark.parametrize('entry, message', [
    ('{channel: 64, name: x, location: a, region: head, side: center, size: small}', 'outside 0..63'),
    ('{channel: 0, name: y, location: a, region: head, side: center, size: small}', 'channel 0 is given twice'),
    ('{channel: 2, name: head1, location: a, region: head, side: center, size: small}', 'used twice'),
    ('{channel: 2, name: z, location: a, region: head, side: middle, size: small}', 'side'),
    ('{channel: 2, name: z, location: a, region: head, side: left, size: huge}', 'size'),
    ('{channel: 2, name: z, location: a, region: head, side: left, size: small, colour: red}', "unknown key 'colour'"),
    ('{channel: 2, name: z, location: a, region: head, side: left}', "missing key 'size'"),
    ('{channel: two, name: z, location: a, region: head, side: left, size: small}', 'must be int'),
    ('{channel: 2, name: Bad-Name, location: a, region: head, side: left, size: small}', 'lower case'),
])
def test_validation_errors(tmp_path: Path, entry: str, message: str) -> None:
    path = write(tmp_path, f'''\
        sensors:
          - {{channel: 0, name: head1, location: crown, region: head, side: center, size: small}}
          - {entry}
        ''')
    with pytest.raises(ConfigError, match=message) as err:
        BodyMap.load(path)
    assert err.value.line == 3


def test_top_level_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="unknown key 'sensor'"):
        BodyMap.load(write(tmp_path, 'sensor: []\n'))
    with pytest.raises(ConfigError, match='non-empty list'):
        BodyMap.load(write(tmp_path, 'sensors: []\n'))
    with pytest.raises(ConfigError, match='format 2'):
        BodyMap.load(write(tmp_path, 'format: 2\nsensors: [{channel: 0, name: a, location: b, region: head, '
                                     'side: left, size: small}]\n'))
    with pytest.raises(ConfigError, match='file not found'):
        BodyMap.load(tmp_path / 'missing.yaml')


def test_constructed_from_code() -> None:
    body = BodyMap([BodySensor(9, 'b', 'x', 'face', 'center', 'small'),
                    BodySensor(2, 'a', 'y', 'head', 'left', 'large')])
    assert body.names == ('a', 'b')
    assert np.flatnonzero(body.fitted_mask()).tolist() == [2, 9]
    with pytest.raises(ConfigError, match='used twice'):
        BodyMap([BodySensor(1, 'a', 'x', 'head', 'left', 'small'), BodySensor(2, 'a', 'x', 'head', 'left', 'small')])
    with pytest.raises(ConfigError, match='region'):
        BodyMap([BodySensor(1, 'a', 'x', 'tail', 'left', 'small')])
