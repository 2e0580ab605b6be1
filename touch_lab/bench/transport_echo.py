"""The far end of ``social-touch bench transport``: a process that sends every ping back as a pong.

``python -c "$ECHO_MAIN" ours|raw KIND...`` (:data:`touch_lab.bench.transport.ECHO_MAIN`): ``ours`` echoes
``/bench/<kind>/ping`` to ``.../pong`` with a runtime node (decoded and encoded again) and
``.../ping_cdr`` to ``.../pong_cdr`` as bytes; ``raw`` echoes ``rt/bench_raw/<kind>/ping`` bytes and
``rt/bench_codec/<kind>/ping`` through our codec with plain cyclonedds. It prints ``ready`` once its
endpoints exist and exits when its stdin closes.
"""

from __future__ import annotations

import sys
import threading

from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from touch_graph import messages
from touch_graph.dds.cdds import WaitSet, delete_entity
from touch_graph.dds.config import domain_id, read_discovery
from touch_graph.dds.domain import acquire_domain, release_domain
from touch_graph.dds.idl import idl_struct
from touch_graph.dds.qos import dds_qos
from touch_graph.runtime import Context, Node, QoSProfile, SingleThreadedExecutor
from touch_lab.bench.timing import gc_paused

#: The kinds of message the bench measures -> their type.
KINDS = {
    'bear_frame': 'social_touch_msgs/msg/BearFrame',
    'patch_frame': 'social_touch_msgs/msg/PatchFrame',
    'skin_frame': 'social_touch_msgs/msg/SkinFrame',
    'gesture_event': 'social_touch_msgs/msg/GestureEvent',
}
#: Reliable, deep enough that a burst of the throughput test is not overwritten on the way.
BENCH_QOS = QoSProfile(depth=1000)


def _ours(kinds: list[str], stop: threading.Event) -> None:
    context = Context('wall', network=True)
    context.init()
    node = Node('bench_echo', context=context)
    for kind in kinds:
        cls = messages.get_message(KINDS[kind])
        pong = node.create_publisher(cls, f'/bench/{kind}/pong', BENCH_QOS)
        node.create_subscription(cls, f'/bench/{kind}/ping', pong.publish, BENCH_QOS)
        pong_cdr = node.create_publisher(cls, f'/bench/{kind}/pong_cdr', BENCH_QOS)
        node.create_subscription(cls, f'/bench/{kind}/ping_cdr', pong_cdr.publish, BENCH_QOS, raw=True)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    print('ready', flush=True)
    while not stop.is_set():
        executor.spin_once(0.1)
    context.shutdown()


def _raw(kinds: list[str], stop: threading.Event) -> None:
    domain = domain_id()
    acquire_domain(domain, read_discovery())
    participant = DomainParticipant(domain)
    qos = dds_qos(BENCH_QOS)
    waitset = WaitSet(participant._ref)
    routes = {}  # wait set key -> (reader, writer, type name to decode and encode again or None)
    keep = []
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    for kind in kinds:
        cls = idl_struct(KINDS[kind])
        for prefix, typename in (('bench_raw', None), ('bench_codec', KINDS[kind])):
            reader = DataReader(participant, Topic(participant, f'rt/{prefix}/{kind}/ping', cls), qos)
            writer = DataWriter(participant, Topic(participant, f'rt/{prefix}/{kind}/pong', cls), qos)
            condition = ReadCondition(reader, mask)
            key = len(routes) + 1
            waitset.attach(condition._ref, key)
            routes[key] = (reader._ref, writer._ref, typename)
            keep += [reader, writer, condition]
    print('ready', flush=True)
    while not stop.is_set():
        for key in waitset.wait(100_000_000):
            if key in routes:
                reader_ref, writer_ref, typename = routes[key]
                for data, info in ddspy_take(reader_ref, mask, 256):
                    if not info.valid_data:
                        continue  # a writer went away (as the runtime's readers skip it)
                    if typename is not None:
                        data = messages.serialize(messages.deserialize(data, typename))
                    ddspy_write(writer_ref, data)
    del keep
    delete_entity(participant)
    release_domain(domain)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    mode, kinds = argv[0], argv[1:]
    stop = threading.Event()

    def watch_stdin() -> None:
        sys.stdin.read()
        stop.set()
    threading.Thread(target=watch_stdin, daemon=True).start()
    with gc_paused():  # as in the measuring process: a collection is noise, not the transport's cost
        (_ours if mode == 'ours' else _raw)(kinds, stop)
    return 0

