"""The ``social-touch`` command (see :mod:`touch_graph.cli.main`)."""
