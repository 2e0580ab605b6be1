"""See what the robot feels: a live web view of the touch graph, and the graph in Foxglove.

- :mod:`touch_view.node`: ``touch_view``, a node of the graph that subscribes to the perception
  topics and serves a page on localhost (:mod:`touch_view.server`) showing them live;
  ``social-touch view`` runs it, ``social-touch demo --view`` adds it to the demo scene.
- :mod:`touch_view.foxglove_node`: ``foxglove_server``, every topic over the Foxglove WebSocket
  protocol (foxglove-sdk), with the patch and skin maps as images; ``social-touch foxglove``.

Only the runtime is imported (touch_graph, and message-level things of touch_driver): a view
runs beside a robot's graph, never the simulator.
"""

from .errors import ViewError

__all__ = ['ViewError']
