"""One Cyclone domain per domain id and process, made with ROS 2's discovery configuration and deleted
with its last participant, as rmw_cyclonedds does; a second context must ask for the same options.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from cyclonedds.core import DDSException
from cyclonedds.domain import Domain

from ..errors import GraphError
from .cdds import delete_entity
from .config import DiscoveryOptions, cyclone_config

__all__ = ['acquire_domain', 'release_domain']


@dataclass
class _Entry:
    domain: Domain
    options: DiscoveryOptions
    config: str
    users: int = 0


_lock = threading.Lock()
_domains: dict[int, _Entry] = {}


def acquire_domain(domain_id: int, options: DiscoveryOptions) -> str:
    """Create (or share) the process's domain ``domain_id``; returns the configuration used.

    Raises:
        GraphError: the domain exists in this process with other discovery options, or
            Cyclone refuses the configuration (a bad ``CYCLONEDDS_URI``, no usable network).
    """
    with _lock:
        entry = _domains.get(domain_id)
        if entry is not None:
            if entry.options != options:
                raise GraphError(f'domain {domain_id} is already joined by this process with discovery '
                                 f'{entry.options}; cannot join it again with {options} (ROS 2 refuses this too)')
            entry.users += 1
            return entry.config
        config = cyclone_config(options)
        try:
            domain = Domain(domain_id, config or None)
        except DDSException as err:
            raise GraphError(f'cannot create DDS domain {domain_id} ({err}); configuration: {config!r} '
                             '(check CYCLONEDDS_URI, ROS_AUTOMATIC_DISCOVERY_RANGE and ROS_STATIC_PEERS)') from err
        _domains[domain_id] = _Entry(domain, options, config, users=1)
        return config


def release_domain(domain_id: int) -> None:
    """Drop one user of the domain; the last one deletes it (and Cyclone's threads for it)."""
    with _lock:
        entry = _domains.get(domain_id)
        if entry is None:
            return
        entry.users -= 1
        if entry.users <= 0:
            del _domains[domain_id]
            delete_entity(entry.domain)
