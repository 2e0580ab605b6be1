"""Subscriptions that take the QoS their publishers offer, as ``ros2 topic echo`` and rosbag2 do.

RELIABLE only when every publisher offers RELIABLE, else BEST_EFFORT; TRANSIENT_LOCAL only when
every publisher offers it, else VOLATILE (ros2cli's ``choose_qos``). Unlike ros2cli, a subscription
that a publisher which joined later cannot match is made again with the profile now offered
(checked every ``check_period_s``); one that matches every publisher is never remade.
Works on rclpy and on our runtime (both answer ``get_publishers_info_by_topic``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

__all__ = ['AdaptedSubscription', 'OfferedQosSubscriptions', 'adapted_policies', 'offered_policies']

#: How often a node's adapted subscriptions are checked against the publishers' offers, s.
CHECK_PERIOD_S = 0.5


def _name(policy: Any) -> str:
    return getattr(policy, 'name', str(policy)).upper()


def offered_policies(endpoints: Iterable[Any]) -> list[tuple[str, str]]:
    """``(reliability, durability)`` names offered by publishers (rclpy ``TopicEndpointInfo`` or ours).

    Returns names such as ``('BEST_EFFORT', 'VOLATILE')``, comparable across backends.
    """
    return [(_name(ep.qos_profile.reliability), _name(ep.qos_profile.durability)) for ep in endpoints]


def adapted_policies(offered: list[tuple[str, str]]) -> tuple[str, str]:
    """The ``(reliability, durability)`` every publisher offering ``offered`` matches.

    >>> adapted_policies([('RELIABLE', 'TRANSIENT_LOCAL'), ('BEST_EFFORT', 'TRANSIENT_LOCAL')])
    ('BEST_EFFORT', 'TRANSIENT_LOCAL')
    >>> adapted_policies([('RELIABLE', 'TRANSIENT_LOCAL'), ('RELIABLE', 'VOLATILE')])
    ('RELIABLE', 'VOLATILE')
    >>> adapted_policies([])  # nobody offers yet: the default profile, remade when someone does
    ('RELIABLE', 'VOLATILE')
    """
    reliable = all(r == 'RELIABLE' for r, _ in offered)
    latched = bool(offered) and all(d == 'TRANSIENT_LOCAL' for _, d in offered)
    return 'RELIABLE' if reliable else 'BEST_EFFORT', 'TRANSIENT_LOCAL' if latched else 'VOLATILE'


def matches(requested: tuple[str, str], offered: tuple[str, str]) -> bool:
    """Whether a subscription requesting ``(reliability, durability)`` matches a publisher offering ``offered``.

    >>> matches(('RELIABLE', 'VOLATILE'), ('BEST_EFFORT', 'VOLATILE'))
    False
    >>> matches(('BEST_EFFORT', 'VOLATILE'), ('RELIABLE', 'TRANSIENT_LOCAL'))
    True
    """
    reliability, durability = requested
    return not ((reliability == 'RELIABLE' and offered[0] == 'BEST_EFFORT')
                or (durability == 'TRANSIENT_LOCAL' and offered[1] == 'VOLATILE'))


def _qos_module(node: Any) -> Any:
    """The QoS classes of the node's backend: ours for a :mod:`touch_graph.runtime` node, else rclpy's."""
    if any(cls.__module__.startswith('touch_graph.runtime') for cls in type(node).__mro__):
        from .runtime import qos  # (checked by module name: on a ROS 2 machine the runtime is not imported)
        return qos
    from rclpy import qos  # pragma: no cover - on a ROS 2 machine
    return qos  # pragma: no cover


class AdaptedSubscription:
    """A subscription of :class:`OfferedQosSubscriptions`; the DDS subscription underneath may be remade.

    Attributes:
        topic: the topic as asked for; subscription: the node's current subscription;
        policies: its ``(reliability, durability)``; remade: how many times it was made again.
    """

    def __init__(self, topic: str, make: Callable[[tuple[str, str]], Any], policies: tuple[str, str],
                 guessed: bool) -> None:
        self.topic = topic
        self._make = make
        self.policies = policies
        self.guessed = guessed  # chosen before any publisher was known
        self.subscription = make(policies)
        self.remade = 0
        self._dropped_before = 0

    @property
    def dropped(self) -> int:
        """Messages dropped from a full queue, over every subscription made for this one."""
        return self._dropped_before + getattr(self.subscription, 'dropped', 0)

    @property
    def received(self) -> int:
        return getattr(self.subscription, 'received', 0)


class OfferedQosSubscriptions:
    """A node's subscriptions whose QoS follows what the publishers of their topics offer.

    Args:
        node: an rclpy node or one of ours.
        check_period_s: how often to check the offers (a timer of the node); None: only on :meth:`check`.
    """

    def __init__(self, node: Any, check_period_s: float | None = CHECK_PERIOD_S) -> None:
        self.node = node
        self.subscriptions: list[AdaptedSubscription] = []
        self._qos = _qos_module(node)
        self.timer = node.create_timer(check_period_s, self.check) if check_period_s else None

    def offered(self, topic: str) -> list[tuple[str, str]]:
        """What the publishers of ``topic`` offer now."""
        return offered_policies(self.node.get_publishers_info_by_topic(topic))

    def profile(self, policies: tuple[str, str], depth: int) -> Any:
        """A keep-last ``depth`` profile of the node's backend with ``(reliability, durability)``."""
        q = self._qos
        return q.QoSProfile(depth=depth, history=q.HistoryPolicy.KEEP_LAST,
                            reliability=q.ReliabilityPolicy[policies[0]], durability=q.DurabilityPolicy[policies[1]])

    def create_subscription(self, msg_type: type, topic: str, callback: Callable[..., None], depth: int = 10,
                            **kwargs: Any) -> AdaptedSubscription:
        """Subscribe to ``topic`` with the QoS its publishers offer (``kwargs`` as ``create_subscription``'s,
        e.g. ``raw=True``)."""
        offered = self.offered(topic)

        def make(policies: tuple[str, str]) -> Any:
            return self.node.create_subscription(msg_type, topic, callback, self.profile(policies, depth), **kwargs)
        sub = AdaptedSubscription(topic, make, adapted_policies(offered), guessed=not offered)
        self.subscriptions.append(sub)
        return sub

    def check(self) -> int:
        """Remake the subscriptions that a publisher cannot match, or that were made before any publisher
        was known and now want another profile; the number remade."""
        remade = 0
        for sub in self.subscriptions:
            offered = self.offered(sub.topic)
            if not offered:
                continue
            wanted = adapted_policies(offered)
            stale = sub.guessed and wanted != sub.policies
            if not stale and all(matches(sub.policies, o) for o in offered):
                sub.guessed = False
                continue
            sub._dropped_before += getattr(sub.subscription, 'dropped', 0)
            self.node.destroy_subscription(sub.subscription)
            sub.subscription = sub._make(wanted)
            sub.policies, sub.guessed = wanted, False
            sub.remade += 1
            remade += 1
        return remade

    def destroy(self) -> None:
        """Destroy every subscription and the timer."""
        for sub in self.subscriptions:
            self.node.destroy_subscription(sub.subscription)
        self.subscriptions.clear()
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
            self.timer = None
