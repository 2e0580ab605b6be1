"""Does a bag's message definition match ours? And if not, which field differs?

A bag stores each type's full ``.msg`` text (with its nested types) in the MCAP schema.
Replaying a bag recorded with an older ``SkinFrame.msg`` would publish bytes our classes
decode wrongly, or not at all, so the player compares definitions field by field first
and names what changed:

>>> from rosbags.typesys import Stores, get_typestore
>>> old = 'uint16 sequence\\nfloat32[36] force\\n'
>>> check_definition('/skin/frame', 'social_touch_msgs/msg/SkinFrame', old).differences[0]
"social_touch_msgs/msg/SkinFrame: field 'header' (std_msgs/Header) is in our .msg but not in the bag's"
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import get_types_from_msg

from .. import messages

__all__ = ['DefinitionCheck', 'check_definition', 'type_string']


def type_string(desc: Any) -> str:
    """A field descriptor of the rosbags type system as a ``.msg`` type (``float32[144]``).

    >>> type_string((Nodetype.ARRAY, ((Nodetype.BASE, ('float32', 0)), 144)))
    'float32[144]'
    """
    kind, detail = desc
    if kind == Nodetype.BASE:
        name, bound = detail
        return f'{name}<={bound}' if bound else name
    if kind == Nodetype.NAME:
        return str(detail).replace('/msg/', '/')
    sub, size = detail
    if kind == Nodetype.ARRAY:
        return f'{type_string(sub)}[{size}]'
    return f'{type_string(sub)}[<={size}]' if size else f'{type_string(sub)}[]'


@dataclass
class DefinitionCheck:
    """The verdict for one bag connection.

    ``status``: ``match``; ``differs`` (see ``differences``); ``unknown`` (a type we do not
    have); ``unchecked`` (the bag stores no definition and no hash).
    """

    topic: str
    type_name: str
    status: str
    differences: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status in ('match', 'unchecked')


def _compare_type(name: str, bag_def: tuple, ours: tuple) -> list[str]:
    out = []
    bag_consts = {c[0]: (c[1], c[2]) for c in bag_def[0]}
    our_consts = {c[0]: (c[1], c[2]) for c in ours[0]}
    for const in sorted(set(bag_consts) | set(our_consts)):
        if bag_consts.get(const) != our_consts.get(const):
            out.append(f'{name}: constant {const} is {bag_consts.get(const, "absent")} in the bag, '
                       f'{our_consts.get(const, "absent")} here')
    bag_fields = dict(bag_def[1])
    our_fields = dict(ours[1])
    for fname, desc in ours[1]:
        if fname not in bag_fields:
            out.append(f"{name}: field '{fname}' ({type_string(desc)}) is in our .msg but not in the bag's")
        elif _normal(bag_fields[fname]) != _normal(desc):
            out.append(f"{name}: field '{fname}' is {type_string(bag_fields[fname])} in the bag, "
                       f'{type_string(desc)} in our .msg')
    for fname, desc in bag_def[1]:
        if fname not in our_fields:
            out.append(f"{name}: field '{fname}' ({type_string(desc)}) is in the bag but not in our .msg")
    if not out and [f for f, _ in bag_def[1]] != [f for f, _ in ours[1]]:
        out.append(f'{name}: the same fields in another order (CDR bytes differ)')
    return out


def _normal(desc: Any) -> Any:
    """Descriptors as plain nested tuples of ints/strs, so enum members and ints compare equal."""
    if isinstance(desc, (tuple, list)):
        return tuple(_normal(d) for d in desc)
    return int(desc) if isinstance(desc, Nodetype) else desc


def check_definition(topic: str, type_name: str, msgdef: str, digest: str = '') -> DefinitionCheck:
    """Compare a bag connection's ``.msg`` text (``msgdef``, with nested types) with our type store."""
    store = messages.typestore
    if type_name not in store.fielddefs:
        return DefinitionCheck(topic, type_name, 'unknown', [
            f'{type_name} is not a type known here; known types of this package: '
            f'{", ".join(messages.interface_names())}'])
    if not msgdef.strip():
        if digest and digest.startswith('RIHS01_'):
            if digest != store.hash_rihs01(type_name):
                return DefinitionCheck(topic, type_name, 'differs', [
                    f'{type_name}: the bag stores no definition and its type hash {digest[:19]}... differs '
                    'from ours; the .msg changed since it was recorded'])
            return DefinitionCheck(topic, type_name, 'match')
        return DefinitionCheck(topic, type_name, 'unchecked')
    try:
        bag_types = get_types_from_msg(msgdef, type_name)
    except Exception as err:  # rosbags' parser raises several kinds
        return DefinitionCheck(topic, type_name, 'differs', [
            f'{type_name}: the definition stored in the bag does not parse: {err}'])
    differences = []
    for name, bag_def in bag_types.items():
        ours = store.fielddefs.get(name)
        if ours is None:
            differences.append(f'{name} (used by {type_name} in the bag) is not a type known here')
            continue
        differences += _compare_type(name, bag_def, ours)
    return DefinitionCheck(topic, type_name, 'differs' if differences else 'match', differences)
