"""The skin driver node on a real pseudo-terminal: each frame is data once, and /diagnostics says what came (issue 25).

The test writes synthetic skin frames (version-2 framing, docs/protocols.md) to the pty's master
side; the driver opens the terminal side's path as its port and runs on a simulated clock.
"""

from __future__ import annotations

import math

from touch_driver.skin.node import SkinDriverNode
from touch_lab.robustness.pty_run import WARN, corrupt_some, level_of, paced, run_driver, value_of
from touch_lab.robustness.pty_run import skin_frames as frames

RATE_HZ = 150.0


def run_skin(wire: list[tuple[bytes, float]], **params):
    return run_driver(SkinDriverNode, 'skin', wire, **params)


def test_a_replayed_frame_is_published_once() -> None:
    one = frames([4711])[0]
    _, statuses, diagnostics, published = run_skin(paced([one] * 733, RATE_HZ))
    assert published == 1 and statuses[-1].frames == 1               # 732 replays: published 0 extra times
    assert value_of(diagnostics[-1], 'repeated_frames') == '732' and statuses[-1].repeated_frames == 732
    assert (statuses[-1].frames_missed, statuses[-1].sequence_gaps) == (0, 0)
    assert any('resent with the last sequence number' in d.message and level_of(d) >= WARN for d in diagnostics)


def test_a_reboot_is_reported_once_and_nothing_is_lost() -> None:
    wire = frames(range(300)) + frames(range(300))                   # the sensor restarted at 0
    _, statuses, diagnostics, published = run_skin(paced(wire, RATE_HZ))
    assert published == 600
    assert value_of(diagnostics[-1], 'sequence_resets') == '1' and statuses[-1].sequence_resets == 1
    assert (statuses[-1].frames_missed, statuses[-1].sequence_gaps) == (0, 0)
    assert all(s.error_fraction == 0.0 for s in statuses)             # not "99.8 % bad or lost"
    told = [d for d in diagnostics if 'jumped back' in d.message]
    assert len(told) == 1 and level_of(told[0]) == WARN
    assert 'jumped back (1 times since start)' in statuses[-1].last_error   # and ~/status names it


def test_a_quarter_of_frames_corrupt_reads_a_quarter() -> None:
    n = 1500
    wire, hit = corrupt_some(frames(range(n)), 0.25, seed=25)
    _, statuses, _diagnostics, published = run_skin(paced(wire, RATE_HZ))
    last = statuses[-1]
    lost = last.frames_missed + last.checksum_errors + last.decode_errors + last.length_errors + last.handle_errors
    assert published == last.frames == n - hit
    assert lost == hit                                          # each corrupt frame counted once
    # The share a driver reports is K / n with K ~ Binomial(n, 0.25): within 4 standard deviations of 25 %.
    assert abs(lost / (lost + last.frames) - 0.25) <= 4 * math.sqrt(0.25 * 0.75 / n)


def test_ten_times_the_rate_is_warned() -> None:
    wire = frames(range(3000))
    _, statuses, diagnostics, published = run_skin(paced(wire, 10 * RATE_HZ, per_write=12), seconds=0.0)
    assert published == 3000
    assert statuses[0].rate_hz > 5 * RATE_HZ
    fast = [d for d in diagnostics if 'x the expected' in d.message]
    assert len(fast) == 2 and all(level_of(d) == WARN for d in fast)


def test_the_rate_expected_is_ok() -> None:
    _, _, diagnostics, published = run_skin(paced(frames(range(450)), RATE_HZ), seconds=0.0)
    assert published == 450
    assert len(diagnostics) >= 2 and [level_of(d) for d in diagnostics[:2]] == [0, 0]
