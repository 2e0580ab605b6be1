"""Service definitions: the ``.srv`` texts the runtime knows, parsed into rosbags type definitions
(``pkg/srv/Name_Request`` and ``_Response``) for the type store of :mod:`touch_graph.messages`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from rosbags.typesys import get_types_from_msg

from .errors import MessageError
from .paths import INTERFACE_PACKAGE, share_file

__all__ = ['STANDARD_SERVICES', 'own_services', 'parse_srv', 'service_names', 'service_types', 'srv_files']

#: ROS 2 services the runtime serves or calls, ``pkg/srv/Name`` -> ``.srv`` text.
STANDARD_SERVICES: dict[str, str] = {
    'rcl_interfaces/srv/DescribeParameters': 'string[] names\n---\nParameterDescriptor[] descriptors\n',
    'rcl_interfaces/srv/GetParameters': 'string[] names\n---\nParameterValue[] values\n',
    'rcl_interfaces/srv/GetParameterTypes': 'string[] names\n---\nuint8[] types\n',
    'rcl_interfaces/srv/ListParameters': ('uint64 DEPTH_RECURSIVE=0\nstring[] prefixes\nuint64 depth\n---\n'
                                          'ListParametersResult result\n'),
    'rcl_interfaces/srv/SetParameters': 'Parameter[] parameters\n---\nSetParametersResult[] results\n',
    'rcl_interfaces/srv/SetParametersAtomically': 'Parameter[] parameters\n---\nSetParametersResult result\n',
    'std_srvs/srv/Empty': '---\n',
    'std_srvs/srv/Trigger': '---\nbool success\nstring message\n',
    'std_srvs/srv/SetBool': 'bool data\n---\nbool success\nstring message\n',
    'type_description_interfaces/srv/GetTypeDescription': (
        'string type_name\nstring type_hash\nbool include_type_sources true\n---\nbool successful\n'
        'string failure_reason\nTypeDescription type_description\nTypeSource[] type_sources\n'
        'KeyValue[] extra_information\n'),
}

_SEPARATOR = re.compile(r'^---\s*$', re.MULTILINE)
#: What rosidl puts in an empty structure, so that it has a size.
_PLACEHOLDER = 'uint8 structure_needs_at_least_one_member\n'


def srv_files() -> list[Path]:
    """The package's ``.srv`` files, sorted by name (none when the directory is missing)."""
    directory = share_file('srv')
    return sorted(directory.glob('*.srv')) if directory.is_dir() else []


def own_services() -> dict[str, str]:
    return {f'{INTERFACE_PACKAGE}/srv/{p.stem}': p.read_text(encoding='utf-8') for p in srv_files()}


def service_names() -> list[str]:
    """This package's service types, e.g. ``social_touch_msgs/srv/X``."""
    return sorted(own_services())


def _has_fields(text: str) -> bool:
    return any(line.split('#')[0].strip() and '=' not in line.split('#')[0] for line in text.splitlines())


def parse_srv(text: str, name: str) -> dict[str, Any]:
    """rosbags type definitions of ``pkg/srv/Name``'s request and response (for ``store.register``).

    Raises:
        MessageError: when the text is not a ``.srv`` (no single ``---`` line) or a half does not parse.
    """
    pkg, kind, short = name.split('/')
    if kind != 'srv':
        raise MessageError(f"expected a service type name 'pkg/srv/Name', got {name!r}")
    halves = _SEPARATOR.split(text)
    if len(halves) != 2:
        raise MessageError(f'{name}: a .srv holds a request and a response separated by one line "---"; '
                           f'found {len(halves) - 1} such lines')
    out: dict[str, Any] = {}
    for part, body in zip(('Request', 'Response'), halves, strict=True):
        if not _has_fields(body):
            body = body + '\n' + _PLACEHOLDER
        # Parsed as a message of the package, so bare type names resolve to pkg/msg/...; then renamed.
        as_msg = f'{pkg}/msg/{short}_{part}'
        try:
            types = get_types_from_msg(body, as_msg)
        except Exception as err:  # the parser raises several kinds
            raise MessageError(f'{name}: cannot parse the {part.lower()}: {err}') from err
        out[f'{pkg}/srv/{short}_{part}'] = types.pop(as_msg)
        out.update(types)
    return out


def service_types() -> dict[str, Any]:
    """Definitions of every known service's request and response (standard and this package's)."""
    out: dict[str, Any] = {}
    for name, text in {**STANDARD_SERVICES, **own_services()}.items():
        out.update(parse_srv(text, name))
    return out
