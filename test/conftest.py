"""Shared test setup: keep the suite's graphs off the network unless a test asks, and give each a domain.

``SOCIAL_TOUCH_NETWORK=0`` makes every ``Context`` that is not told otherwise stay in
process, so in-process tests never meet another graph on this machine (another test
run, a robot). What joins DDS anyway (``social-touch demo`` and ``launch`` join because
they are told to) lands in a domain this test session holds, with discovery on this host
only. A test that wants DDS takes the ``dds_domain`` fixture: a domain id no other test
on the machine holds (a lock file per id); it sets ``ROS_DOMAIN_ID`` and
``ROS_AUTOMATIC_DISCOVERY_RANGE`` for the test and for the processes it starts, and lifts
``SOCIAL_TOUCH_NETWORK``.
"""

import os

import pytest
from dds_testing import allocate_domain

os.environ['SOCIAL_TOUCH_NETWORK'] = '0'
# Held until the session's process ends (the lock goes with its file descriptor).
_session_domain = allocate_domain()
os.environ['ROS_DOMAIN_ID'] = str(_session_domain.__enter__())
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
for _name in ('ROS_STATIC_PEERS', 'CYCLONEDDS_URI', 'ROS_LOCALHOST_ONLY'):
    os.environ.pop(_name, None)


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
