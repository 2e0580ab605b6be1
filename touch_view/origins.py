"""Which requests the view's HTTP server and the Foxglove server answer: pages of other sites are refused.

Any page open in the user's browser can send requests to ``127.0.0.1``. Checks, for both servers:

- **Host** (DNS rebinding): accepted are no Host (not a browser), ``localhost``, an IP address, this
  machine's name, the configured ``host`` and the names of ``allowed_origins``.
- **Origin**: accepted are no Origin (desktop clients and scripts), the server's own page (an Origin
  whose authority is the request's Host), ``allowed_origins`` and, for Foxglove only,
  :data:`FOXGLOVE_ORIGINS` (the web app and Electron's ``file://``). ``Origin: null`` is refused.
- **Sec-Fetch-Site**: ``cross-site`` or ``same-site`` (a plain cross-site GET sends no Origin) is
  refused by the view.
- A request with two Host or two Origin headers is refused.

Neither server offers a request that changes anything, so these checks keep what the robot senses
from being read by a page of another site.
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Iterable
from urllib.parse import urlsplit

__all__ = ['FOXGLOVE_ORIGINS', 'OriginPolicy', 'normalise_origin']

#: Origins the Foxglove server accepts besides its own: the Foxglove web app, and Electron desktop apps.
FOXGLOVE_ORIGINS = ('https://app.foxglove.dev', 'file://')
_LOCAL_NAMES = {'localhost', 'localhost.localdomain', 'ip6-localhost'}


def normalise_origin(origin: str) -> str:
    """``scheme://host[:port]`` in lower case, the form browsers send (``file://`` stays as it is).

    >>> normalise_origin('HTTP://LocalHost:8080/'), normalise_origin('file://')
    ('http://localhost:8080', 'file://')
    """
    text = origin.strip().rstrip('/').lower()
    return 'file://' if text in ('file:', 'file://') else text


def _host_name(authority: str) -> str:
    """The host of ``host[:port]`` or ``[v6]:port``, lower case, without brackets."""
    authority = authority.strip().lower()
    if authority.startswith('['):
        return authority[1:authority.find(']')] if ']' in authority else authority[1:]
    return authority.rsplit(':', 1)[0] if authority.count(':') == 1 else authority


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class OriginPolicy:
    """The Host and Origin checks of one server (see the module's text).

    Args:
        host: the address the server listens on.
        allowed_origins: more origins to accept, e.g. ``http://robot.local:8080``.
        extra_origins: origins this kind of server accepts by default (:data:`FOXGLOVE_ORIGINS`).

    >>> policy = OriginPolicy('127.0.0.1')
    >>> policy.refusal(['127.0.0.1:8080'], []), policy.refusal(['localhost:8080'], ['http://localhost:8080'])
    (None, None)
    >>> policy.refusal(['evil.example:8080'], [])
    "Host 'evil.example:8080' is not this machine (a page of another site, re-pointed at 127.0.0.1?)"
    >>> policy.refusal(['127.0.0.1:8080'], ['https://evil.example'])
    "Origin 'https://evil.example' is a page of another site"
    """

    def __init__(self, host: str = '127.0.0.1', allowed_origins: Iterable[str] = (),
                 extra_origins: Iterable[str] = ()) -> None:
        self.origins = {normalise_origin(o) for o in (*extra_origins, *allowed_origins) if o.strip()}
        names = {*_LOCAL_NAMES, socket.gethostname().lower()}  # no DNS look-up: it may stall without a network
        if host and not _is_ip(host):
            names.add(host.lower())
        for origin in self.origins:
            parts = urlsplit(origin)
            if parts.hostname:
                names.add(parts.hostname)
        self.host_names = names
        self.refused = 0

    def host_ok(self, host_header: str | None) -> bool:
        """Is ``Host`` absent, an IP address, or a name of this machine or of an allowed origin?"""
        if host_header is None or not host_header.strip():
            return True
        name = _host_name(host_header)
        return _is_ip(name) or name in self.host_names

    def origin_ok(self, origin: str | None, host_header: str | None) -> bool:
        """Is ``Origin`` absent, the server's own page (same authority as Host), or an allowed one?"""
        if origin is None:
            return True
        origin = normalise_origin(origin)
        if origin in self.origins:
            return True
        parts = urlsplit(origin)
        if parts.scheme not in ('http', 'https') or not parts.netloc or not host_header:
            return False
        return parts.netloc == host_header.strip().lower()

    def refusal(self, hosts: list[str], origins: list[str], fetch_site: str | None = None) -> str | None:
        """Why a request is refused (counted in :attr:`refused`), or None when it may go on.

        Args:
            hosts, origins: every value of the request's Host and Origin headers (normally 0 or 1).
            fetch_site: its ``Sec-Fetch-Site`` (None where the check does not apply).
        """
        if len(hosts) > 1 or len(origins) > 1:
            self.refused += 1
            return 'more than one Host or Origin header'
        host_header = hosts[0] if hosts else None
        origin = origins[0] if origins else None
        if not self.host_ok(host_header):
            self.refused += 1
            return (f'Host {host_header[:100]!r} is not this machine (a page of another site, re-pointed at '
                    '127.0.0.1?)')
        if not self.origin_ok(origin, host_header):
            self.refused += 1
            return f'Origin {origin[:100]!r} is a page of another site'
        if fetch_site is not None and fetch_site.strip().lower() in ('cross-site', 'same-site') \
                and not (origin and normalise_origin(origin) in self.origins):
            self.refused += 1
            return f'Sec-Fetch-Site: {fetch_site[:20]}: a page of another site'
        return None
