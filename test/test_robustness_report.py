"""The robustness report's cases and figures hold what docs/robustness.md states (issue 12, build item 6)."""

from __future__ import annotations

import pytest

from touch_lab.robustness.cases import CLEAR, HANDLED, all_cases, run_case, run_cli
from touch_lab.robustness.dds_injection import dds_injection
from touch_lab.robustness.figures import bag_corruption, recorder_kill, unplug_recovery

CASES = all_cases()


@pytest.mark.parametrize(('area', 'case', 'what'), CASES, ids=[f'{a}: {c}' for a, c, _ in CASES])
def test_every_case_is_a_clear_error_or_handled(area, case, what) -> None:
    outcome = run_cli(area, case, what) if isinstance(what, list) else run_case(area, case, what)
    assert outcome.result in (CLEAR, HANDLED), outcome


def test_eight_of_eight_bag_corruptions_are_detected_by_reindex_and_both_readers() -> None:
    detected = bag_corruption(8)['detected']
    assert detected['reindex'] == detected['rosbags_reader'] == detected['mcap_reader_crc_on'] == 8


def test_a_recorder_killed_with_sigkill_keeps_a_gapless_prefix_losing_at_most_a_flush_period() -> None:
    result = recorder_kill(run_s=2.5, flush_period_s=0.5)
    assert result['returncode'] == -9 and result['gapless_prefix'] and result['recovered'] > 0
    assert result['lost'] <= 0.5 * 200 + 20          # a flush period of a 200 Hz topic, and the last chunk's slack


def test_a_driver_recovers_within_a_reconnect_period_after_an_unplug() -> None:
    result = unplug_recovery()
    assert result['error_while_unplugged'] and result['reconnects'] == [1, 1, 1, 1]
    assert result['max_recovery_s'] <= result['reconnect_period_s'] + 0.01


def test_another_process_on_our_domain_can_inject_haptic_commands(dds_domain) -> None:
    """The measured default (no DDS Security): what docs/robustness.md and docs/network.md state."""
    result = dds_injection(domain=dds_domain, messages=20)
    assert result['measured'] and result['intruder_exit'] == 0
    assert result['received'] == 20


def test_the_outcome_classes_cover_hangs_and_lost_data():
    from touch_lab.robustness.cases import HANG, LOST, DataLost

    def lose():
        raise DataLost('2 of 5 flushed messages gone')

    def spin():
        while True:
            pass

    assert run_case('t', 'lost', lose).result == LOST
    hung = run_case('t', 'hang', spin, timeout_s=0.2)
    assert hung.result == HANG and '0.2 s' in hung.detail
    assert run_case('t', 'fine', lambda: 'ok').result == HANDLED       # the alarm is off again afterwards
    assert run_cli('t', 'slow', ['--help'], timeout_s=1e-3).result == HANG
