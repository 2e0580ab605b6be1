"""A restricted evaluator for ``$(eval ...)``: literals, arithmetic, comparisons, logic.

ROS 2's ``PythonExpression`` calls Python's ``eval``; here only a side-effect-free subset of
:mod:`ast` is walked: literals, tuples and lists, ``+ - * / // % **``, ``- + not``,
comparisons, ``and``/``or``, ``x if c else y``, a few pure builtins and :mod:`math` (as
``sqrt`` or ``math.sqrt``). Every value's *weight* (characters of its strings, digits of its
integers, items of its lists, shared nested lists counted in full) stays under
:data:`MAX_WEIGHT`, so no expression can hang or exhaust memory; ``%`` formats no strings.

>>> safe_eval('2 * (3 + 4)'), safe_eval("'sim' == 'sim' and 20 / 4 > 3"), safe_eval('round(math.pi, 2)')
(14, True, 3.14)
>>> safe_eval("__import__('os')")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
touch_graph.launch.safe_eval.EvalError: call of '__import__' is not allowed; functions: abs, ...
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable
from typing import Any

__all__ = ['MAX_EXPRESSION_CHARS', 'MAX_INT_BITS', 'MAX_POWER_EXPONENT', 'MAX_WEIGHT', 'EvalError', 'safe_eval']

#: Longest expression accepted; also keeps :func:`ast.parse` far from its recursion limit.
MAX_EXPRESSION_CHARS = 2000
#: Largest ``|exponent|`` of ``**`` (``2 ** 1000`` is fine, ``9 ** 9 ** 9`` is not).
MAX_POWER_EXPONENT = 1000
#: Largest weight of a value (module doc); its ``str()`` has at most ~25 characters per unit.
MAX_WEIGHT = 100_000
#: Largest integer magnitude, in bits, an operation may produce.
MAX_INT_BITS = 4096


class EvalError(ValueError):
    """The expression is malformed, uses something not allowed, or fails to evaluate."""


_BINARY: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[Any], Any]] = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Not: operator.not_}
_COMPARE: dict[type, Callable[[Any, Any], Any]] = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.In: lambda a, b: a in b, ast.NotIn: lambda a, b: a not in b,
}
_BUILTINS: dict[str, Callable[..., Any]] = {
    'abs': abs, 'min': min, 'max': max, 'round': round, 'int': int, 'float': float, 'str': str, 'bool': bool,
    'len': len,
}
_MATH: dict[str, Any] = {name: getattr(math, name) for name in (
    'pi', 'e', 'tau', 'inf', 'nan', 'sqrt', 'exp', 'log', 'log10', 'log2', 'sin', 'cos', 'tan', 'asin', 'acos',
    'atan', 'atan2', 'degrees', 'radians', 'floor', 'ceil', 'fabs', 'hypot', 'isclose', 'isfinite', 'trunc')}
_CONSTANTS: dict[str, Any] = {'True': True, 'False': False, 'None': None}
_LITERAL_TYPES = (bool, int, float, str, type(None))


def _allowed_functions() -> str:
    return ', '.join(sorted({*_BUILTINS, *(name for name, value in _MATH.items() if callable(value))}))


def _allowed_constants() -> str:
    return ', '.join(sorted({*_CONSTANTS, *(name for name, value in _MATH.items() if not callable(value))}))


def _weight(value: Any, budget: int = MAX_WEIGHT) -> int:
    """The weight of ``value`` (module doc), counting stopped as soon as it passes ``budget``, so
    a list that holds one big list many times costs no more than ``budget`` steps."""
    if isinstance(value, str):
        return len(value)
    if isinstance(value, int) and not isinstance(value, bool):
        return 1 + value.bit_length() // 3  # about its decimal digits
    if isinstance(value, (list, tuple)):
        total = 1 + len(value)
        for item in value:
            if total > budget:
                break
            if isinstance(item, (str, int, list, tuple)):
                total += _weight(item, budget - total) - 1
        return total
    return 1


def _check_size(value: Any) -> Any:
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > MAX_INT_BITS:
        raise EvalError(f'integer result larger than 2**{MAX_INT_BITS}')
    if _weight(value) > MAX_WEIGHT:
        raise EvalError(f'result too large (more than {MAX_WEIGHT} characters, digits and items in all)')
    return value


def _binary(op: ast.operator, left: Any, right: Any) -> Any:
    func = _BINARY.get(type(op))
    if func is None:
        raise EvalError(f'operator {type(op).__name__} is not allowed; use + - * / // % **')
    if isinstance(op, ast.Pow) and isinstance(right, (int, float)) and abs(right) > MAX_POWER_EXPONENT:
        raise EvalError(f'exponent {right!r} is larger than {MAX_POWER_EXPONENT}')
    if isinstance(op, ast.Mod) and isinstance(left, str):
        raise EvalError("'%' formatting of strings is not allowed in $(eval); join strings with + and str()")
    if isinstance(op, ast.Mult):
        # Repetition ('ab' * n, [[0] * 9] * n) is bounded before it allocates.
        for seq, count in ((left, right), (right, left)):
            if isinstance(seq, (str, list, tuple)) and isinstance(count, int) and not isinstance(count, bool) \
                    and count > 0 and _weight(seq) * count > MAX_WEIGHT:
                raise EvalError(f'repetition would make a result too large (more than {MAX_WEIGHT} characters, '
                                'digits and items in all)')
    return _check_size(func(left, right))


def _call(node: ast.Call, walk: Callable[[ast.AST], Any]) -> Any:
    func = node.func
    if isinstance(func, ast.Name) and func.id in _BUILTINS:
        target = _BUILTINS[func.id]
    elif isinstance(func, ast.Name) and func.id in _MATH and callable(_MATH[func.id]):
        target = _MATH[func.id]
    elif isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == 'math' \
            and func.attr in _MATH and callable(_MATH[func.attr]):
        target = _MATH[func.attr]
    else:
        raise EvalError(f'call of {ast.unparse(func)!r} is not allowed; functions: {_allowed_functions()} '
                        '(math functions also as math.<name>)')
    if node.keywords:
        raise EvalError('keyword arguments are not allowed in $(eval)')
    args = [walk(arg) for arg in node.args]
    if target is round and len(args) == 2 and isinstance(args[1], int) and abs(args[1]) > 100:
        raise EvalError('round() digits must be within [-100, 100]')
    return _check_size(target(*args))


def _walk(node: ast.AST) -> Any:
    if isinstance(node, ast.Expression):
        return _walk(node.body)
    if isinstance(node, ast.Constant):
        if not isinstance(node.value, _LITERAL_TYPES):
            raise EvalError(f'literal {node.value!r} is not allowed; use numbers, strings, True/False/None')
        return node.value
    if isinstance(node, (ast.Tuple, ast.List)):
        items = [_walk(item) for item in node.elts]
        return _check_size(tuple(items) if isinstance(node, ast.Tuple) else items)
    if isinstance(node, ast.Name):
        if node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        if node.id in _MATH and not callable(_MATH[node.id]):
            return _MATH[node.id]
        raise EvalError(f'name {node.id!r} is not allowed; $(eval) knows literals, the constants '
                        f'{_allowed_constants()} and calls of {_allowed_functions()}')
    if isinstance(node, ast.Attribute):
        if isinstance(node.value, ast.Name) and node.value.id == 'math' and node.attr in _MATH \
                and not callable(_MATH[node.attr]):
            return _MATH[node.attr]
        raise EvalError(f'attribute {ast.unparse(node)!r} is not allowed; only math constants and functions')
    if isinstance(node, ast.BinOp):
        return _binary(node.op, _walk(node.left), _walk(node.right))
    if isinstance(node, ast.UnaryOp):
        func = _UNARY.get(type(node.op))
        if func is None:
            raise EvalError(f'operator {type(node.op).__name__} is not allowed')
        return func(_walk(node.operand))
    if isinstance(node, ast.BoolOp):
        # Short-circuit like Python: stop at the first operand that decides the result.
        value: Any = None
        for operand in node.values:
            value = _walk(operand)
            if isinstance(node.op, ast.And) and not value:
                return value
            if isinstance(node.op, ast.Or) and value:
                return value
        return value
    if isinstance(node, ast.Compare):
        left = _walk(node.left)
        for op, right_node in zip(node.ops, node.comparators, strict=True):
            compare = _COMPARE.get(type(op))
            if compare is None:
                raise EvalError(f'comparison {type(op).__name__} is not allowed; use == != < <= > >= in, not in')
            right = _walk(right_node)
            if not compare(left, right):
                return False
            left = right
        return True
    if isinstance(node, ast.IfExp):
        return _walk(node.body) if _walk(node.test) else _walk(node.orelse)
    if isinstance(node, ast.Call):
        return _call(node, _walk)
    raise EvalError(f'{type(node).__name__} is not allowed in $(eval); use literals, arithmetic, '
                    'comparisons, and/or/not and x if c else y')


def safe_eval(expression: str) -> Any:
    """Evaluate ``expression`` with the restricted grammar described in the module docstring.

    Returns:
        a bool, int, float, str, ``None``, tuple or list.

    Raises:
        EvalError: the expression does not parse, uses something not allowed, or fails
            (division by zero, a type error, a size limit).
    """
    if not isinstance(expression, str):
        raise EvalError(f'expression must be a string, got {type(expression).__name__}')
    if len(expression) > MAX_EXPRESSION_CHARS:
        raise EvalError(f'expression longer than {MAX_EXPRESSION_CHARS} characters')
    try:
        tree = ast.parse(expression.strip(), mode='eval')
    except (SyntaxError, ValueError, RecursionError, MemoryError) as err:
        detail = err.msg if isinstance(err, SyntaxError) else type(err).__name__
        raise EvalError(f'not a valid expression ({detail}): {expression!r}') from err
    try:
        return _walk(tree)
    except EvalError:
        raise
    except (ArithmeticError, TypeError, ValueError, RecursionError) as err:
        raise EvalError(f'{type(err).__name__}: {err}') from err
