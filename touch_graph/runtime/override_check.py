"""Overrides nobody declared: a misspelt parameter in a launch or parameter file (ROS 2 ignores them silently).

An override for one node is unknown when that node does not declare it; one for a wildcard key
(``/**``, ``/ns/*``) when no node it reached declares it. Warnings, or with ``strict`` an error.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from ..errors import ParameterError
from ..yamlconf import did_you_mean

__all__ = ['UnknownOverride', 'check_overrides', 'unknown_overrides']


@dataclass(frozen=True)
class UnknownOverride:
    """One override that no node it applies to declares."""

    name: str
    source: Any  #: where it was written (``file:line``, ``launch``, ...); str() gives it
    nodes: tuple[str, ...]  #: fully qualified names of the nodes it reached
    suggestion: str  #: `` (did you mean 'x'?)`` or ''

    def __str__(self) -> str:
        who = self.nodes[0] if len(self.nodes) == 1 else f'any of {", ".join(self.nodes)}'
        return f"{self.source}: parameter '{self.name}' is not declared by {who}{self.suggestion}"


def unknown_overrides(nodes: Iterable[Any]) -> list[UnknownOverride]:
    """Every override that no node it reached declares, in the order the nodes were made."""
    wildcard: dict[tuple[str, str], tuple[Any, list[Any]]] = {}
    declared_somewhere: set[tuple[str, str]] = set()
    out: list[UnknownOverride] = []
    nodes = list(nodes)
    for node in nodes:
        for name, source, key, declared in node.override_origins():
            if declared:
                declared_somewhere.add((key, name))
            elif '*' in key:
                wildcard.setdefault((key, name), (source, []))[1].append(node)
            else:
                out.append(UnknownOverride(name, source, (node.get_fully_qualified_name(),),
                                           did_you_mean(name, _declared(node))))
    for (key, name), (source, reached) in wildcard.items():
        if (key, name) not in declared_somewhere:
            choices = {p for node in reached for p in _declared(node)}
            out.append(UnknownOverride(name, source, tuple(n.get_fully_qualified_name() for n in reached),
                                       did_you_mean(name, choices)))
    return out


def check_overrides(nodes: Iterable[Any], logger: Any, strict: bool = False) -> list[UnknownOverride]:
    """Warn about (or with ``strict``, raise ParameterError for) overrides nobody declares."""
    found = unknown_overrides(nodes)
    if found and strict:
        raise ParameterError('parameters that no node declares (--strict-params):\n  '
                             + '\n  '.join(str(f) for f in found))
    for item in found:
        logger.warning(f'{item} (ignored; --strict-params makes this an error)')
    return found


def _declared(node: Any) -> list[str]:
    return [name for name in node.get_parameters_by_prefix('') if name != 'use_sim_time']
