"""Trace CSV reader: grouping, gzip, and clear errors on bad rows (synthetic files only)."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from touch_gestures.skin.errors import TraceFormatError
from touch_lab.skin.datasets import TraceSample, read_traces, write_traces

HEADER = 'subject,variant,gesture,sample,stroke,x,y,t_ms\n'


def _write(tmp_path, text, name='t.csv'):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_groups_rows_by_sample_and_sorts_by_stroke_and_time(tmp_path):
    text = HEADER + ('1,a,line,0,0,2,0,20\n'
                     '1,a,line,0,0,0,0,0\n'
                     '1,a,line,1,0,5,5,0\n'
                     '1,a,x,0,1,9,9,300\n'
                     '1,a,x,0,0,0,0,0\n'
                     '1,a,x,0,0,9,9,100\n')
    traces = read_traces(_write(tmp_path, text))
    assert [s.key for s in traces] == [('1', 'a', 'line', '0'), ('1', 'a', 'line', '1'), ('1', 'a', 'x', '0')]
    first = traces.samples[0]
    assert first.x.tolist() == [0.0, 2.0] and first.t_ms.tolist() == [0.0, 20.0]
    assert traces.samples[2].stroke.tolist() == [0, 0, 1] and traces.samples[2].n_strokes == 2
    assert traces.multi_stroke_samples == 1 and traces.rows == 6
    assert traces.subjects == ['1'] and traces.gestures == ['line', 'x']


def test_gzip_is_recognised_by_content_and_round_trips(tmp_path):
    sample = TraceSample('7', 'slow', 'v', '3', x=np.array([0.0, 1.5]), y=np.array([2.0, 0.25]),
                         t_ms=np.array([0.0, 12.5]), stroke=np.array([0, 0], dtype=np.int32))
    path = tmp_path / 'traces.csv.gz'
    write_traces(path, [sample])
    assert path.read_bytes()[:2] == b'\x1f\x8b'
    with gzip.open(path, 'rt') as f:
        assert f.readline().strip() == HEADER.strip()
    back = read_traces(path).samples[0]
    assert back.key == sample.key
    np.testing.assert_array_equal(back.x, sample.x)
    np.testing.assert_array_equal(back.t_ms, sample.t_ms)
    # Same content without the .gz name: still read as gzip.
    renamed = tmp_path / 'plain_name.csv'
    renamed.write_bytes(path.read_bytes())
    assert len(read_traces(renamed)) == 1


def test_missing_column_names_the_header_line(tmp_path):
    with pytest.raises(TraceFormatError, match=r't.csv:1: missing column\(s\) t_ms'):
        read_traces(_write(tmp_path, 'subject,variant,gesture,sample,stroke,x,y\n1,a,b,0,0,1,2\n'))


@pytest.mark.parametrize('row, message', [
    ('1,a,line,0,0,abc,0,0', 'numbers'),
    ('1,a,line,0,0,1,nan,0', 'finite'),
    ('1,a,line,0', 'expected 8 fields'),
    ('1,a,line,0,-1,1,1,0', 'stroke >= 0'),
])
def test_bad_row_raises_with_its_line(tmp_path, row, message):
    text = HEADER + '1,a,line,0,0,0,0,0\n' + row + '\n'
    with pytest.raises(TraceFormatError, match=message) as info:
        read_traces(_write(tmp_path, text))
    assert info.value.line == 3


def test_skip_mode_counts_bad_rows(tmp_path):
    text = HEADER + '1,a,line,0,0,0,0,0\n1,a,line,0,0,x,0,5\n1,a,line,0,0,4,0,10\n\n'
    traces = read_traces(_write(tmp_path, text), errors='skip')
    assert traces.skipped_rows == 1 and traces.skip_reasons == {'not a number': 1}
    assert len(traces.samples[0].x) == 2


def test_empty_missing_and_sampleless_files(tmp_path):
    with pytest.raises(TraceFormatError, match='empty file'):
        read_traces(_write(tmp_path, ''))
    with pytest.raises(TraceFormatError, match='file not found'):
        read_traces(tmp_path / 'nope.csv')
    with pytest.raises(TraceFormatError, match='no valid sample'):
        read_traces(_write(tmp_path, HEADER + '1,a,b,0,0,x,y,z\n'), errors='skip')
    with pytest.raises(TraceFormatError, match='not a readable'):
        (tmp_path / 'bad.gz').write_bytes(b'\x1f\x8b' + b'garbage' * 10)
        read_traces(tmp_path / 'bad.gz')


def test_limit_keeps_the_first_samples(tmp_path):
    text = HEADER + ''.join(f'1,a,g,{i},0,{i},0,0\n' for i in range(5))
    assert [s.sample for s in read_traces(_write(tmp_path, text), limit=2)] == ['0', '1']
    with pytest.raises(ValueError, match='limit'):
        read_traces(_write(tmp_path, text), limit=0)
