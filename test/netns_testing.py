"""Hosts for tests: network namespaces joined by veth pairs to a bridge, made and removed by the test.

:class:`NetnsLab` makes ``hosts`` namespaces (each with ``lo`` and one veth interface
``eth0`` at ``10.<net>.0.<i+1>/24``) and a hub namespace holding a Linux bridge that joins
their peers, so multicast discovery works between them as on one Ethernet segment. Names
carry the test process id and a random part, so tests running at once never collide;
:meth:`close` kills what runs in them and deletes every namespace (with its veths), also
after a failure. :func:`netns_unavailable` says why a machine cannot (no ``ip``, no
permission), for ``pytest.skip``.
"""

import contextlib
import os
import random
import shutil
import signal
import subprocess


def _ip(*args, check=True):
    return subprocess.run(['ip', *args], capture_output=True, text=True, check=check, timeout=30)


def netns_unavailable():
    """None if this machine lets us make network namespaces, else the reason."""
    if shutil.which('ip') is None:
        return "the 'ip' command (iproute2) is not installed"
    name = f'stprobe{os.getpid()}'
    result = _ip('netns', 'add', name, check=False)
    if result.returncode != 0:
        return f'cannot create a network namespace here: {result.stderr.strip()} (needs root or CAP_SYS_ADMIN)'
    _ip('netns', 'del', name, check=False)
    return None


class NetnsLab:
    """``hosts`` network namespaces on one bridged segment."""

    def __init__(self, hosts=3):
        tag = f'{os.getpid() % 100000}x{random.randrange(36 ** 3):03x}'
        self.net = random.randrange(100, 250)
        self.hub = f'sthub{tag}'
        self.hosts = [f'st{i}h{tag}' for i in range(hosts)]
        self.procs = []
        self._made = []
        try:
            self._make()
        except BaseException:
            self.close()
            raise

    def _make(self):
        _ip('netns', 'add', self.hub)
        self._made.append(self.hub)
        _ip('-n', self.hub, 'link', 'add', 'br0', 'type', 'bridge')
        # No IGMP querier on this segment: flood multicast instead of snooping it.
        _ip('-n', self.hub, 'link', 'set', 'br0', 'type', 'bridge', 'mcast_snooping', '0')
        _ip('-n', self.hub, 'link', 'set', 'br0', 'up')
        for i, host in enumerate(self.hosts):
            _ip('netns', 'add', host)
            self._made.append(host)
            _ip('link', 'add', 'eth0', 'netns', host, 'type', 'veth', 'peer', 'name', f'p{i}', 'netns', self.hub)
            _ip('-n', self.hub, 'link', 'set', f'p{i}', 'master', 'br0')
            _ip('-n', self.hub, 'link', 'set', f'p{i}', 'up')
            _ip('-n', host, 'addr', 'add', f'{self.address(i)}/24', 'dev', 'eth0')
            _ip('-n', host, 'link', 'set', 'eth0', 'up')
            _ip('-n', host, 'link', 'set', 'lo', 'up')

    def address(self, i):
        return f'10.{self.net}.0.{i + 1}'

    def run(self, i, argv, **popen_kwargs):
        """Start ``argv`` in host ``i``'s namespace; it is killed by :meth:`close`."""
        proc = subprocess.Popen(['ip', 'netns', 'exec', self.hosts[i], *argv], start_new_session=True,
                                **popen_kwargs)
        self.procs.append(proc)
        return proc

    def set_link(self, i, up):
        """Pull host ``i``'s cable (``up=False``) or plug it back in."""
        _ip('-n', self.hosts[i], 'link', 'set', 'eth0', 'up' if up else 'down')

    def close(self):
        for proc in self.procs:
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGTERM)
                    proc.wait(10)
                except (ProcessLookupError, subprocess.TimeoutExpired):
                    with contextlib.suppress(ProcessLookupError):
                        os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait(10)
        self.procs.clear()
        for name in reversed(self._made):
            _ip('netns', 'del', name, check=False)
        self._made.clear()
