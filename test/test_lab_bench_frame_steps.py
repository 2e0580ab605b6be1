"""``bench frame-steps``: every frame of the scene is timed at every step, and the bench's figures add up."""

from __future__ import annotations

from touch_lab.bench.frame_steps import STEPS, bench_frame_steps, time_steps
from touch_lab.bench.replay import record_scene


def test_every_frame_is_timed_at_every_step() -> None:
    chunks = record_scene('skin', 0.5).chunks
    steps = time_steps(chunks, 0.0)
    assert set(steps) == set(STEPS)
    assert all(len(times) == len(chunks) for times in steps.values())   # one wire frame per chunk
    assert all(ns > 0 for step in ('decode', 'calibrate', 'publish', 'recognise') for ns in steps[step])


def test_the_sum_is_the_steps_and_its_share_of_a_core_at_150_hz() -> None:
    out = bench_frame_steps(repeats=1, seconds=0.3)
    for pacing in ('hot', 'paced'):
        row = out[pacing]
        total = sum(row[f'{step} us'] for step in STEPS)
        assert abs(row['sum us'] - total) <= 0.1 * len(STEPS)
        assert abs(row['sum at 150 Hz, % of one core'] - row['sum us'] * 150 / 1e4) <= 0.01
    assert out['synthetic_data'] is True
