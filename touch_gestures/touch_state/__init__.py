"""The Robotic Touch API (knight2009 VII): what the robot feels now, as a service and a latched topic.

- :mod:`.tracker`: :class:`TouchStateTracker`, the latest of every perception topic folded into
  one ``TouchState`` (plain class, no graph code);
- :mod:`.node`: ``touch_state``, serving ``/touch/get_state`` and publishing ``/touch/state``.
"""
