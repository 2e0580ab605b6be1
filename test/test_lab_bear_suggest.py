"""Suggested symbolic-gesture settings (touch_lab/bear/suggest.py): the rule on hand-made trials, and bad input
(a gesture with one trial, one never labelled, one whose trials activate no sensor, an unknown gesture) giving
a warning that names the gesture, never a traceback. Sessions are built in memory: 3.4 Hz cycles with the
active sensors set by hand (what :func:`touch_lab.bear.sessions.bear_trials` would measure).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.symbolic import GestureLibrary
from touch_graph.errors import ConfigError
from touch_lab.bear import suggest as sg
from touch_lab.bear.sessions import BearTrials
from touch_lab.bear.suggest_report import format_table, run_suggestions, write_config
from touch_lab.collect.session_bag import LabelRow, SessionRecording

RATE = 3.4
BODY = BodyMap.default()


def channel(name: str) -> int:
    return int(BODY.by_name(name).channel)


def session(person: str, trials: list[tuple[str, float, float, list[str]]], seconds: float = 80.0) -> BearTrials:
    """One person's session: per trial (gesture, start s, end s, sensors active from start + 0.3 s to end)."""
    times = np.arange(0.0, seconds, 1 / RATE)
    active = np.zeros((len(times), 64), dtype=bool)
    labels = []
    for gesture, start, end, sensors in trials:
        on = (times >= start + 0.3) & (times <= end)
        for name in sensors:
            active[on, channel(name)] = True
        labels.append(LabelRow(person, f'symbolic/{gesture}', 'normal', start, end))
    rec = SessionRecording(Path(f'bags/bear_{person}'), 'bear', True, 0, labels, {'/bear/frame': times}, {})
    fitted = np.asarray(BODY.fitted_mask(), dtype=bool)
    return BearTrials(rec, times, np.zeros((len(times), 64, 12), np.float32), np.zeros((len(times), 64), np.int8),
                      [], [], fitted, active, labels)


def run(runs: list[BearTrials]) -> tuple[dict, list[str]]:
    said: list[str] = []
    return run_suggestions(runs, GestureLibrary.default(BODY), BODY, None, None, said.append), said


HUG = ['chest_left', 'chest_right', 'belly_upper', 'back_upper', 'back_middle', 'side_left_upper',
       'side_right_upper']


def test_min_active_is_a_low_quantile_of_the_peaks_and_dwell_fits_the_hold_and_reaction_time():
    # Five hugs per person touching 5, 6, 7, 7, 7 of the filter (both sides), 6 s each.
    runs = [session(p, [('hug', 5.0 + 12 * i, 11.0 + 12 * i, HUG[:n]) for i, n in enumerate((5, 6, 7, 7, 7))])
            for p in ('p1', 'p2')]
    result, said = run(runs)
    s = result['suggestions']['hug']
    assert s.min_active == 5 and s.trials == 10 and s.people == 2
    # Reach is 0.3 s plus at most one cycle; the hold is about 5.7 s: the 2 s reaction time bounds the dwell.
    assert 2.0 - 0.3 - 1 / RATE - sg.DWELL_STEP_S <= s.dwell_s <= 2.0 - 0.3
    lopo = result['lopo']['suggested']['hug']
    assert lopo['trials'] == 10 and lopo['detected'] == 10 and lopo['median_start_latency_s'] <= 2.0 + 1e-9
    assert result['lopo']['configured']['hug']['detected'] == 10
    assert "gesture 'head_pat': never labelled" in ' '.join(said)


def test_min_active_rises_when_that_stops_matching_other_gestures_trials_but_few_of_its_own():
    # Tickles touch two side sensors (one each side); hugs touch 2 of the filter once, then 5+.
    sides = ['side_left_upper', 'side_right_upper']
    trials = [('hug', 5.0, 10.0, HUG[:2]), ('hug', 15.0, 20.0, HUG[:5]), ('hug', 25.0, 30.0, HUG[:6]),
              ('hug', 65.0, 70.0, HUG[:7]),
              ('tickle', 35.0, 40.0, sides), ('tickle', 45.0, 50.0, sides), ('tickle', 55.0, 60.0, sides)]
    runs = [session(p, trials) for p in ('p1', 'p2', 'p3')]
    stats = sg.gesture_stats(runs, [None] * 3, GestureLibrary.default(BODY), BODY, lambda m: None)
    assert sorted(stats['hug'].peaks) == [2] * 3 + [5] * 3 + [6] * 3 + [7] * 3
    assert stats['hug'].other_peaks.count(2) == 9          # the hug filter counts the tickles' two sensors
    assert stats['tickle'].other_peaks == []               # hug supersedes tickle: its trials do not count
    # The quantile says 2 (a quarter of the hugs peak at 2); 3 loses those 3 hugs but no longer matches 9 tickles.
    assert sg.suggest(stats['hug'], GestureLibrary.default(BODY)['hug']).min_active == 3


def test_bad_input_warns_naming_the_gesture_and_keeps_its_settings(tmp_path):
    trials = [('head_pat', 5.0, 9.0, ['head1']), ('head_pat', 15.0, 19.0, ['head2']),
              ('foot_rub', 25.0, 30.0, []), ('foot_rub', 35.0, 40.0, [])]
    runs = [session('p1', [*trials, ('handshake', 45.0, 50.0, ['paw_right_palm', 'paw_right_back'])]),
            session('p2', [*trials, ('hugg', 45.0, 50.0, HUG)])]
    result, said = run(runs)
    text = '\n'.join(said)
    assert "gesture 'handshake': one labelled trial (p1): too few to suggest from; its configured settings are kept" \
        in text
    assert "gesture 'foot_rub': no trial of it activated a sensor of its filter" in text
    assert "gesture 'feeding': never labelled" in text
    assert "bags/bear_p2 at 45.00 s: gesture 'hugg' is not a detectable gesture" in text and "'hug'" in text
    assert result['suggestions']['head_pat'].min_active == 1
    table = format_table(result, GestureLibrary.default(BODY), synthetic=True)
    assert 'handshake' in table and 'kept' in table and 'SYNTHETIC' in table

    out = tmp_path / 'suggested.yaml'
    changed = write_config(GestureLibrary.default(BODY).source, out, result['suggestions'], 'test\nheader', BODY)
    written = GestureLibrary.load(out, BODY)
    shipped = GestureLibrary.default(BODY)
    assert changed == 1 and written['head_pat'].dwell_s == result['suggestions']['head_pat'].dwell_s
    assert (written['handshake'].min_active, written['handshake'].dwell_s) == \
        (shipped['handshake'].min_active, shipped['handshake'].dwell_s)
    assert out.read_text().startswith('# test\n# header\n')


def test_a_user_config_is_never_overwritten(tmp_path):
    config = tmp_path / 'gestures.yaml'
    config.write_text(Path(GestureLibrary.default(BODY).source).read_text())
    before = config.read_text()
    suggestion = {'head_pat': sg.Suggestion('head_pat', 1, 0.5, 4, 2)}
    with pytest.raises(ConfigError, match='is the gesture config the suggestion is made from'):
        write_config(config, tmp_path / '.' / 'gestures.yaml', suggestion, 'x', BODY)
    assert config.read_text() == before


def test_one_person_is_suggested_from_but_not_checked():
    runs = [session('p1', [('head_pat', 5.0, 9.0, ['head1']), ('head_pat', 15.0, 19.0, ['head2', 'head3'])])]
    result, said = run(runs)
    assert result['lopo'] is None and result['suggestions']['head_pat'].min_active == 1
    assert any('needs trials of two people or more' in m for m in said)
    assert 'checked leave-one-person-out' not in format_table(result, GestureLibrary.default(BODY), True)


def test_train_refuses_to_write_the_suggestion_over_its_config_before_any_work(tmp_path, capsys):
    from touch_lab.cli.main import main as cli_main
    config = tmp_path / 'gestures.yaml'
    config.write_text(Path(GestureLibrary.default(BODY).source).read_text())
    assert cli_main(['train', 'bear', '--bags', str(tmp_path / 'no_bag'), '-o', str(tmp_path / 'm.npz'),
                     '--gestures-config', str(config), '--suggest-out', str(config)]) == 2
    assert 'is the gesture config the suggestion is made from' in capsys.readouterr().err
    assert not (tmp_path / 'm.npz').exists()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.integers(0, 10), min_size=1, max_size=30), min_size=0, max_size=8),
       st.lists(st.integers(0, 10), max_size=20))
def test_any_trials_give_settings_the_config_accepts_or_a_reason(counts, other_peaks):
    """Whatever the counts (cycles at 3.4 Hz, hug's ten-sensor filter), the suggestion loads or says why not."""
    g = GestureLibrary.default(BODY)['hug']
    stats = sg.GestureStats('hug', other_peaks=other_peaks)
    for i, c in enumerate(counts):
        c = np.minimum(np.array(c), len(g.channels))
        stats.people.append(f'p{i % 3}')
        stats.peaks.append(int(c.max()))
        stats.counts.append(c)
        stats.times.append(np.arange(len(c)) / RATE)
        stats.sides.append(np.ones(len(c), dtype=bool))
    s = sg.suggest(stats, g)
    if s.min_active is None:
        assert s.reason and s.dwell_s is None
    else:
        assert 1 <= s.min_active <= max(stats.peaks) and 0.0 <= s.dwell_s <= sg.REACTION_S
        steps = s.dwell_s / sg.DWELL_STEP_S
        assert abs(steps - round(steps)) < 1e-6   # a whole number of steps (rounded to 2 decimals: 1e-6 is ample)
        GestureLibrary.loads(f'gestures: {{hug: {{sensors: [{", ".join(g.sensor_names)}], min_active: '
                             f'{s.min_active}, dwell_s: {s.dwell_s}}}}}', BODY)


def test_train_evaluate_with_one_person_saves_the_model_and_says_why_no_evaluation(tmp_path, capsys):
    from touch_lab.cli.main import main as cli_main
    bags = tmp_path / 'sessions'
    assert cli_main(['collect', 'bear', '--simulate', '1', '--gestures', 'pat,rub', '--repetitions', '4',
                     '--pause-s', '2', '--seed', '3', '--out', str(bags)]) == 0
    model = tmp_path / 'm.npz'
    capsys.readouterr()
    assert cli_main(['train', 'bear', '--bags', *map(str, bags.iterdir()), '--evaluate', '-o', str(model)]) == 0
    assert '--evaluate holds out one person at a time and the bags hold 1' in capsys.readouterr().err
    assert model.exists()


def test_the_check_counts_false_starts_as_eval_bear_does():
    """One definition (touch_lab/bear/false_starts.py): every START of foot_rub no foot rub explains is false,
    each counted (two in one pet on a sole), by the touch it fell in, also outside every trial; a START in a
    rub on the sole (foot_rub's own subtype) is none."""
    sole = ['foot_left_sole']
    runs = []
    for p in ('p1', 'p2'):
        one = session(p, [('foot_rub', 5.0, 11.0, sole), ('foot_rub', 15.0, 21.0, sole)], seconds=75.0)
        touches = [(25.0, 29.0), (31.0, 35.0), (45.0, 51.0), (60.0, 66.0)]   # two in the pet, one in the rub, one out
        for lo, hi in touches:
            one.active[(one.times >= lo) & (one.times <= hi), channel('foot_left_sole')] = True
        one.labels[:] = [LabelRow(p, 'pet', 'normal', 24.5, 36.0), LabelRow(p, 'rub', 'normal', 44.5, 52.0)]
        runs.append(one)
    result, _said = run(runs)
    configured = result['lopo']['configured']['foot_rub']
    assert (configured['trials'], configured['detected']) == (4, 4)
    assert configured['false_starts'] == 6
    assert configured['false_starts_by_touch'] == {'subtype/pet': 4, 'none': 2}
    assert configured['false_starts_by_cause'] == {'other_gesture': 0, 'subtype_trial': 4, 'outside_trials': 2}


def test_the_hold_is_the_longest_episode_so_a_first_touch_that_lifts_does_not_make_the_dwell_zero():
    """foot_rub restarts its dwell at every lift (lift_s 0): a first touch of the sole (one scan, 0.59 s into the
    trial) that lifts for two scans is an episode of its own, the rub after it (from 1.47 s, 4.4 s long) the one
    that STARTs it."""
    runs = []
    for p in ('p1', 'p2'):
        one = session(p, [('foot_rub', 5.0 + 12 * k, 11.0 + 12 * k, ['foot_left_sole']) for k in range(3)])
        for k in range(3):
            one.active[(one.times > 5.6 + 12 * k) & (one.times < 6.3 + 12 * k), channel('foot_left_sole')] = False
        runs.append(one)
    result, _said = run(runs)
    reach, hold = result['stats']['foot_rub'].reach_hold(1, GestureLibrary.default(BODY)['foot_rub'].lift_s)
    assert np.all(np.abs(reach - 1.47) <= 1 / RATE) and np.all(hold >= 4.4 - 1 / RATE)
    # min(hold, 2 s - reach): the reach bounds it, not the one-scan first touch (a hold of 0 s)
    assert result['suggestions']['foot_rub'].dwell_s >= 2.0 - 1.47 - 1 / RATE - sg.DWELL_STEP_S > 0
