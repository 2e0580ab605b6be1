"""Child process of test/test_dds_qos_conversion.py: many threads read built-in topics at once.

``python qos_conversion_hammer.py DOMAIN SECONDS [unguarded]``. One domain, one participant per
reader thread; a churn thread creates and deletes writers whose user data and partitions
say which topic they belong to (their lengths vary, so a pointer read in the wrong thread
shows). Each reader thread takes the publications' built-in topic (through
``touch_graph.dds.cdds.take_builtin``, or bare with ``unguarded``) and checks every sample's
QoS against its topic. Runs SECONDS, and on past them until the readers have checked
``ENOUGH`` samples in all (discovery of the churned writers can take seconds on a busy machine), at most
``LONGEST`` seconds. Prints one JSON line: ``checked``, ``mismatched``, ``errors``.
A separate process, because a race in the conversion can corrupt the heap.
"""

import json
import sys
import threading
import time
from dataclasses import dataclass

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter, Publisher
from cyclonedds.qos import Policy, Qos
from cyclonedds.topic import Topic

from touch_graph.dds.cdds import delete_entity, take_builtin
from touch_graph.dds.config import DiscoveryOptions
from touch_graph.dds.domain import acquire_domain, release_domain

READERS = 6
TOPICS = 24
ENOUGH = 100  # samples checked before the hammer may stop
LONGEST = 90.0  # s; the test's timeout is above it


@dataclass
class Hammer(IdlStruct, typename='hammer::Hammer'):
    value: int


def expected(topic_name: str) -> tuple[bytes, list[str]]:
    """The user data and partitions a writer of ``hammer_<i>`` carries."""
    i = int(topic_name.rsplit('_', 1)[1])
    return f'topic={topic_name};'.encode() + b'x' * (7 * i), [f'part{i}_{j}' for j in range(1 + i % 6)]


def churn(participant: DomainParticipant, stop: threading.Event) -> None:
    topics = [Topic(participant, f'hammer_{i}', Hammer) for i in range(TOPICS)]
    i = 0
    while not stop.is_set():
        topic = topics[i % TOPICS]
        user_data, partitions = expected(topic.name)
        publisher = Publisher(participant, qos=Qos(Policy.Partition(partitions)))
        writer = DataWriter(publisher, topic, qos=Qos(Policy.Userdata(user_data)))
        time.sleep(0.002)
        delete_entity(writer)
        delete_entity(publisher)
        i += 1


def read(participant: DomainParticipant, guarded: bool, stop: threading.Event, counts: dict,
         lock: threading.Lock) -> None:
    reader = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
    checked = mismatched = errors = 0
    while not stop.is_set():
        checked_before = checked
        try:
            samples = take_builtin(reader, 64) if guarded else reader.take(N=64)
        except Exception:
            errors += 1
            continue
        for sample in samples:
            if not sample.sample_info.valid_data or not sample.topic_name.startswith('hammer_'):
                continue
            user_data, partitions = expected(sample.topic_name)
            checked += 1
            if (Policy.Userdata not in sample.qos or sample.qos[Policy.Userdata].data != user_data
                    or Policy.Partition not in sample.qos
                    or list(sample.qos[Policy.Partition].partitions) != partitions):
                mismatched += 1
        with lock:
            counts['progress'] += checked - checked_before
    with lock:
        counts['checked'] += checked
        counts['mismatched'] += mismatched
        counts['errors'] += errors


def main() -> None:
    domain, seconds = int(sys.argv[1]), float(sys.argv[2])
    guarded = 'unguarded' not in sys.argv[3:]
    acquire_domain(domain, DiscoveryOptions(range='LOCALHOST'))
    participants = [DomainParticipant(domain) for _ in range(READERS + 1)]
    stop, lock = threading.Event(), threading.Lock()
    counts = {'checked': 0, 'mismatched': 0, 'errors': 0, 'progress': 0}
    threads = [threading.Thread(target=churn, args=(participants[0], stop))]
    threads += [threading.Thread(target=read, args=(p, guarded, stop, counts, lock)) for p in participants[1:]]
    for thread in threads:
        thread.start()
    start = time.monotonic()
    while True:
        time.sleep(0.1)
        elapsed = time.monotonic() - start
        with lock:
            progress = counts['progress']
        if (elapsed >= seconds and progress >= ENOUGH) or elapsed >= LONGEST:
            break
    stop.set()
    for thread in threads:
        thread.join(30)
    for participant in participants:
        delete_entity(participant)
    release_domain(domain)
    del counts['progress']
    print(json.dumps(counts), flush=True)


if __name__ == '__main__':
    main()
