"""The outcome classes of a robustness case (docs/robustness.md), and the exception a case raises on lost data."""

__all__ = ['CASE_TIMEOUT_S', 'CLEAR', 'CRASH', 'HANDLED', 'HANG', 'LOST', 'TRACEBACK', 'WRONG', 'DataLost']

CLEAR, HANDLED, TRACEBACK, CRASH, WRONG = 'clear error', 'handled', 'traceback', 'crash', 'wrong'
HANG, LOST = 'hang', 'data lost'
#: Wall time after which a case counts as a hang (the longest, a 300 Hz flood over a real-time scene, takes ~1 min).
CASE_TIMEOUT_S = 300.0


class DataLost(Exception):
    """Raised by a case whose input was dealt with but something already recorded or saved was lost."""
