"""Launch substitutions: the $(...) grammar, each substitution, conditions, the restricted $(eval)."""

import contextlib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_graph.errors import ConfigError, LaunchError
from touch_graph.launch.safe_eval import MAX_WEIGHT, EvalError, safe_eval
from touch_graph.launch.substitutions import (
    Call,
    Location,
    Scope,
    TemplateSyntaxError,
    Text,
    evaluate,
    evaluate_condition,
    literal_text,
    parse_template,
    to_bool,
)

HERE = Location('scene.launch.yaml', 7)


def run(text, **configurations):
    return evaluate(parse_template(text), Scope(configurations=configurations, environ={}), HERE)


# ------------------------------------------------------------------------------------ grammar

def test_plain_text_is_one_literal_part():
    assert parse_template('bearsim://x?seed=3') == (Text('bearsim://x?seed=3'),)
    assert parse_template('') == ()
    assert literal_text(parse_template('a b')) == 'a b'


def test_substitutions_nest_and_mix_with_text():
    template = parse_template('/$(var ns)/$(env ROBOT $(var fallback))_x')
    assert template == (
        Text('/'), Call('var', ((Text('ns'),),)), Text('/'),
        Call('env', ((Text('ROBOT'),), (Call('var', ((Text('fallback'),),)),))), Text('_x'))
    assert literal_text(template) is None


def test_quoted_arguments_keep_spaces_and_nested_substitutions():
    assert run("$(eval '$(var a) + 2 * 3')", a='1') == '7'
    assert run('$(eval "\'$(var mode)\' == \'sim\'")', mode='sim') == 'True'
    assert run("$(env MISSING 'a default with spaces')") == 'a default with spaces'


def test_backslash_escapes_the_next_character_as_in_ros():
    assert run(r'cost \$(var x)') == 'cost $(var x)'
    assert run(r"$(env MISSING a\)b)") == 'a)b'
    assert run('price $5') == 'price $5'  # a lone $ is text


def test_extra_spaces_between_arguments_are_tolerated():
    assert run('$(equals  a   a )') == 'true'


@pytest.mark.parametrize(('text', 'fragment'), [
    ('$(var x', "is not closed; add ')'"),
    ('$(', "expected a substitution name after '$('"),
    ('$(var.x)', "unexpected '.'"),
    ("$(eval '1 + 2)", 'missing closing'),
    ('$(env a(b)', "'(' inside an unquoted argument"),
    ('$(vra x)', "unknown substitution '$(vra ...)' (did you mean 'var'?)"),
    ('$(command ls)', 'supported: all, and, anon'),
    ('$(var)', '$(var) takes 1 argument, got 0; usage: $(var NAME)'),
    ('$(equals a)', 'takes 2 arguments, got 1'),
    ('$(env a b c)', 'takes 1 to 2 arguments, got 3'),
])
def test_syntax_errors_say_what_and_where(text, fragment):
    with pytest.raises(TemplateSyntaxError) as info:
        parse_template(text)
    assert fragment in str(info.value)
    assert 'column' in str(info.value)


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet=st.characters(blacklist_characters='\\$'), max_size=40))
def test_text_without_escapes_or_dollars_is_its_own_value(text):
    assert run(text) == text


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet='$()\'" \\abvr-', max_size=30))
def test_any_text_parses_or_fails_with_a_syntax_error(text):
    with contextlib.suppress(TemplateSyntaxError):
        parse_template(text)


# ------------------------------------------------------------------------------ substitutions

def test_var_reads_configurations_and_names_the_line_when_unset():
    assert run('$(var robot)', robot='teddy') == 'teddy'
    with pytest.raises(LaunchError) as info:
        run('$(var rbot)', robot='teddy')
    message = str(info.value)
    assert message.startswith('scene.launch.yaml:7: ')
    assert "'rbot' is not declared" in message and "did you mean 'robot'" in message
    assert info.value.path == 'scene.launch.yaml' and info.value.line == 7


def test_env_and_optenv():
    scope = Scope(environ={'ROBOT': 'teddy'})
    assert evaluate(parse_template('$(env ROBOT)'), scope, HERE) == 'teddy'
    assert evaluate(parse_template('$(env NOPE fallback)'), scope, HERE) == 'fallback'
    assert evaluate(parse_template('[$(optenv NOPE)]'), scope, HERE) == '[]'
    with pytest.raises(LaunchError, match=r"environment variable 'NOPE' is not set; .*\$\(env NOPE DEFAULT\)"):
        evaluate(parse_template('$(env NOPE)'), scope, HERE)


def test_find_pkg_share_uses_the_lookup_and_reports_its_error_at_the_line(tmp_path):
    def lookup(package):
        if package == 'social_touch':
            return tmp_path
        raise ConfigError(f"package '{package}' not found")

    scope = Scope(find_package_share=lookup)
    assert evaluate(parse_template('$(find-pkg-share social_touch)/config'), scope, HERE) == f'{tmp_path}/config'
    with pytest.raises(LaunchError, match=r"scene.launch.yaml:7: \$\(find-pkg-share nope\): package 'nope'"):
        evaluate(parse_template('$(find-pkg-share nope)'), scope, HERE)


def test_dirname_and_filename_follow_the_current_file():
    scope = Scope(launch_file=Path('/robot/launch/demo.launch.yaml'))
    assert evaluate(parse_template('$(dirname)/x.yaml'), scope, HERE) == '/robot/launch/x.yaml'
    assert evaluate(parse_template('$(filename)'), scope, HERE) == '/robot/launch/demo.launch.yaml'
    with pytest.raises(LaunchError, match='only defined while a launch file is read'):
        evaluate(parse_template('$(dirname)'), Scope(), HERE)


def test_anon_is_a_valid_unique_name_stable_within_one_scope():
    scope = Scope()
    first = evaluate(parse_template('$(anon listener)'), scope, HERE)
    assert first == evaluate(parse_template('$(anon listener)'), scope, HERE)
    assert first != evaluate(parse_template('$(anon listener)'), Scope(), HERE)
    assert first.startswith('listener_') and first.replace('_', '').isalnum()
    assert evaluate(parse_template('$(anon my-node)'), scope, HERE).startswith('my_node_')


@pytest.mark.parametrize(('text', 'expected'), [
    ('$(not true)', 'false'), ('$(not off)', 'true'), ('$(not 0)', 'true'),
    ('$(and true yes)', 'true'), ('$(and true false)', 'false'),
    ('$(or false 1)', 'true'), ('$(or no off)', 'false'),
    ('$(any false false true)', 'true'), ('$(all true true false)', 'false'),
    ('$(equals sim sim)', 'true'), ('$(equals 1.0 1)', 'true'), ('$(equals True 1)', 'true'),
    ('$(equals a b)', 'false'), ('$(notequals a b)', 'true'), ('$(equals 0.1 0.10000000001)', 'true'),
])
def test_boolean_substitutions_match_ros(text, expected):
    assert run(text) == expected


def test_boolean_substitution_rejects_a_non_boolean():
    with pytest.raises(LaunchError, match=r"\$\(not\) expects a boolean .*got 'maybe'"):
        run('$(not maybe)')


def test_eval_is_restricted_and_errors_name_the_line():
    assert run("$(eval '$(var rate) * 2')", rate='12.5') == '25.0'
    with pytest.raises(LaunchError, match=r"scene.launch.yaml:7: \$\(eval .*call of .*__import__.* is not allowed"):
        run("$(eval \"__import__('os').system('true')\")")
    with pytest.raises(LaunchError, match='ZeroDivisionError'):
        run("$(eval '1 / 0')")


@pytest.mark.parametrize(('text', 'value'), [('true', True), ('True', True), ('1', True), ('FALSE', False),
                                             ('0', False), (' false ', False)])
def test_conditions_accept_what_ros_accepts(text, value):
    assert evaluate_condition(text, 'if', HERE) is value


@pytest.mark.parametrize('text', ['yes', '', 'on', '2', 'truee'])
def test_conditions_reject_anything_else(text):
    with pytest.raises(LaunchError, match=r"'if' must evaluate to true/false/1/0"):
        evaluate_condition(text, 'if', HERE)


def test_to_bool_reads_yaml_booleans():
    assert to_bool('Yes', 'x', HERE) is True
    with pytest.raises(LaunchError):
        to_bool('', 'x', HERE)


# ------------------------------------------------------------------------------- safe_eval

@pytest.mark.parametrize(('expression', 'value'), [
    ('1 + 2 * 3', 7), ('7 // 2', 3), ('7 % 4', 3), ('2 ** 10', 1024), ('-3 < -2 <= -2', True),
    ("'a' in 'abc'", True), ("'x' not in ('a', 'b')", True), ('[1, 2] == [1, 2]', True),
    ('not (1 and 0)', True), ('0 or 5', 5), ("'yes' if 3 > 2 else 'no'", 'yes'),
    ('round(pi, 3)', 3.142), ('math.sqrt(16)', 4.0), ('max(1, 4, 2)', 4), ('int("3") + float(2)', 5.0),
    ('None == None', True), ('abs(-2.5)', 2.5), ("len('abc')", 3),
    ("str(3) + 'x'", '3x'), ('math.inf > 1e308', True),
])
def test_safe_eval_allows_literals_arithmetic_logic(expression, value):
    assert safe_eval(expression) == value


@pytest.mark.parametrize(('expression', 'fragment'), [
    ("__import__('os')", "call of '__import__'"),
    ('open("/etc/passwd")', "call of 'open'"),
    ('().__class__.__bases__', "attribute '().__class__.__bases__'"),
    ('math.__dict__', "attribute 'math.__dict__'"),
    ('[x for x in range(3)]', 'ListComp is not allowed'),
    ('lambda: 1', 'Lambda is not allowed'),
    ('x', "name 'x' is not allowed"),
    ('{1: 2}', 'Dict is not allowed'),
    ('"abc"[0]', 'Subscript is not allowed'),
    ('1 is 1', 'comparison Is is not allowed'),
    ('9 ** 9 ** 9', 'exponent'),
    ("'a' * 10 ** 9", 'repetition'),
    ('[0] * 200000', 'repetition'),
    ('2 ** 1000 * 2 ** 1000 * 2 ** 1000 * 2 ** 1000 * 2 ** 1000', 'integer result larger'),
    ('max(1, key=abs)', 'keyword arguments'),
    ('1 +', 'not a valid expression'),
    ('(' * 3000 + ')' * 3000, 'longer than'),
    ('1 / 0', 'ZeroDivisionError'),
    ("'a' + 1", 'TypeError'),
    ('round(1.5, 10 ** 6)', 'round() digits'),
    # the robustness review: each ran for seconds or ended in MemoryError
    ('str([[0] * 99999] * 99999)', 'repetition'),
    ("'%*d' % (2000000000, 1)", "'%' formatting"),
    ('max([[0] * 99999] * 99999)', 'repetition'),
    ("[['x' * 99999]] * 2", 'too large'),
    ("['ab' * 30000] + ['cd' * 30000]", 'result too large'),
])
def test_safe_eval_rejects_code_and_huge_results(expression, fragment):
    with pytest.raises(EvalError) as info:
        safe_eval(expression)
    assert fragment in str(info.value)


@settings(max_examples=300, deadline=None)
@given(st.recursive(
    st.integers(-1000, 1000).map(str),
    lambda inner: st.tuples(inner, st.sampled_from(['+', '-', '*', '<', '==', 'and', 'or']), inner)
    .map(lambda t: f'({t[0]} {t[1]} {t[2]})'),
    max_leaves=12))
def test_safe_eval_agrees_with_python_on_integer_expressions(expression):
    assert safe_eval(expression) == eval(expression)  # the reference is Python itself on trusted input


@settings(max_examples=200, deadline=None)
@given(st.recursive(
    st.sampled_from(['0', "'ab'", '[0]', '[1, 2]', '999']),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from(['*', '+']), inner).map(lambda t: f'({t[0]} {t[1]} {t[2]})'),
        st.tuples(inner, st.integers(1, 10 ** 6)).map(lambda t: f'({t[0]} * {t[1]})'),
        inner.map(lambda t: f'[{t}, {t}]'), inner.map(lambda t: f'str({t})')),
    max_leaves=10))
def test_safe_eval_results_stay_within_the_weight_bound(expression):
    # Whatever the nesting and repetition, a result's text stays within a fixed multiple of
    # MAX_WEIGHT: so nothing computed from it (str, max, ==) can run away.
    with contextlib.suppress(EvalError):
        assert len(str(safe_eval(expression))) <= 25 * MAX_WEIGHT


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet='0123456789+-*/%().<>=! andortifelsNoneTrueFalse\'"abcxyz_[],', max_size=40))
def test_safe_eval_raises_only_eval_error_on_any_text(text):
    with contextlib.suppress(EvalError):
        safe_eval(text)
