"""Parameters the serving nodes (``touch_view``, ``foxglove_server``) declare alike."""

from __future__ import annotations

from typing import Any

from touch_graph.compat import ParameterDescriptor

__all__ = ['declare_listen_parameters', 'declare_read_only']


def declare_read_only(node: Any, name: str, default: Any, description: str) -> Any:
    """Declare a parameter read once at start (read-only, as it takes effect only then); its value."""
    return node.declare_parameter(name, default, ParameterDescriptor(description=description,
                                                                     read_only=True)).value


def declare_listen_parameters(node: Any, default_port: int) -> tuple[str, int]:
    """``host`` and ``port`` of a node that serves on localhost by default."""
    host = declare_read_only(node, 'host', '127.0.0.1', "address to listen on ('0.0.0.0': every interface)")
    port = declare_read_only(node, 'port', default_port, 'port to listen on (0: any free port)')
    return host, port
