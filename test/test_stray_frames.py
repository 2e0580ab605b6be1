"""A graph a stray process cannot silently blind: frame screening, bounded parameters, a real flood.

The flood is SYNTHETIC: the people scene (config/scenes/skin_people.yaml) on the virtual skin, with a
real second process on our runtime publishing over Cyclone DDS on the test's own domain.
"""

import itertools
from types import SimpleNamespace as NS

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_graph.frame_screen import ERROR, WARN, FrameScreen
from touch_graph.node_health import NodeHealth
from touch_graph.runtime import Context, Node, Parameter
from touch_graph.runtime.parameters import FloatingPointRange, IntegerRange, ParameterDescriptor, check_ranges
from touch_lab.robustness.cases import HANDLED, all_cases, run_case
from touch_lab.robustness.cases_stray import skin_flood, stray_cases


def frame(t_s: float, seq: int = 0, frame_id: str = 'skin') -> NS:
    sec, nanosec = divmod(round(t_s * 1e9), 1_000_000_000)
    return NS(header=NS(stamp=NS(sec=sec, nanosec=nanosec), frame_id=frame_id), sequence=seq)


# ------------------------------------------------------------------ the screen

def test_a_stray_interleaving_frames_stamped_0_is_screened_and_the_driver_followed():
    screen = FrameScreen('/skin/frame')
    used = []
    for i in range(300):
        used += screen.admit(frame(100 + i / 150, i))
        for _ in range(2):                                    # twice the driver's rate
            used += screen.admit(frame(0.0, 0, 'skin'))        # stale, under the driver's own frame_id
    assert [f.sequence for f in used] == list(range(300))
    assert screen.screened == {'stamp_back': 600} and screen.source_changes == 0
    level, text = screen.status()
    assert level == WARN and '600 of 900 frames on /skin/frame not used: 600 stamp_back' in text
    assert screen.status() is None                             # nothing new since


def test_the_stray_first_does_not_keep_the_driver_out():
    screen = FrameScreen('/skin/frame')
    used = []
    for _ in range(5):
        used += screen.admit(frame(0.0, 0, ''))                # the stray's SkinFrame() arrives first
    for i in range(50):
        used += screen.admit(frame(100 + i / 150, i))
        used += screen.admit(frame(0.0, 0, ''))
    driver = [f for f in used if f.header.frame_id == 'skin']
    assert [f.sequence for f in driver] == list(range(50)) and screen.source_changes == 1
    # the stray's frames pass until the driver's third (switch_after) one; none after it
    assert screen.screened == {'other_frame_id': 48}


def test_a_restarted_driver_or_looped_bag_is_followed_without_losing_a_frame():
    screen = FrameScreen('/skin/frame')
    used = [f for i in range(20) for f in screen.admit(frame(500 + i / 150, 1000 + i))]
    used += [f for i in range(20) for f in screen.admit(frame(10 + i / 150, i))]    # stamps and counter restart
    assert len(used) == 40 and [f.sequence for f in used[20:]] == list(range(20))
    assert screen.source_changes == 1 and not screen.screened and screen.status() is None


def test_a_counter_out_of_step_is_screened_once_the_driver_is_seen_counting():
    screen = FrameScreen('/skin/frame', max_sequence_gap=100)
    for i in range(10):
        assert screen.admit(frame(100 + i, 40_000 + i))
    assert screen.admit(frame(200.0, 3)) == []                 # stamped now, but counting from elsewhere
    assert screen.admit(frame(201.0, 40_060))                  # the driver lost 50 frames: still its own
    assert screen.screened == {'sequence_jump': 1}


@settings(max_examples=200, deadline=None)
@given(kept=st.lists(st.booleans(), min_size=2, max_size=400), start=st.integers(0, (1 << 16) - 1))
def test_frames_the_counter_skipped_are_counted_as_missed(kept, start):
    # The driver's uint16 counter from any start (so across its wrap); the node is handed only the kept frames.
    sequence = [(start + i) % (1 << 16) for i in range(len(kept))]
    taken = [i for i, keep in enumerate(kept) if keep]
    screen = FrameScreen('/skin/frame')
    for i in taken:
        assert screen.admit(frame(100 + i / 150, sequence[i]))
    # Counting starts at the first +1 step; from there every index skipped is one frame missed.
    steps = list(itertools.pairwise(taken))
    first = next((n for n, (a, b) in enumerate(steps) if b == a + 1), None)
    expected = 0 if first is None else sum(b - a - 1 for a, b in steps[first + 1:])
    assert screen.missed == expected and screen.counters()['frames_missed'] == expected


def test_missed_frames_are_a_warning_and_repeats_or_restarts_are_not_missed():
    screen = FrameScreen('/skin/frame')
    for i in (0, 1, 2, 6, 7):                                  # 3, 4, 5 never arrived
        screen.admit(frame(100 + i / 150, i))
    screen.admit(frame(100 + 7.5 / 150, 7))                    # a repeat of 7, later stamp: nothing skipped
    assert screen.missed == 3
    level, text = screen.status()
    assert level == WARN and text.startswith('3 frames on /skin/frame missed (6 taken)')
    assert screen.status() is None                             # nothing new since
    for i in range(5):                                         # the driver restarts from 0: a new source, no gap
        screen.admit(frame(10 + i / 150, i))
    assert screen.missed == 3 and screen.source_changes == 1


def test_node_health_puts_the_missed_frames_on_diagnostics():
    context = Context()
    context.init()
    try:
        node = Node('recogniser', context=context)
        health = NodeHealth(node)
        screen = health.screen('/skin/frame')
        for i in (0, 1, 2, 5):
            screen.admit(frame(100 + i / 150, i))
        level, text, counters = health.status()
        assert level == WARN and '2 frames on /skin/frame missed' in text and counters['frames_missed'] == 2
        assert health.status()[0] == 0 and health.status()[2]['frames_missed'] == 2
    finally:
        context.shutdown()


def test_nothing_usable_is_an_error_naming_the_cause():
    screen = FrameScreen('/skin/frame')
    for _ in range(4):
        screen.malformed('non_finite')
    assert screen.status() == (ERROR, 'no usable frame on /skin/frame: 4 received, 4 malformed: non_finite')


def test_bad_screen_arguments_are_refused():
    with pytest.raises(ValueError, match='switch_after'):
        FrameScreen('/x', switch_after=1)


# ------------------------------------------------------------------ parameters

@pytest.fixture
def node():
    ctx = Context('sim', network=False)
    ctx.init()
    yield Node('checked', context=ctx)
    ctx.try_shutdown()


def test_ranges_are_enforced_as_rclpy_does_with_its_text(node):
    node.declare_parameter('gain', 0.5, ParameterDescriptor(floating_point_range=[FloatingPointRange(0.0, 1.0)]))
    node.declare_parameter('taps', 3, ParameterDescriptor(integer_range=[IntegerRange(1, 9, 2)]))
    results = node.set_parameters([Parameter('gain', value=v) for v in (1e6, float('nan'), 1.0 + 1e-9, 0.0)])
    assert [r.successful for r in results] == [False, False, True, True]
    assert results[0].reason.startswith('Parameter gain out of range Min: 0.0, Max: 1.0, value: 1000000.0')
    [odd, even] = node.set_parameters([Parameter('taps', value=9), Parameter('taps', value=4)])
    assert odd.successful and not even.successful and 'not a valid step' in even.reason
    desc = ParameterDescriptor(floating_point_range=[FloatingPointRange(0.0, 1.0, 0.25)])
    assert check_ranges('x', 0.5, desc, '/n') is None and 'valid step' in check_ranges('x', 0.6, desc, '/n')


def test_changes_after_declaration_are_logged_at_warn_and_counted(node, capsys):
    health = NodeHealth(node)
    node.declare_parameter('late', 1.0)                        # a declaration is no change
    node.declare_parameter('gain', 0.5)
    assert health.parameter_changes == 0
    node.set_parameters([Parameter('gain', value=0.7)])
    node.set_parameters([Parameter('gain', value=0.7)])        # the same value: no change
    level, text, counters = health.status()
    assert (level, counters['parameter_changes'], counters['last_parameter_change']) == (WARN, 1, 'gain: 0.5 -> 0.7')
    assert '1 parameter changes from outside the node (last: gain: 0.5 -> 0.7)' in text
    assert '[WARN]' in capsys.readouterr().err
    assert health.status()[0] == 0 and health.status()[2]['parameter_changes'] == 1


def test_post_set_callbacks_run_after_a_set_as_in_rclpy(node):
    seen = []
    node.add_post_set_parameters_callback(lambda params: seen.append([(p.name, p.value) for p in params]))
    node.declare_parameter('a', 1)
    node.set_parameters([Parameter('a', value=2)])
    node.add_on_set_parameters_callback(lambda params: NS(successful=False, reason='no'))
    node.set_parameters([Parameter('a', value=3)])             # refused: no post-set call
    assert seen == [[('a', 1)], [('a', 2)]]


# ------------------------------------------------------------------ the robustness cases

def test_every_stray_case_but_the_floods_is_handled():
    registered = {case for area, case, _ in all_cases() if area == 'stray process in the domain'}
    cases = stray_cases()
    assert registered == {case for _, case, _ in cases}
    for area, case, fn in cases:
        if 'floods' not in case:
            outcome = run_case(area, case, fn)
            assert outcome.result == HANDLED, (case, outcome.detail)


def test_a_real_process_flooding_the_skin_frames_blinds_nothing(dds_domain):
    """SkinFrame() (stamp 0, no frame_id) at 300 Hz from another process over DDS, through the people scene."""
    result = skin_flood(hz=300.0)
    calm, flood = result['calm'], result['flood']
    assert calm['commands'] and abs(len(flood['commands']) - len(calm['commands'])) <= 1, (calm, flood)
    assert flood['screened'].get('other_frame_id', 0) > 0 and flood['stray_before_scene'] > 0
    assert flood['restarts'] == 0 and flood['callback_errors'] == 0
    assert any(level == WARN and 'other_frame_id' in text and 'another publisher' in text
               for level, text in flood['statuses'])
    assert result['ok']


def test_the_flood_under_the_drivers_frame_id_is_a_handled_case():
    """The report's case: it takes a domain of its own (the suite's lock files), stray frames under 'skin_link'."""
    [(area, case, fn)] = [c for c in stray_cases() if "as 'skin_link'" in c[1]]
    outcome = run_case(area, case, fn)
    assert outcome.result == HANDLED and 'stamp_back' in outcome.detail, outcome.detail
