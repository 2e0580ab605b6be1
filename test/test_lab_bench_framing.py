"""The framing flood benchmark: its floods are what they say, and version 2 passes none of them."""

from __future__ import annotations

import pytest

from touch_driver.framing import SYNC
from touch_lab.bench.framing import FLOODS, flood, run_flood


@pytest.mark.parametrize('kind', FLOODS)
def test_a_flood_passes_no_bogus_frame_and_loses_no_real_one(kind: str) -> None:
    result = run_flood(kind, megabytes=0.3, seed=11)
    assert result['real_frames'] > 100
    assert result['bogus_frames'] == 0 and result['lost_frames'] == 0
    if kind == 'checked_headers':          # every fake reaches the CRC-32 and fails it there
        assert result['checksum_errors'] > 800
    else:                                  # fakes die at the header check, before any payload is awaited
        assert result['checksum_errors'] < 10 and result['header_errors'] + result['version_errors'] > 20_000


def test_the_flood_is_mostly_fake_headers() -> None:
    stream, sent = flood('v1_headers', megabytes=0.1, seed=1)
    assert stream.count(SYNC) > 10_000 and 30 < len(sent) < 100


def test_unknown_flood_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match='unknown flood'):
        flood('nosie', 0.1)
