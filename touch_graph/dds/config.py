"""Which DDS domain to join and how far to look for peers, read from the environment as ROS 2 reads it.

``ROS_DOMAIN_ID`` (0-232, default 0), ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (``SUBNET`` default,
``LOCALHOST``, ``OFF``, ``SYSTEM_DEFAULT``; another value is ``LOCALHOST`` with a warning, as in rcl;
``ROS_LOCALHOST_ONLY=1`` means ``LOCALHOST`` when unset), ``ROS_STATIC_PEERS`` (``;``-separated) and
``CYCLONEDDS_URI`` (appended). :func:`cyclone_config` builds rmw_cyclonedds' XML for them, with a
participant announcement every second so that a Fast DDS node started later finds it at once.

>>> read_discovery({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'ROS_STATIC_PEERS': '10.0.0.2;host-b'})
DiscoveryOptions(range='LOCALHOST', static_peers=('10.0.0.2', 'host-b'))
>>> print(cyclone_config(DiscoveryOptions('LOCALHOST', ('10.0.0.2',)), {}))
<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto\
</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><SPDPInterval>1s</SPDPInterval><Peers>\
<Peer address="localhost"/>\
<Peer address="10.0.0.2"/></Peers></Discovery></Domain></CycloneDDS>,
>>> domain_id({'ROS_DOMAIN_ID': '7'})
7
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass

from ..errors import GraphError

__all__ = ['MAX_DOMAIN_ID', 'RANGES', 'DiscoveryOptions', 'cyclone_config', 'domain_id', 'read_discovery']

#: rcl refuses larger ids: the RTPS port formula overflows 16 bits beyond 232.
MAX_DOMAIN_ID = 232
RANGES = ('SUBNET', 'LOCALHOST', 'OFF', 'SYSTEM_DEFAULT')
#: How often our participant announces itself to its unicast peers (Cyclone's Discovery/SPDPInterval).
SPDP_INTERVAL = '1s'

_log = logging.getLogger('touch_graph.dds')


@dataclass(frozen=True)
class DiscoveryOptions:
    """rmw's ``rmw_discovery_options_t``: automatic discovery range and static peers."""

    range: str = 'SUBNET'
    static_peers: tuple[str, ...] = ()


def domain_id(environ: Mapping[str, str] | None = None) -> int:
    """``ROS_DOMAIN_ID`` as an int (0 when unset or empty).

    Raises:
        GraphError: when it is not an integer in 0-232.
    """
    env = os.environ if environ is None else environ
    text = env.get('ROS_DOMAIN_ID', '').strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > MAX_DOMAIN_ID:
        raise GraphError(f'ROS_DOMAIN_ID must be an integer in 0-{MAX_DOMAIN_ID}, got {text!r}; unset it or use e.g. 0')
    return int(text)


def read_discovery(environ: Mapping[str, str] | None = None) -> DiscoveryOptions:
    """The discovery options of ``ROS_AUTOMATIC_DISCOVERY_RANGE`` / ``ROS_STATIC_PEERS`` (rcl's rules)."""
    env = os.environ if environ is None else environ
    text = env.get('ROS_AUTOMATIC_DISCOVERY_RANGE', '')
    if not text:
        text = 'LOCALHOST' if env.get('ROS_LOCALHOST_ONLY', '') == '1' else 'SUBNET'
    elif text not in RANGES:
        _log.warning("Invalid value '%s' specified for 'ROS_AUTOMATIC_DISCOVERY_RANGE', assuming localhost only "
                     '(expected one of %s)', text, ', '.join(RANGES))
        text = 'LOCALHOST'
    peers = tuple(p.strip() for p in env.get('ROS_STATIC_PEERS', '').split(';') if p.strip())
    return DiscoveryOptions(text, peers)


def cyclone_config(options: DiscoveryOptions, environ: Mapping[str, str] | None = None) -> str:
    """The Cyclone configuration rmw_cyclonedds uses for ``options``, then ``$CYCLONEDDS_URI``.

    With ``SYSTEM_DEFAULT`` or ``OFF`` static peers are ignored (with a warning), as there.
    """
    env = os.environ if environ is None else environ
    localhost = options.range == 'LOCALHOST'
    add_peers = options.range in ('SUBNET', 'LOCALHOST')
    no_multicast = options.range in ('LOCALHOST', 'OFF')
    if options.static_peers and not add_peers:
        _log.warning('%d static peers were specified, but discovery is %s, so they are ignored',
                     len(options.static_peers), options.range)
    config = ''
    if localhost or add_peers or no_multicast:
        config = '<CycloneDDS><Domain>'
        if no_multicast:
            config += '<General><AllowMulticast>false</AllowMulticast></General>'
        if options.range == 'OFF':
            # A tag nobody else has: nothing is discovered (rmw_cyclonedds does the same).
            config += f'<Discovery><ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_{os.getpid()}</Tag>'
        else:
            # Peers hear our participant again every SPDP_INTERVAL: a Fast DDS node (rclpy's default) on
            # LOCALHOST announces itself by multicast only, so it learns of a participant that started
            # before it only from that participant's next announcement (Cyclone's default interval is long).
            config += '<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32' \
                      f'</MaxAutoParticipantIndex><SPDPInterval>{SPDP_INTERVAL}</SPDPInterval>'
        peers = (['localhost'] if localhost else []) + (list(options.static_peers) if add_peers else [])
        if peers:
            from xml.sax.saxutils import quoteattr  # here: the graph daemon's clients read no XML
            config += '<Peers>' + ''.join(f'<Peer address={quoteattr(p)}/>' for p in peers) + '</Peers>'
        config += '</Discovery></Domain></CycloneDDS>,'
    return config + env.get('CYCLONEDDS_URI', '')
