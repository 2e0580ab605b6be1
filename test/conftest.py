"""Shared test setup: keep the suite's graphs off the network unless a test asks, and give each a domain.

``SOCIAL_TOUCH_NETWORK=0`` makes every ``Context`` that is not told otherwise stay in
process, so in-process tests never meet another graph on this machine (another test
run, a robot). A test that wants DDS takes the ``dds_domain`` fixture: a domain id no
other test on the machine holds (a lock file per id), with discovery limited to this
host; it sets ``ROS_DOMAIN_ID`` and ``ROS_AUTOMATIC_DISCOVERY_RANGE`` for the test and
for the processes it starts, and lifts ``SOCIAL_TOUCH_NETWORK``.
"""

import os

import pytest
from dds_testing import allocate_domain

os.environ['SOCIAL_TOUCH_NETWORK'] = '0'


@pytest.fixture
def dds_domain(monkeypatch):
    """A DDS domain id of the test's own (int), set in the environment with LOCALHOST discovery."""
    with allocate_domain() as domain:
        monkeypatch.setenv('ROS_DOMAIN_ID', str(domain))
        monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        monkeypatch.delenv('ROS_STATIC_PEERS', raising=False)
        monkeypatch.delenv('CYCLONEDDS_URI', raising=False)
        monkeypatch.delenv('ROS_DISTRO', raising=False)
        monkeypatch.delenv('SOCIAL_TOUCH_NETWORK', raising=False)
        yield domain
