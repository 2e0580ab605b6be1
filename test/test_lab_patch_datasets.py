"""Readers of labelled patch recordings: CoST-layout CSV and rosbag2 bags with a YAML manifest."""


import numpy as np
import pytest
from doctest_testing import check_doctests
from rosbags.rosbag2 import Writer

from touch_graph.errors import ConfigError
from touch_graph.messages import get_message, serialize, typestore
from touch_lab.patch import datasets as datasets_module
from touch_lab.patch.datasets import (
    DatasetError,
    activation_from_raw,
    parse_grid,
    read_bag_manifest,
    read_cost_csv,
)


def write_csv(path, rows, n_ch=4):
    header = 'subject,variant,gesture,frame,' + ','.join(f'ch{i + 1}' for i in range(n_ch))
    path.write_text(header + '\n' + '\n'.join(rows) + '\n')
    return path


def test_cost_csv_splits_sessions_and_converts_raw(tmp_path):
    rows = []
    for subject, gesture in (('s1', 'pat'), ('s1', 'stroke'), ('s2', 'pat')):
        for f in range(5):
            level = 300 if f == 2 else 10
            rows.append(f'{subject},normal,{gesture},{f},{level},10,10,10')
    rows += [f's2,normal,pat,{f},10,10,10,10' for f in range(3)]  # frame restarts: a new capture
    sessions = read_cost_csv(write_csv(tmp_path / 'cost.csv', rows), grid=(2, 2), rate_hz=135.0, gain=1 / 200)
    assert [(s.subject, s.gesture, s.n_frames) for s in sessions] == [
        ('s1', 'pat', 5), ('s1', 'stroke', 5), ('s2', 'pat', 5), ('s2', 'pat', 3)]
    s = sessions[0]
    assert s.activations.dtype == np.float32 and s.grid == (2, 2) and s.rate_hz == 135.0
    assert s.activations[2, 0, 0] == pytest.approx(1.0)   # 290 counts over the minimum, clipped
    assert s.activations[0, 0, 0] == pytest.approx(0.08)  # the floor k
    assert s.events is None and not s.synthetic


def test_cost_csv_activation_values_and_empty_cells(tmp_path):
    rows = ['a,v,g,0,0.08,0.5,,nan', 'a,v,g,1,0.08,0.08,0.08,0.08']
    s = read_cost_csv(write_csv(tmp_path / 'a.csv', rows), grid=(2, 2), rate_hz=20, values='activation')[0]
    assert s.activations[0, 0, 1] == pytest.approx(0.5)
    assert np.isnan(s.activations[0, 1]).all()  # empty and nan cells: no reading


@pytest.mark.parametrize('content, match, line', [
    ('subject,variant,gesture,ch1\n', 'CoST header', 1),
    ('subject,variant,gesture,frame,ch1,ch2\n', '2 channel columns.*--grid 2x2 needs 4', 1),
    ('subject,variant,gesture,frame,ch1,ch2,ch3,ch4\na,v,g,0,1,2,3\n', '7 fields', 2),
    ('subject,variant,gesture,frame,ch1,ch2,ch3,ch4\na,v,g,0,1,2,3,4\na,v,g,1,1,x,3,4\n', 'numbers', 3),
    ('subject,variant,gesture,frame,ch1,ch2,ch3,ch4\n,v,g,0,1,2,3,4\n', 'subject and gesture', 2),
    ('subject,variant,gesture,frame,ch1,ch2,ch3,ch4\n', 'no data rows', None),
    ('', 'empty file', 1),
])
def test_cost_csv_errors_name_file_and_line(tmp_path, content, match, line):
    path = tmp_path / 'bad.csv'
    path.write_text(content)
    with pytest.raises(DatasetError, match=match) as err:
        read_cost_csv(path, grid=(2, 2), rate_hz=135)
    assert err.value.line == line and err.value.path == str(path)


def test_cost_csv_missing_file_and_bad_arguments(tmp_path):
    with pytest.raises(ConfigError, match='cannot open'):
        read_cost_csv(tmp_path / 'missing.csv')
    with pytest.raises(ValueError, match='values'):
        read_cost_csv(tmp_path / 'x.csv', values='counts')
    with pytest.raises(ValueError, match='ROWSxCOLS'):
        parse_grid('8by8')


def test_activation_from_raw_tracks_the_minimum_and_survives_nan():
    raw = np.full((200, 1, 2), 100.0)
    raw[50:60, 0, 0] = 400.0
    raw[:, 0, 1] += np.linspace(0, 40, 200)  # slow drift of the resting value
    raw[70, 0, 1] = np.nan
    r = activation_from_raw(raw, gain=1 / 300)
    assert r[55, 0, 0] == pytest.approx(1.0, abs=0.01)
    assert r[100, 0, 0] == pytest.approx(0.08)
    assert np.isnan(r[70, 0, 1]) and np.isfinite(r[71:, 0, 1]).all()
    assert r[199, 0, 1] < 0.2  # the minimum rises with the drift (eq. 1)


# ---------------------------------------------------------------------- bags
def write_bag(path, frames, topic='/patch/frame', msgtype='social_touch_msgs/msg/PatchFrame', rate=20.0):
    PatchFrame, Header = get_message('PatchFrame'), get_message('std_msgs/msg/Header')
    Time = get_message('builtin_interfaces/msg/Time')
    with Writer(path, version=9) as writer:
        conn = writer.add_connection(topic, msgtype, typestore=typestore)
        for i, act in enumerate(frames):
            ns = int(i / rate * 1e9) + 1_000_000_000
            msg = PatchFrame(header=Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id='patch'),
                             sequence=i, activation=np.asarray(act, np.float32).ravel(),
                             raw=np.zeros(256, np.uint16), in_outline=[True] * 256)
            writer.write(conn, ns, serialize(msg))


def test_bag_manifest_reads_sessions(tmp_path):
    frames = np.full((30, 16, 16), 0.08, np.float32)
    frames[10:15, 4, 4] = 0.7
    write_bag(tmp_path / 'p1_stroke', frames)
    write_bag(tmp_path / 'p2_push', frames[:12])
    (tmp_path / 'm.yaml').write_text(
        'sessions:\n'
        '  - {bag: p1_stroke, subject: p1, gesture: stroke, events: [[0.5, 0.7]]}\n'
        '  - {bag: p2_push, subject: p2, gesture: push}\n')
    s1, s2 = read_bag_manifest(tmp_path / 'm.yaml')
    assert (s1.subject, s1.gesture, s1.n_frames, s1.events) == ('p1', 'stroke', 30, [(0.5, 0.7)])
    assert s1.rate_hz == pytest.approx(20.0)
    np.testing.assert_array_equal(s1.activations, frames)
    assert (s2.subject, s2.n_frames, s2.events) == ('p2', 12, None)


@pytest.mark.parametrize('manifest, match, line', [
    ('sessions:\n  - {bag: b, subject: p1, gestur: stroke}\n', "unknown key 'gestur'.*did you mean 'gesture'", 2),
    ('sessions:\n  - {bag: nope, subject: p1, gesture: stroke}\n', 'not found', 2),
    ('sessions:\n  - {bag: b, subject: p1, gesture: stroke, events: [[2, 1]]}\n', 'onset < offset', 2),
    ('topic: /other\nsessions:\n  - {bag: b, subject: p1, gesture: stroke}\n', 'no topic /other', 3),
    ('sessions: []\n', 'non-empty list', 1),
    ('session:\n  - {bag: b}\n', "unknown key 'session'", 1),
])
def test_bag_manifest_errors_point_at_the_line(tmp_path, manifest, match, line):
    write_bag(tmp_path / 'b', np.full((3, 16, 16), 0.08, np.float32))
    path = tmp_path / 'm.yaml'
    path.write_text(manifest)
    with pytest.raises(ConfigError, match=match) as err:
        read_bag_manifest(path)
    assert err.value.line == line


def test_bag_of_another_message_type_is_refused(tmp_path):
    with Writer(tmp_path / 'b', version=9) as writer:
        conn = writer.add_connection('/patch/frame', 'std_msgs/msg/Header', typestore=typestore)
        writer.write(conn, 1, serialize(get_message('std_msgs/msg/Header')()))
    (tmp_path / 'm.yaml').write_text('sessions:\n  - {bag: b, subject: p1, gesture: stroke}\n')
    with pytest.raises(ConfigError, match='expected social_touch_msgs/msg/PatchFrame'):
        read_bag_manifest(tmp_path / 'm.yaml')


def test_doctests():
    check_doctests(datasets_module)
