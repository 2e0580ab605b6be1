"""The graph daemon: one participant that stays in a DDS domain so graph commands answer at once.

Joining a domain and waiting for discovery takes a command seconds; ros2cli avoids it with a
daemon (``ros2 daemon``) that keeps a node in the domain and answers ``ros2 topic list`` and
the like from its graph cache. This is the same design for ``social-touch``:

- :mod:`.address`: where a daemon listens, one per ``ROS_DOMAIN_ID`` and discovery setting
  (``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_STATIC_PEERS``, ``CYCLONEDDS_URI``, the GID layout
  of ``ROS_DISTRO``): a Unix socket in a directory only its user can enter, so it listens on
  this host only and never answers another user (ros2cli uses TCP port 11511 + domain id; a
  socket file also keeps clear of a ROS 2 daemon on the same machine), and the code version a
  daemon must match.
- :mod:`.server`: the daemon process. It keeps a hidden node in the domain and answers each
  query with its graph once complete by the rule a command of its own waits by
  (:func:`~touch_graph.dds.tool.wait_for_complete_graph`): a participant announced but whose
  nodes or endpoints are not known yet is waited for (bounded), so a node started just before
  the query is listed; and it announces itself more often than other participants of ours, so a
  Fast DDS node made after it (which waits to hear of older participants) finds it at once
  (:data:`.server.DAEMON_SPDP`). It runs until ``social-touch daemon stop``, a client of a newer
  installation, or two hours without a query (as ros2cli's).
- :mod:`.client`: what a command uses: the daemon's graph, starting the daemon in the background
  on first use, and a participant of the command's own when the daemon cannot be reached or
  ``--no-daemon`` is given (or ``SOCIAL_TOUCH_DAEMON=0``, as the test suite sets it).
"""
