"""The few Cyclone DDS C calls cyclonedds-python does not expose the way the transport needs them.

A wait set that says which conditions triggered; deleting an entity so that its Python object will
not delete it again; the count of a writer's matched readers; one lock around the calls that turn
a C QoS into a ``Qos`` (:func:`take_builtin`, :func:`matched_endpoint`: not thread-safe).
"""

from __future__ import annotations

import ctypes as ct
import threading
from typing import Any

from cyclonedds.core import DDSException, Entity
from cyclonedds.internal import DDS

__all__ = ['QOS_CONVERSION_LOCK', 'WaitSet', 'delete_entity', 'forget', 'matched_endpoint', 'matched_readers',
           'take_builtin', 'wait_for_acks']

_lib = DDS._dll_handle
_entity = ct.c_int32
_attach = ct.c_ssize_t  # dds_attach_t is an intptr_t


def _fn(name: str, restype: Any, *argtypes: Any) -> Any:
    fn = getattr(_lib, name)
    fn.restype = restype
    fn.argtypes = list(argtypes)
    return fn


_create_waitset = _fn('dds_create_waitset', _entity, _entity)
_waitset_attach = _fn('dds_waitset_attach', ct.c_int32, _entity, _entity, _attach)
_waitset_detach = _fn('dds_waitset_detach', ct.c_int32, _entity, _entity)
_waitset_wait = _fn('dds_waitset_wait', ct.c_int32, _entity, ct.POINTER(_attach), ct.c_size_t, ct.c_int64)
_create_guard = _fn('dds_create_guardcondition', _entity, _entity)
_set_guard = _fn('dds_set_guardcondition', ct.c_int32, _entity, ct.c_bool)
_delete = _fn('dds_delete', ct.c_int32, _entity)
_matched_subscriptions = _fn('dds_get_matched_subscriptions', ct.c_int32, _entity, ct.c_void_p, ct.c_size_t)
_wait_for_acks = _fn('dds_wait_for_acks', ct.c_int32, _entity, ct.c_int64)


# cyclonedds-python (11.0.1) turns a C QoS into a Qos through output buffers shared by the whole
# process (class attributes of cyclonedds.qos._CQos), and decodes a built-in sample's type id
# through a buffer shared by the type. Two threads converting at once read each other's
# pointers: a partition list read through another thread's array, and in dds_qget_userdata a
# copy written into another thread's smaller block (heap corruption; a CI run died of it).
# Every participant's receive thread takes built-in samples, so every such call holds this.
QOS_CONVERSION_LOCK = threading.Lock()


def take_builtin(reader: Any, n: int) -> list:
    """Up to ``n`` samples of a cyclonedds ``BuiltinDataReader``, taken under :data:`QOS_CONVERSION_LOCK`."""
    with QOS_CONVERSION_LOCK:
        return reader.take(N=n)


def matched_endpoint(get_data: Any, handle: int) -> Any:
    """``get_data(handle)`` (a writer's ``get_matched_subscription_data`` or a reader's
    ``get_matched_publication_data``) under :data:`QOS_CONVERSION_LOCK`; None when the endpoint is gone."""
    with QOS_CONVERSION_LOCK:
        try:
            return get_data(handle)
        except Exception:  # the endpoint went away between the two calls
            return None


def delete_entity(entity: Entity | int) -> None:
    """Delete a DDS entity (and its children) now; forget cyclonedds' Python object for it."""
    ref = entity if isinstance(entity, int) else entity._ref
    Entity._entities.pop(ref, None)
    _delete(ref)


def forget(entity: Entity) -> None:
    """Keep cyclonedds' Python object from deleting ``entity`` when it is collected (its parent does)."""
    Entity._entities.pop(entity._ref, None)


def matched_readers(writer_ref: int) -> int:
    """How many readers a writer is matched with (0 on error)."""
    return max(0, _matched_subscriptions(writer_ref, None, 0))


def wait_for_acks(writer_ref: int, timeout_ns: int) -> bool:
    """Wait until every reliable reader acknowledged the writer's samples; False on timeout or error.

    (cyclonedds' ``DataWriter.wait_for_acks`` raises AttributeError on a timeout in 11.0.1.)
    """
    return _wait_for_acks(writer_ref, max(0, timeout_ns)) == 0


class WaitSet:
    """A Cyclone wait set plus a guard condition that wakes it (attach id 0).

    Args:
        participant_ref: the participant the wait set belongs to.
        capacity: how many triggered attachments one :meth:`wait` reports at most.
    """

    GUARD = 0

    def __init__(self, participant_ref: int, capacity: int = 256) -> None:
        self.ref = _check(_create_waitset(participant_ref), 'dds_create_waitset')
        self.guard = _check(_create_guard(participant_ref), 'dds_create_guardcondition')
        _check(_waitset_attach(self.ref, self.guard, self.GUARD), 'dds_waitset_attach')
        self._buffer = (_attach * capacity)()
        self._capacity = capacity

    def attach(self, entity_ref: int, key: int) -> None:
        """Report ``key`` when ``entity_ref`` (a read condition, a reader) triggers; ``key`` > 0."""
        _check(_waitset_attach(self.ref, entity_ref, key), 'dds_waitset_attach')

    def detach(self, entity_ref: int) -> None:
        _waitset_detach(self.ref, entity_ref)  # an entity already deleted is detached already

    def wake(self) -> None:
        """Make a waiting :meth:`wait` return (safe from any thread)."""
        _set_guard(self.guard, True)

    def wait(self, timeout_ns: int) -> list[int]:
        """The keys of the triggered attachments (the guard's is 0 and is reset), or [] on timeout."""
        n = _waitset_wait(self.ref, self._buffer, self._capacity, timeout_ns)
        if n <= 0:
            if n < 0:
                raise DDSException(n, 'Occurred in dds_waitset_wait')
            return []
        keys = self._buffer[:min(n, self._capacity)]  # ints (ctypes converts c_ssize_t items)
        if self.GUARD in keys:
            _set_guard(self.guard, False)
        return keys

    def wait_into(self, timeout_ns: int, keys: set[int]) -> int:
        """:meth:`wait` adding the triggered keys but the guard's to ``keys``; the number triggered (0: timeout).

        (No list is built: this is the executor's wait, on every received sample's path.)
        """
        n = _waitset_wait(self.ref, self._buffer, self._capacity, timeout_ns)
        if n <= 0:
            if n < 0:
                raise DDSException(n, 'Occurred in dds_waitset_wait')
            return 0
        buffer = self._buffer
        for i in range(min(n, self._capacity)):
            key = buffer[i]
            if key == self.GUARD:
                _set_guard(self.guard, False)
            else:
                keys.add(key)
        return n

    def close(self) -> None:
        _delete(self.ref)
        _delete(self.guard)


def _check(ret: int, what: str) -> int:
    if ret < 0:
        raise DDSException(ret, f'Occurred in {what}')
    return ret
