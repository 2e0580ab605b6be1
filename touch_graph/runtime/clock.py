"""Time, Duration and Clock with rclpy's names, and a context's time source for ROS time:
:class:`WallTimeSource` (the system clock) or :class:`SimTimeSource` (simulated time, ``rate`` times
real time; with ``rate=inf`` the executor jumps to the next timer when idle: deterministic).
"""

from __future__ import annotations

import math
import threading
import time
from enum import IntEnum
from functools import total_ordering
from typing import Any

from ..messages import get_message

__all__ = ['Clock', 'ClockType', 'Duration', 'SimTimeSource', 'Time', 'TimeSource', 'WallTimeSource']

_NS = 1_000_000_000


class ClockType(IntEnum):
    ROS_TIME = 1
    SYSTEM_TIME = 2
    STEADY_TIME = 3


@total_ordering
class Duration:
    """A span of time in integer nanoseconds (``Duration(seconds=0.5)``)."""

    __slots__ = ('_ns',)

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0) -> None:
        self._ns = round(seconds * _NS) + int(nanoseconds)

    @property
    def nanoseconds(self) -> int:
        return self._ns

    def to_msg(self) -> Any:
        sec, nsec = divmod(self._ns, _NS)
        return get_message('builtin_interfaces/msg/Duration')(sec=sec, nanosec=nsec)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Duration) and self._ns == other._ns

    def __lt__(self, other: Duration) -> bool:
        return self._ns < other._ns

    def __hash__(self) -> int:
        return hash(self._ns)

    def __repr__(self) -> str:
        return f'Duration(nanoseconds={self._ns})'


@total_ordering
class Time:
    """A point in time in integer nanoseconds since the epoch of its clock."""

    __slots__ = ('_ns', 'clock_type')

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0,
                 clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        self._ns = round(seconds * _NS) + int(nanoseconds)
        if self._ns < 0:
            raise ValueError(f'time must be >= 0, got {self._ns} ns')
        self.clock_type = clock_type

    @property
    def nanoseconds(self) -> int:
        return self._ns

    def seconds_nanoseconds(self) -> tuple[int, int]:
        return divmod(self._ns, _NS)

    def to_msg(self) -> Any:
        """A ``builtin_interfaces/msg/Time`` for a message header."""
        sec, nsec = divmod(self._ns, _NS)
        return get_message('builtin_interfaces/msg/Time')(sec=sec, nanosec=nsec)

    @classmethod
    def from_msg(cls, msg: Any, clock_type: ClockType = ClockType.ROS_TIME) -> Time:
        return cls(nanoseconds=msg.sec * _NS + msg.nanosec, clock_type=clock_type)

    def __add__(self, other: Duration) -> Time:
        if not isinstance(other, Duration):
            return NotImplemented
        return Time(nanoseconds=self._ns + other.nanoseconds, clock_type=self.clock_type)

    def __sub__(self, other: Time | Duration) -> Any:
        if isinstance(other, Time):
            return Duration(nanoseconds=self._ns - other._ns)
        if isinstance(other, Duration):
            return Time(nanoseconds=self._ns - other.nanoseconds, clock_type=self.clock_type)
        return NotImplemented

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Time) and self._ns == other._ns

    def __lt__(self, other: Time) -> bool:
        return self._ns < other._ns

    def __hash__(self) -> int:
        return hash(self._ns)

    def __repr__(self) -> str:
        return f'Time(nanoseconds={self._ns}, clock_type={self.clock_type.name})'


class TimeSource:
    """Where a context's ROS time comes from, and how the executor waits on it."""

    simulated = False

    def now_ns(self) -> int:
        raise NotImplementedError

    def wait_until(self, deadline_ns: int | None, wake: threading.Event, max_wall_s: float | None) -> None:
        """Block until ``deadline_ns`` (ROS time), ``wake`` is set or ``max_wall_s`` passes."""
        raise NotImplementedError


class WallTimeSource(TimeSource):
    """ROS time is the system clock."""

    now_ns = staticmethod(time.time_ns)  # no Python frame: read on every publish and every executor turn

    def wait_until(self, deadline_ns: int | None, wake: threading.Event, max_wall_s: float | None) -> None:
        wait = None if deadline_ns is None else max(0.0, (deadline_ns - time.time_ns()) / _NS)
        if max_wall_s is not None:
            wait = max_wall_s if wait is None else min(wait, max_wall_s)
        wake.wait(wait)


class SimTimeSource(TimeSource):
    """Simulated ROS time from ``start_s``, ``rate`` times real time (``math.inf``: as fast as possible).

    With an infinite rate, time stands still while there is work and jumps to the next
    deadline when there is none, so runs are deterministic.
    """

    simulated = True

    def __init__(self, start_s: float = 1_700_000_000.0, rate: float = math.inf) -> None:
        if not rate > 0:
            raise ValueError(f'simulated time rate must be > 0 (or inf), got {rate}')
        self.rate = rate
        self._start_ns = int(start_s * _NS)
        self._now_ns = self._start_ns
        self._wall0 = time.monotonic_ns()
        self._lock = threading.Lock()

    def now_ns(self) -> int:
        if math.isinf(self.rate):
            return self._now_ns
        return self._start_ns + int((time.monotonic_ns() - self._wall0) * self.rate)

    def advance_to(self, t_ns: int) -> None:
        """Move a fast simulated clock forward (never back)."""
        with self._lock:
            if t_ns > self._now_ns:
                self._now_ns = t_ns

    def wait_until(self, deadline_ns: int | None, wake: threading.Event, max_wall_s: float | None) -> None:
        if math.isinf(self.rate):
            if deadline_ns is not None:
                self.advance_to(deadline_ns)
            elif max_wall_s:
                wake.wait(max_wall_s)  # nothing scheduled: only another thread can bring work
            return
        wait = None if deadline_ns is None else max(0.0, (deadline_ns - self.now_ns()) / _NS / self.rate)
        if max_wall_s is not None:
            wait = max_wall_s if wait is None else min(wait, max_wall_s)
        wake.wait(wait)


class Clock:
    """``node.get_clock()``: ``now()`` gives a :class:`Time` of the context's time source."""

    def __init__(self, source: TimeSource, clock_type: ClockType = ClockType.ROS_TIME) -> None:
        self._source = source
        self.clock_type = clock_type

    def now(self) -> Time:
        if self.clock_type == ClockType.ROS_TIME:
            return Time(nanoseconds=self._source.now_ns(), clock_type=ClockType.ROS_TIME)
        if self.clock_type == ClockType.STEADY_TIME:
            return Time(nanoseconds=time.monotonic_ns(), clock_type=ClockType.STEADY_TIME)
        return Time(nanoseconds=time.time_ns(), clock_type=ClockType.SYSTEM_TIME)

    @property
    def ros_time_is_active(self) -> bool:
        return self._source.simulated
