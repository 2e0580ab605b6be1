"""Quality of service, with rclpy.qos's names.

In process, ``depth`` bounds each subscription's queue (the oldest message is dropped and
counted), TRANSIENT_LOCAL hands a publisher's last ``depth`` messages to later subscriptions,
and a publisher delivers only to subscriptions whose QoS it satisfies (:func:`incompatible_policy`),
as DDS does between processes.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

__all__ = [
    'DurabilityPolicy', 'HistoryPolicy', 'QoSDurabilityPolicy', 'QoSHistoryPolicy', 'QoSProfile',
    'QoSReliabilityPolicy', 'ReliabilityPolicy', 'incompatible_policy', 'qos_profile_from',
    'qos_profile_parameter_events',
    'qos_profile_rosout_default', 'qos_profile_sensor_data', 'qos_profile_services_default',
    'qos_profile_system_default',
]


class HistoryPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2


class ReliabilityPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class DurabilityPolicy(IntEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


QoSHistoryPolicy = HistoryPolicy
QoSReliabilityPolicy = ReliabilityPolicy
QoSDurabilityPolicy = DurabilityPolicy

#: Queue bound used for KEEP_ALL, so that memory stays bounded on long runs.
KEEP_ALL_LIMIT = 10_000


@dataclass
class QoSProfile:
    """A QoS profile; ``QoSProfile(depth=10)`` as in rclpy."""

    depth: int = 10
    history: HistoryPolicy = HistoryPolicy.KEEP_LAST
    reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE
    durability: DurabilityPolicy = DurabilityPolicy.VOLATILE

    def __post_init__(self) -> None:
        if not isinstance(self.depth, int) or isinstance(self.depth, bool) or self.depth < 0:
            raise ValueError(f'QoS depth must be an int >= 0, got {self.depth!r}')
        if self.history == HistoryPolicy.KEEP_LAST and self.depth == 0:
            raise ValueError('QoS depth 0 with KEEP_LAST keeps nothing; use depth >= 1 or KEEP_ALL')

    @property
    def queue_bound(self) -> int:
        return KEEP_ALL_LIMIT if self.history == HistoryPolicy.KEEP_ALL else self.depth


qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
qos_profile_system_default = QoSProfile(depth=10)
#: rmw's ``rmw_qos_profile_services_default``: reliable, volatile, keep last 10.
qos_profile_services_default = QoSProfile(depth=10)
#: rmw's ``rmw_qos_profile_parameter_events``: reliable, volatile, keep last 1000.
qos_profile_parameter_events = QoSProfile(depth=1000)
#: rcl's ``rcl_qos_profile_rosout_default``: reliable, transient local, keep last 1000 (its
#: 10 s lifespan is not modelled: late joiners get the last 1000 lines).
qos_profile_rosout_default = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def incompatible_policy(offered: QoSProfile, requested: QoSProfile) -> str | None:
    """The policy (rclpy's ``QoSPolicyKind`` name) that keeps a publisher offering ``offered`` from a
    subscription requesting ``requested``, as DDS matches them; None when they match.

    SYSTEM_DEFAULT is the rmw default: RELIABLE, VOLATILE.

    >>> incompatible_policy(qos_profile_sensor_data, QoSProfile(depth=10))
    'RELIABILITY'
    >>> incompatible_policy(QoSProfile(depth=1), QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    'DURABILITY'
    >>> incompatible_policy(QoSProfile(depth=1), qos_profile_sensor_data) is None
    True
    """
    best_effort = offered.reliability == ReliabilityPolicy.BEST_EFFORT
    if best_effort and requested.reliability != ReliabilityPolicy.BEST_EFFORT:
        return 'RELIABILITY'
    durable = offered.durability == DurabilityPolicy.TRANSIENT_LOCAL
    if not durable and requested.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        return 'DURABILITY'
    return None


def qos_profile_from(qos: QoSProfile | int) -> QoSProfile:
    """Accept a depth or a profile, as ``create_publisher`` does."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, int) and not isinstance(qos, bool):
        return QoSProfile(depth=qos)
    raise TypeError(f'qos_profile must be a QoSProfile or an int depth, got {qos!r}')
