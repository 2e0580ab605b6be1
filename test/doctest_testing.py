"""The doctest harnesses' one check: every example of a module passes, and there is at least one."""

import doctest
from types import ModuleType


def check_doctests(module: ModuleType) -> doctest.TestResults:
    """Run ``module``'s examples (``...`` matches anything); fail on a failed example or on none run.

    A module listed for its doctests that has none (its examples removed or moved) fails here instead
    of passing while nothing was checked.
    """
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0, f'{result.failed} of {result.attempted} examples of {module.__name__} failed'
    assert result.attempted > 0, f'{module.__name__} has no example: nothing was checked (take it off the list)'
    return result
