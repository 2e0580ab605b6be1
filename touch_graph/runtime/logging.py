"""Node loggers with rclpy's names: ``node.get_logger().info('...', throttle_duration_sec=1.0)``.

Lines go to stderr as rcutils prints them, ``[INFO] [1700000000.123456789] [bear.driver]: text``,
stamped with the graph's ROS time; ``once`` and ``throttle_duration_sec`` count in ROS time.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from enum import IntEnum
from typing import TextIO

__all__ = ['LoggingSeverity', 'RcutilsLogger', 'get_logger', 'set_default_level']


class LoggingSeverity(IntEnum):
    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


_default_level = LoggingSeverity.INFO
_stream_lock = threading.Lock()


def set_default_level(level: LoggingSeverity | str) -> None:
    """Level of loggers that have none of their own (``--log-level`` sets it)."""
    global _default_level
    _default_level = parse_level(level)


def parse_level(level: LoggingSeverity | str | int) -> LoggingSeverity:
    if isinstance(level, str):
        key = level.strip().upper()
        key = {'WARNING': 'WARN'}.get(key, key)
        if key not in LoggingSeverity.__members__:
            raise ValueError(f'unknown log level {level!r}; use debug, info, warn, error or fatal')
        return LoggingSeverity[key]
    return LoggingSeverity(level)


class RcutilsLogger:
    """A named logger; children are ``parent.child`` as in rclpy."""

    def __init__(self, name: str = '', clock_ns: Callable[[], int] | None = None,
                 stream: TextIO | None = None) -> None:
        self.name = name
        self._clock_ns = clock_ns or time.time_ns
        self._stream = stream
        self._level = LoggingSeverity.UNSET
        self._sink: Callable[..., None] | None = None  # (severity, name, text, file, function, line): /rosout
        self._seen_once: set[tuple[str, int]] = set()
        self._last_emit: dict[tuple[str, int], int] = {}
        self.counts = {severity: 0 for severity in LoggingSeverity}

    def get_child(self, name: str) -> RcutilsLogger:
        child = RcutilsLogger(f'{self.name}.{name}' if self.name else name, self._clock_ns, self._stream)
        child._level = self._level
        child._sink = self._sink
        return child

    def set_sink(self, sink: Callable[..., None] | None) -> None:
        """Also hand each emitted line to ``sink(severity, name, text, file, function, line)`` (a node's /rosout)."""
        self._sink = sink

    def set_level(self, level: LoggingSeverity | str) -> None:
        self._level = parse_level(level)

    def get_effective_level(self) -> LoggingSeverity:
        return self._level if self._level != LoggingSeverity.UNSET else _default_level

    def is_enabled_for(self, severity: LoggingSeverity) -> bool:
        return severity >= self.get_effective_level()

    def log(self, message: object, severity: LoggingSeverity, *, once: bool = False,
            throttle_duration_sec: float | None = None, skip_first: bool = False) -> bool:
        """Emit ``message`` unless filtered; returns whether it was printed."""
        if not self.is_enabled_for(severity):
            return False
        now = self._clock_ns()
        # The call site (caller's file and line) identifies a repeated message, as in rclpy.
        frame = sys._getframe(2)
        site = (frame.f_code.co_filename, frame.f_lineno)
        if once:
            if site in self._seen_once:
                return False
            self._seen_once.add(site)
        if throttle_duration_sec is not None or skip_first:
            last = self._last_emit.get(site)
            if last is None and skip_first:
                self._last_emit[site] = now
                return False
            if last is not None and throttle_duration_sec is not None \
                    and now - last < throttle_duration_sec * 1e9:
                return False
            self._last_emit[site] = now
        self.counts[severity] += 1
        sec, nsec = divmod(now, 1_000_000_000)
        line = f'[{severity.name}] [{sec}.{nsec:09d}] [{self.name}]: {message}\n'
        stream = self._stream or sys.stderr
        with _stream_lock:
            stream.write(line)
            stream.flush()
        if self._sink is not None:
            self._sink(severity, self.name, str(message), frame.f_code.co_filename, frame.f_code.co_name,
                       frame.f_lineno)
        return True

    def debug(self, message: object, **kwargs: object) -> bool:
        return self.log(message, LoggingSeverity.DEBUG, **kwargs)

    def info(self, message: object, **kwargs: object) -> bool:
        return self.log(message, LoggingSeverity.INFO, **kwargs)

    def warning(self, message: object, **kwargs: object) -> bool:
        return self.log(message, LoggingSeverity.WARN, **kwargs)

    warn = warning

    def error(self, message: object, **kwargs: object) -> bool:
        return self.log(message, LoggingSeverity.ERROR, **kwargs)

    def fatal(self, message: object, **kwargs: object) -> bool:
        return self.log(message, LoggingSeverity.FATAL, **kwargs)


def get_logger(name: str) -> RcutilsLogger:
    """A logger outside any node (``rclpy.logging.get_logger``)."""
    return RcutilsLogger(name)
