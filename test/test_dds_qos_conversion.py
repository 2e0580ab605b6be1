"""Built-in topics read by many threads at once: every QoS is the one its entity was made with.

cyclonedds-python converts a C QoS through buffers the whole process shares, so each
participant's receive thread taking discovery samples at the same time read other threads'
pointers (a CI run died of it in dds_qget_userdata). ``touch_graph.dds.cdds`` serialises those
calls; this test hammers them from six threads in a child process (a heap corruption would
kill only the child) and checks every sample's user data and partitions against its topic.
Without the lock the same hammer reads samples wrong (38 of about 300, twice, on the machine it was written on:
``python test/qos_conversion_hammer.py DOMAIN 5 unguarded``).
"""

import json
import subprocess
import sys
from pathlib import Path

from touch_graph.dds.cdds import QOS_CONVERSION_LOCK, matched_endpoint

HERE = Path(__file__).resolve().parent


def test_threads_taking_builtin_topics_at_once_read_every_qos_right(dds_domain):
    child = subprocess.run([sys.executable, str(HERE / 'qos_conversion_hammer.py'), str(dds_domain), '3'],
                           capture_output=True, text=True, timeout=150)
    assert child.returncode == 0, child.stderr[-3000:]
    counts = json.loads(child.stdout.strip().splitlines()[-1])
    assert counts['errors'] == 0 and counts['mismatched'] == 0, counts
    assert counts['checked'] >= 100, counts  # the hammer did read samples of the churned writers


def test_matched_endpoint_holds_the_lock_and_says_none_for_a_gone_endpoint():
    seen = []

    def get_data(handle):
        seen.append(QOS_CONVERSION_LOCK.locked())
        raise KeyError(handle)  # cyclonedds raises when the handle no longer names a match

    assert matched_endpoint(get_data, 7) is None
    assert seen == [True] and not QOS_CONVERSION_LOCK.locked()
