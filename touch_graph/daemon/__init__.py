"""The graph daemon (as ``ros2 daemon``): one participant that stays in a DDS domain so graph commands answer at once.

:mod:`.address`: where a daemon listens (a Unix socket per domain and discovery setting, in a
directory only its user can enter) and the code version it must match; :mod:`.server`: the
daemon process; :mod:`.client`: what a command uses (the daemon's graph, starting it on first
use, or a participant of its own with ``--no-daemon`` or ``SOCIAL_TOUCH_DAEMON=0``).
"""
