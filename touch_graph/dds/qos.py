"""ROS 2 QoS profiles as DDS QoS, the way rmw_cyclonedds maps them (``create_readwrite_qos``).

Depth 0 is 1; a RELIABLE writer blocks at most :data:`MAX_BLOCKING_S` (rmw: forever);
TRANSIENT_LOCAL keeps the same history; XCDR1 only; ignore-local PARTICIPANT (the runtime delivers
in process); user data ``typehash=RIHS01_...;``. :func:`qos_to_dict` gives ``{'history', 'depth',
'reliability', 'durability'}`` with enum values of :mod:`touch_graph.runtime.qos`.
"""

from __future__ import annotations

from typing import Any

from cyclonedds.core import Policy, Qos
from cyclonedds.util import duration

from ..offered_qos import adapted_policies
from ..runtime.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['MAX_BLOCKING_S', 'POLICY_NAMES', 'adapted_profile', 'dds_qos', 'describe_qos', 'qos_to_dict']

#: How long a reliable KEEP_ALL writer may block on a full history before the sample is dropped, s.
MAX_BLOCKING_S = 0.1

#: DDS QoS policy ids (as in dds_qos_policy_id_t) -> the names ROS 2 reports for them.
POLICY_NAMES = {
    1: 'USER_DATA', 2: 'DURABILITY', 3: 'PRESENTATION', 4: 'DEADLINE', 5: 'LATENCY_BUDGET', 6: 'OWNERSHIP',
    7: 'OWNERSHIP_STRENGTH', 8: 'LIVELINESS', 9: 'TIME_BASED_FILTER', 10: 'PARTITION', 11: 'RELIABILITY',
    12: 'DESTINATION_ORDER', 13: 'HISTORY', 14: 'RESOURCE_LIMITS', 15: 'ENTITY_FACTORY',
    16: 'WRITER_DATA_LIFECYCLE', 17: 'READER_DATA_LIFECYCLE', 18: 'TOPIC_DATA', 19: 'GROUP_DATA',
    20: 'TRANSPORT_PRIORITY', 21: 'LIFESPAN', 22: 'DURABILITY_SERVICE', 23: 'PROPERTY',
    24: 'TYPE_CONSISTENCY_ENFORCEMENT', 25: 'DATA_REPRESENTATION',
}
#: The policy id Cyclone reports when a remote endpoint's type is not assignable to ours.
TYPE_CONSISTENCY_POLICY = 24


def dds_qos(profile: QoSProfile, *, type_hash: str = '', user_data: str = '') -> Qos:
    """The DDS QoS of a reader or writer with ROS 2 QoS ``profile``.

    Args:
        type_hash: the type's ``RIHS01_...`` hash, announced in the user data ('' for none).
        user_data: user data to announce instead (``clientid=...;`` of a service client, as rmw_cyclonedds).
    """
    if profile.history == HistoryPolicy.KEEP_ALL:
        history: Any = Policy.History.KeepAll
    else:
        history = Policy.History.KeepLast(max(1, int(profile.depth)))
    policies = [
        history,
        Policy.Liveliness.Automatic(lease_duration=duration(infinite=True)),
        Policy.WriterDataLifecycle(autodispose=False),
        Policy.DataRepresentation(use_cdrv0_representation=True),
        Policy.IgnoreLocal.Participant,
    ]
    if profile.reliability == ReliabilityPolicy.BEST_EFFORT:
        policies.append(Policy.Reliability.BestEffort)
    else:
        policies.append(Policy.Reliability.Reliable(max_blocking_time=duration(seconds=MAX_BLOCKING_S)))
    if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        policies += [Policy.Durability.TransientLocal,
                     Policy.DurabilityService(cleanup_delay=0, history=history, max_samples=-1, max_instances=-1,
                                              max_samples_per_instance=-1)]
    else:
        policies.append(Policy.Durability.Volatile)
    if user_data:
        policies.append(Policy.Userdata(data=user_data.encode()))
    elif type_hash:
        policies.append(Policy.Userdata(data=f'typehash={type_hash};'.encode()))
    return Qos(*policies)


def qos_to_dict(qos: Any) -> dict[str, int]:
    """A discovered endpoint's DDS QoS as ``{'history', 'depth', 'reliability', 'durability'}``.

    Policies the remote did not announce are left out (another vendor's reader announces
    no history, for instance).
    """
    out: dict[str, int] = {}
    if qos is None:
        return out
    history = qos[Policy.History]
    if history is not None:
        if history == Policy.History.KeepAll:
            out.update(history=int(HistoryPolicy.KEEP_ALL), depth=0)
        else:
            out.update(history=int(HistoryPolicy.KEEP_LAST), depth=int(history.depth))
    reliability = qos[Policy.Reliability]
    if reliability is not None:
        out['reliability'] = int(ReliabilityPolicy.BEST_EFFORT if reliability == Policy.Reliability.BestEffort
                                 else ReliabilityPolicy.RELIABLE)
    durability = qos[Policy.Durability]
    if durability is not None:
        out['durability'] = int(DurabilityPolicy.TRANSIENT_LOCAL if durability == Policy.Durability.TransientLocal
                                else DurabilityPolicy.VOLATILE)
    return out


def _name(enum: Any, value: int | None) -> str:
    """The member name of ``value`` in ``enum``, or ``'UNKNOWN'`` (also for None: not announced)."""
    try:
        return enum(value).name
    except ValueError:
        return 'UNKNOWN'


def describe_qos(qos: dict[str, int], indent: str = '  ') -> list[str]:
    """The ``QoS profile:`` lines of ``ros2 topic info -v`` for a profile dict.

    >>> describe_qos({'history': 1, 'depth': 5, 'reliability': 2, 'durability': 2})
    ['  Reliability: BEST_EFFORT', '  History (Depth): KEEP_LAST (5)', '  Durability: VOLATILE']
    """
    history = _name(HistoryPolicy, qos.get('history'))
    if history == 'KEEP_LAST':
        history += f" ({qos.get('depth', '?')})"
    return [f'{indent}Reliability: {_name(ReliabilityPolicy, qos.get("reliability"))}',
            f'{indent}History (Depth): {history}',
            f'{indent}Durability: {_name(DurabilityPolicy, qos.get("durability"))}']


def adapted_profile(offered: list[dict[str, int]], depth: int = 10) -> QoSProfile:
    """A subscription profile that matches every publisher offering ``offered`` (ros2cli's ``choose_qos``;
    the rule is :func:`touch_graph.offered_qos.adapted_policies`).

    >>> adapted_profile([{'reliability': 2, 'durability': 2}, {'reliability': 1, 'durability': 2}]).reliability.name
    'BEST_EFFORT'
    >>> adapted_profile([]).reliability.name
    'RELIABLE'
    """
    reliability, durability = adapted_policies([(_name(ReliabilityPolicy, q.get('reliability')),
                                                 _name(DurabilityPolicy, q.get('durability'))) for q in offered])
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy[reliability], durability=DurabilityPolicy[durability])
