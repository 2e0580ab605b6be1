"""Can another local user's process inject ``/touch/haptic_command`` into our graph? Measured, not assumed.

Our side: a graph in this process on a DDS domain of its own (LOCALHOST discovery, the narrowest the
defaults allow) with a subscription to ``/touch/haptic_command``. The other side: a real process run
as another user (uid 65534, ``nobody``; needs root to switch, as CI has) that joins the same domain
and publishes commands. What arrives is what the defaults allow (docs/network.md: no DDS Security).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from typing import Any
from unittest.mock import patch

from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, SingleThreadedExecutor

__all__ = ['INTRUDER_UID', 'dds_injection']

INTRUDER_UID = 65534
INTRUDER = textwrap.dedent('''
    import sys, time
    from touch_graph.messages import get_message
    from touch_graph.runtime import Context, Node
    HapticCommand = get_message('HapticCommand')
    ctx = Context('wall', network=True); ctx.init()
    node = Node('intruder', context=ctx)
    pub = node.create_publisher(HapticCommand, '/touch/haptic_command', 10)
    sender = f'uid {__import__("os").getuid()}'
    for i in range(int(sys.argv[1])):
        pub.publish(HapticCommand(gesture='injected', command='release_grip', recogniser=sender))
        time.sleep(0.1)
    time.sleep(0.5)
    ctx.shutdown()
''')


def _as_intruder() -> None:
    os.setgroups([])
    os.setgid(INTRUDER_UID)
    os.setuid(INTRUDER_UID)


def _run_intruder(executor: Any, env: dict[str, str], messages: int, timeout_s: float,
                  switch_user: bool) -> tuple[Any, str]:
    """Start the intruder and spin our graph until it ends; (the process, its stderr), or (why, '') if it
    could not start."""
    try:
        proc = subprocess.Popen([sys.executable, '-c', INTRUDER, str(messages)], env=env, cwd='/tmp',
                                preexec_fn=_as_intruder if switch_user else None, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
    except PermissionError as err:
        return err.strerror or str(err), ''
    deadline = time.monotonic() + timeout_s
    while proc.poll() is None and time.monotonic() < deadline:
        executor.spin_for(0.2)
    executor.spin_for(0.5)
    if proc.poll() is None:
        proc.kill()
    return proc, proc.communicate(timeout=10)[1].decode(errors='replace')


def dds_injection(domain: int | None = None, messages: int = 40, timeout_s: float = 30.0) -> dict[str, Any]:
    """Run the intruder as uid 65534 (as root; otherwise, or when that user cannot run the interpreter, a
    process of our own uid stands in, and the result says so) and count what our subscription receives."""
    domain = domain if domain is not None else 150 + os.getpid() % 60
    env = {**os.environ, 'ROS_DOMAIN_ID': str(domain), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'HOME': '/tmp'}
    env.pop('CYCLONEDDS_URI', None)
    env.pop('ROS_STATIC_PEERS', None)
    env.pop('SOCIAL_TOUCH_NETWORK', None)
    restore_environ = patch.dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    restore_environ.start()
    for key in ('CYCLONEDDS_URI', 'ROS_STATIC_PEERS', 'SOCIAL_TOUCH_NETWORK'):
        os.environ.pop(key, None)
    got: list = []
    ctx = Context('wall', network=True)
    ctx.init()
    try:
        node = Node('commands', context=ctx)
        node.create_subscription(get_message('HapticCommand'), '/touch/haptic_command', got.append, 100)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        note = ''
        intruder_uid = INTRUDER_UID
        can_switch = os.geteuid() == 0
        proc, stderr = _run_intruder(executor, env, messages, timeout_s, switch_user=can_switch) if can_switch \
            else ('only root can start a process as another user', '')
        if isinstance(proc, str) or (proc.returncode != 0 and not got):
            # That user cannot run this interpreter or read the installed package here (e.g. under /root,
            # mode 0700): a process of our own uid stands in. DDS over UDP carries no user id.
            why = proc if isinstance(proc, str) else (stderr.strip().splitlines() or ['exit status'])[-1][:120]
            note = (f'uid {INTRUDER_UID} cannot run {sys.executable} here ({why}); a process of uid {os.getuid()} '
                    'stood in')
            intruder_uid = os.getuid()
            proc, stderr = _run_intruder(executor, env, messages, timeout_s, switch_user=False)
    finally:
        ctx.shutdown()
        restore_environ.stop()
    senders = sorted({m.recogniser for m in got})
    return {'measured': True, 'domain': domain, 'discovery': 'LOCALHOST', 'intruder_uid': intruder_uid, 'note': note,
            'our_uid': os.getuid(), 'sent': messages, 'received': len(got), 'senders': senders,
            'intruder_exit': proc.returncode, 'intruder_stderr': stderr.strip().splitlines()[-1:] if stderr else []}
