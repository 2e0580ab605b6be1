"""ROS 2 names: validation, expansion and remapping, as rcl does them.

>>> expand_topic_name('frame', 'driver', '/bear')
'/bear/frame'
>>> expand_topic_name('~/status', 'driver', '/bear')
'/bear/driver/status'
>>> expand_topic_name('/touch/gesture', 'driver', '/bear')
'/touch/gesture'
>>> expand_topic_name('~', 'driver', '/')
'/driver'
>>> RemapRule.parse('frame:=/patch/frame').target
'/patch/frame'
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import GraphError

__all__ = ['RemapRule', 'apply_remaps', 'expand_topic_name', 'fully_qualified_name', 'normalize_namespace',
           'validate_node_name']

_TOKEN = r'[A-Za-z_][A-Za-z0-9_]*'
_NODE_NAME = re.compile(rf'^{_TOKEN}$')
_NAMESPACE = re.compile(rf'^(/|(/{_TOKEN})+)$')
_TOPIC = re.compile(rf'^(~|~/{_TOKEN}(/{_TOKEN})*|/?{_TOKEN}(/{_TOKEN})*)$')


def validate_node_name(name: str) -> str:
    """Return ``name`` if it is a valid ROS 2 node name, else raise GraphError."""
    if not isinstance(name, str) or not _NODE_NAME.match(name):
        raise GraphError(f'invalid node name {name!r}: a node name is letters, digits and underscores, '
                         'not starting with a digit (e.g. "bear_driver")')
    return name


def normalize_namespace(namespace: str | None) -> str:
    """``None``/``''`` -> ``'/'``; a relative namespace is made absolute; validated.

    >>> normalize_namespace('bear'), normalize_namespace(''), normalize_namespace('/a/b/')
    ('/bear', '/', '/a/b')
    """
    ns = namespace or '/'
    if not ns.startswith('/'):
        ns = '/' + ns
    if len(ns) > 1:
        ns = ns.rstrip('/')
    if not _NAMESPACE.match(ns):
        raise GraphError(f'invalid namespace {namespace!r}: tokens of letters, digits and underscores '
                         'separated by "/", e.g. "/robot/bear"')
    return ns


def fully_qualified_name(name: str, namespace: str) -> str:
    """``/ns/name`` (``/name`` in the root namespace)."""
    return f'/{name}' if namespace == '/' else f'{namespace}/{name}'


def expand_topic_name(topic: str, node_name: str, namespace: str) -> str:
    """Expand a topic or service name relative to a node (rcl_expand_topic_name)."""
    if not isinstance(topic, str) or not _TOPIC.match(topic):
        raise GraphError(f'invalid topic name {topic!r}: use tokens of letters, digits and underscores '
                         'separated by "/", optionally starting with "/" (absolute) or "~" (private)')
    if topic.startswith('/'):
        return topic
    node_fqn = fully_qualified_name(node_name, namespace)
    if topic == '~':
        return node_fqn
    if topic.startswith('~/'):
        return node_fqn + topic[1:]
    return f'/{topic}' if namespace == '/' else f'{namespace}/{topic}'


@dataclass(frozen=True)
class RemapRule:
    """One ``[node:]from:=to`` rule of ``--ros-args -r``."""

    source: str
    target: str
    node: str | None = None

    @classmethod
    def parse(cls, text: str) -> RemapRule:
        if ':=' not in text:
            raise GraphError(f'invalid remap rule {text!r}: expected "from:=to" or "node:from:=to"')
        left, target = text.split(':=', 1)
        node = None
        if ':' in left:
            node, left = left.split(':', 1)
        if not left or not target:
            raise GraphError(f'invalid remap rule {text!r}: both sides of ":=" must be names')
        return cls(left, target, node)

    def applies_to(self, node_name: str) -> bool:
        return self.node is None or self.node == node_name


def apply_remaps(expanded: str, rules: list[RemapRule], node_name: str, namespace: str) -> str:
    """The first rule whose expanded source equals ``expanded`` gives the new name (rcl order)."""
    for rule in rules:
        if rule.source.startswith('__') or not rule.applies_to(node_name):
            continue
        if expand_topic_name(rule.source, node_name, namespace) == expanded:
            return expand_topic_name(rule.target, node_name, namespace)
    return expanded
