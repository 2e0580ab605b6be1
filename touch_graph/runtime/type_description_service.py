"""``~/get_type_description`` (``type_description_interfaces/srv/GetTypeDescription``), as Jazzy nodes serve it.

Answers for the node's own types (``successful=False`` with the reason otherwise), with the
description whose RIHS01 hash the node announces; ``type_sources`` stays empty.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import type_description
from ..errors import MessageError
from ..messages import get_message
from ..srv_types import get_service

if TYPE_CHECKING:
    from .node import Node

__all__ = ['SERVICE_TYPE', 'TypeDescriptionService', 'description_msg']

SERVICE_TYPE = 'type_description_interfaces/srv/GetTypeDescription'
_PKG = 'type_description_interfaces/msg/'


def description_msg(type_name: str) -> Any:
    """``type_description_interfaces/msg/TypeDescription`` of ``type_name``."""
    described = type_description.type_description(type_name)
    FieldType, Field = get_message(_PKG + 'FieldType'), get_message(_PKG + 'Field')
    Individual = get_message(_PKG + 'IndividualTypeDescription')

    def individual(d: dict) -> Any:
        return Individual(type_name=d['type_name'], fields=[
            Field(name=f['name'], default_value=f['default_value'], type=FieldType(**f['type'])) for f in d['fields']])
    return get_message(_PKG + 'TypeDescription')(
        type_description=individual(described['type_description']),
        referenced_type_descriptions=[individual(d) for d in described['referenced_type_descriptions']])


class TypeDescriptionService:
    """The ``~/get_type_description`` service of ``node``."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.service = node.create_service(get_service(SERVICE_TYPE), '~/get_type_description', self._describe)

    def types_in_use(self) -> set[str]:
        """The message and service types of the node's endpoints."""
        node = self.node
        used = {e._topic.type_name for e in [*node.publishers, *node.subscriptions]}
        return used | {e.service_type for e in [*node.services, *node.clients]}

    def _describe(self, request: Any, response: Any) -> Any:
        name = request.type_name
        if name not in self.types_in_use():
            response.successful, response.failure_reason = False, f"type '{name}' is not used by this node"
            return response
        try:
            digest = type_description.type_hash(name)
            if request.type_hash and request.type_hash != digest:
                response.successful = False
                response.failure_reason = f"type '{name}' has hash {digest} here, not {request.type_hash}"
                return response
            response.type_description = description_msg(name)
        except MessageError as err:
            response.successful, response.failure_reason = False, str(err)
            return response
        response.successful = True
        return response
