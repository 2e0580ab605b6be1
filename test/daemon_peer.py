"""How often ``social-touch node list`` lists one of our nodes started 0.1 s before the call (through the daemon).

Each node runs in a process of its own, on our runtime (Cyclone DDS); the process imports
everything first and makes its node only when told, so "started" is the node's creation, as
``test/ros2_peer.py`` measures it for a real rclpy node. The graph daemon of the domain is started
first and stopped at the end::

    .venv/bin/python test/daemon_peer.py 20 72
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time

#: A node of ours that is made when a line arrives on stdin ("ready" once it exists), then spins until stdin
#: closes.
NODE = textwrap.dedent('''
    import sys
    import threading
    from touch_graph.compat import get_message
    from touch_graph.runtime import Context, Node, SingleThreadedExecutor
    String = get_message('std_msgs/msg/String')
    context = Context('wall', network=True)
    print('loaded', flush=True)
    sys.stdin.readline()
    context.init([])
    node = Node(sys.argv[1], context=context)
    pub = node.create_publisher(String, '/late_chatter', 10)
    print('ready', flush=True)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    closed = threading.Event()  # stdin closed: stop
    threading.Thread(target=lambda: (sys.stdin.read(), closed.set()), daemon=True).start()
    try:
        while not closed.is_set():
            executor.spin_once(0.1)
    finally:
        context.try_shutdown()
''')


def load_node(name: str, env: dict[str, str]) -> subprocess.Popen:
    """A process that has imported our runtime and makes node ``name`` on the next line of its stdin."""
    proc = subprocess.Popen([sys.executable, '-c', NODE, name], env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    if proc.stdout.readline().strip() != 'loaded':
        proc.kill()
        raise RuntimeError(f'the node process for {name} did not load')
    return proc


def start_node(proc: subprocess.Popen) -> None:
    """Make the node of a :func:`load_node` process; returns once it exists."""
    proc.stdin.write('\n')
    proc.stdin.flush()
    if proc.stdout.readline().strip() != 'ready':
        raise RuntimeError('the node did not start')


def stop(proc: subprocess.Popen) -> None:
    if proc.stdin:
        proc.stdin.close()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def node_list(env: dict[str, str]) -> list[str]:
    """``social-touch node list`` as a user runs it."""
    out = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'node', 'list'], env=env, capture_output=True,
                         text=True, timeout=60).stdout
    return out.split()


def listed_of(tries: int, env: dict[str, str]) -> int:
    """How many of ``tries`` ``node list`` runs list a node of ours created 0.1 s before each."""
    listed = 0
    loaded = load_node('late_talker_0', env)
    for i in range(tries):
        proc, loaded = loaded, (load_node(f'late_talker_{i + 1}', env) if i + 1 < tries else None)
        try:
            start_node(proc)
            time.sleep(0.1)
            listed += f'/late_talker_{i}' in node_list(env)
        finally:
            stop(proc)
    return listed


def domain_env(domain: int) -> dict[str, str]:
    """The environment of a graph in ``domain`` on this host, the daemon allowed."""
    env = {k: v for k, v in os.environ.items() if k not in ('SOCIAL_TOUCH_NETWORK', 'ROS_STATIC_PEERS',
                                                            'CYCLONEDDS_URI', 'ROS_LOCALHOST_ONLY')}
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', SOCIAL_TOUCH_DAEMON='1')
    return env


def daemon(env: dict[str, str], action: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'daemon', action], env=env,
                          capture_output=True, text=True, timeout=60)


if __name__ == '__main__':
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    env = domain_env(int(sys.argv[2]) if len(sys.argv) > 2 else 72)
    daemon(env, 'start')
    try:
        print(f'social-touch node list (graph daemon) listed a node of ours started 0.1 s before: '
              f'{listed_of(n, env)} of {n}')
    finally:
        daemon(env, 'stop')
