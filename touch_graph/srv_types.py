"""Service types: ``.srv`` files read by the rosbags type system, and service classes with rclpy's shape.

Each half of a ``.srv`` is registered as the message ``pkg/srv/Name_Request`` / ``_Response``
(rosidl's names); an empty half gets rosidl's ``uint8 structure_needs_at_least_one_member``.

>>> cls = get_service('std_srvs/srv/SetBool')
>>> cls.Request(data=True).data, cls.Response().success
(True, False)
>>> cls.__srvtype__, cls.Request.__msgtype__
('std_srvs/srv/SetBool', 'std_srvs/srv/SetBool_Request')
"""

from __future__ import annotations

import threading
from typing import Any

from .errors import MessageError, did_you_mean
from .messages import get_message, typestore
from .srv_definitions import STANDARD_SERVICES, own_services, parse_srv, service_names, srv_files

__all__ = ['STANDARD_SERVICES', 'ServiceType', 'get_service', 'parse_srv', 'service_definition', 'service_names',
           'srv_files']

class ServiceType:
    """Base of service classes: ``Srv.Request`` and ``Srv.Response`` message classes, as rclpy's generated ones.

    Attributes:
        __srvtype__: the full type name, ``pkg/srv/Name``.
    """

    __srvtype__: str = ''
    Request: type
    Response: type


_lock = threading.Lock()
_classes: dict[str, type[ServiceType]] = {}


def normalize_service_name(name: str) -> str:
    """``pkg/srv/T`` or ``pkg/T`` -> ``pkg/srv/T``.

    >>> normalize_service_name('std_srvs/Trigger')
    'std_srvs/srv/Trigger'
    """
    parts = name.strip().split('/')
    if len(parts) == 2:
        parts = [parts[0], 'srv', parts[1]]
    if len(parts) != 3 or parts[1] != 'srv' or not all(parts):
        raise MessageError(f"expected a service type 'pkg/srv/Name' (e.g. std_srvs/srv/Trigger), got {name!r}")
    return '/'.join(parts)


def get_service(name: str) -> type[ServiceType]:
    """The service class of ``pkg/srv/Name`` (also ``pkg/Name``), with ``Request`` and ``Response``.

    Raises:
        MessageError: for a type that is not known (with the known ones).
    """
    full = normalize_service_name(name)
    with _lock:
        cls = _classes.get(full)
        if cls is not None:
            return cls
    if f'{full}_Request' not in typestore.fielddefs:
        known = sorted(n[:-len('_Request')] for n in typestore.fielddefs if n.endswith('_Request') and '/srv/' in n)
        raise MessageError(f"unknown service type '{name}'{did_you_mean(full, known)}; known: {', '.join(known)}")
    request, response = get_message(f'{full}_Request'), get_message(f'{full}_Response')
    pkg, _, short = full.split('/')
    cls = type(short, (ServiceType,), {'__srvtype__': full, 'Request': request, 'Response': response,
                                       '__module__': f'{pkg}.srv', '__qualname__': short})
    with _lock:
        return _classes.setdefault(full, cls)


def service_type_of(srv_type: Any) -> str:
    """The ``pkg/srv/Name`` of a service class (ours or rclpy's generated one).

    Raises:
        TypeError: for something that is not a service class.
    """
    name = getattr(srv_type, '__srvtype__', None)
    if name:
        return name
    request = getattr(srv_type, 'Request', None)
    msgtype = getattr(request, '__msgtype__', '')
    if msgtype.endswith('_Request'):
        return msgtype[:-len('_Request')]
    raise TypeError(f'{srv_type!r} is not a service type (a class with Request and Response, e.g. '
                    "get_service('std_srvs/srv/Trigger'))")


def service_definition(name: str) -> str:
    """The ``.srv`` text of a service type, as ``ros2 interface show`` prints it.

    Raises:
        MessageError: for an unknown type (with the known ones).
    """
    full = normalize_service_name(name)
    get_service(full)  # raises for an unknown one
    texts = {**STANDARD_SERVICES, **own_services()}
    if full in texts:
        return texts[full]
    # registered by other means: rebuilt from its halves
    halves = [typestore.generate_msgdef(f'{full}_{part}', ros_version=2)[0].split('\n' + '=' * 80)[0]
              for part in ('Request', 'Response')]
    return '---\n'.join(halves)
