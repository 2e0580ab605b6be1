"""docs/compiled-code.md: rendered from its figures, one section per compiled twin."""

import argparse

import pytest

from touch_graph.errors import ConfigError
from touch_lab.bench import compiled_code


def test_the_report_is_the_rendering_of_its_figures():
    assert compiled_code.FIGURES.exists(), 'run social-touch report compiled-code'
    assert compiled_code.REPORT.read_text() == compiled_code.render(compiled_code._load())


def test_the_cdr_section_states_the_saving_against_the_threshold():
    figures = compiled_code._load()['cdr']
    text = compiled_code.render_cdr(figures)
    before = figures['compiled_measured']
    saving = before['python_ceiling_percent_of_core'] - before['c_ceiling_percent_of_core']
    assert f'{saving:.3f} % of one core at most' in text
    assert ('under' if saving < compiled_code.THRESHOLD_PERCENT else 'over') + ' the 0.5 % threshold' in text


def test_cost_at_the_rates_is_the_sum_over_kinds_of_rate_times_time():
    kinds = {'a': {'python_encode_us': 2.0, 'python_decode_us': 3.0}, 'b': {'python_encode_us': 1.0,
                                                                            'python_decode_us': 1.0}}
    # 100 Hz x (2 + 3) us + 10 Hz x (1 + 1) us = 520 us per s = 0.052 % of one core
    assert compiled_code._percent_of_core(kinds, {'a': 100.0, 'b': 10.0}, 'python', 1) == pytest.approx(0.052)
    assert compiled_code._percent_of_core(kinds, {'a': 100.0, 'b': 10.0}, 'python', 3) == pytest.approx(0.114)


def test_an_unknown_section_is_refused_with_the_known_ones():
    parser = argparse.ArgumentParser()
    compiled_code.add_arguments(parser)
    with pytest.raises(ConfigError, match='known: cdr'):
        compiled_code.run(parser.parse_args(['nope']))
