"""Gesture -> robot command map (cirillo2017 3: "commands for changing control modality or
selecting a task to execute"), and the HapticCommand message a recognition becomes.

The map is YAML (``config/skin_commands.yaml``), read with :mod:`touch_graph.yamlconf`::

    format_version: 1
    commands:
      line_right: move_right      # gesture name (as in the codebook): command name
      diagonal_down: next_task

Command names are identifiers (``[a-z][a-z0-9_]*``) so a behaviour system can switch on
them. Checked against the codebook's gesture names, an unknown gesture is a
:class:`~touch_graph.errors.ConfigError` naming the file and line with a did-you-mean;
codebook gestures without a command are allowed (they are recognised, then ignored).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from touch_graph.compat import get_message  # rclpy's class under real rclpy (its publisher checks)
from touch_graph.errors import ConfigError
from touch_graph.yamlconf import YamlDict, check_keys, did_you_mean, load_yaml, typed

from .base import Match
from .gesture import TouchGesture

__all__ = ['COMMAND_TOPIC', 'CommandMap', 'haptic_command', 'load_command_map']

#: where the skin's commands are published (DESIGN.md data flow)
COMMAND_TOPIC = '/touch/haptic_command'
FORMAT_VERSION = 1
_COMMAND = re.compile(r'^[a-z][a-z0-9_]*$')


@dataclass
class CommandMap:
    """gesture name -> command name, with where each entry was written (for errors)."""

    commands: dict[str, str]
    path: str | None = None
    lines: dict[str, int | None] = field(default_factory=dict)

    def command_for(self, gesture: str | None) -> str | None:
        """The command of ``gesture``; None for no gesture (rejected) or an unmapped one."""
        return None if gesture is None else self.commands.get(gesture)

    def check_gestures(self, known: Iterable[str]) -> None:
        """Every mapped gesture must be one the codebook knows.

        Raises:
            ConfigError: at the line of the first unknown gesture, with a did-you-mean.
        """
        known = sorted(set(known))
        for gesture in self.commands:
            if gesture not in known:
                raise ConfigError(f"gesture '{gesture}' is not in the codebook (it knows: {', '.join(known)})"
                                  f'{did_you_mean(gesture, known)}; fix the name or record the gesture',
                                  self.path, self.lines.get(gesture))


def load_command_map(path: str | Path, gestures: Iterable[str] | None = None) -> CommandMap:
    """Read and check a command map; with ``gestures`` (the codebook's), check the names too.

    Raises:
        ConfigError: with file and line, for bad YAML, unknown keys, a missing or bad
            format_version, a command that is not an identifier, or an unknown gesture.
    """
    doc = load_yaml(path)
    check_keys(doc, required=('format_version', 'commands'), optional=('description',), what='skin command map')
    version = typed(doc, 'format_version', int, 'skin command map')
    if version != FORMAT_VERSION:
        raise doc.error(f'format_version {version} is not supported; this code reads {FORMAT_VERSION}',
                        'format_version')
    entries = doc['commands']
    if not isinstance(entries, YamlDict) or not entries:
        raise doc.error('commands must be a non-empty mapping of gesture name: command name', 'commands')
    commands: dict[str, str] = {}
    for gesture, command in entries.items():
        if not isinstance(gesture, str) or not gesture:
            raise entries.error(f'gesture names must be strings; got {gesture!r}', gesture)
        if not isinstance(command, str) or not _COMMAND.match(command):
            raise entries.error(f"command of '{gesture}' must be an identifier like move_left "
                                f'(lower case, digits, underscores); got {command!r}', gesture)
        commands[gesture] = command
    result = CommandMap(commands, entries.path, {g: entries.line_of(g) for g in commands})
    if gestures is not None:
        result.check_gestures(gestures)
    return result


def haptic_command(match: Match, gesture: TouchGesture, commands: CommandMap, recogniser: str,
                   stamp: Any = None) -> Any | None:
    """The ``HapticCommand`` message for a recognition, or None when nothing should be published
    (rejected, or a gesture without a command). ``stamp`` is a ``builtin_interfaces/Time``."""
    command = commands.command_for(match.label)
    if command is None:
        return None

    header = get_message('std_msgs/msg/Header')(frame_id='skin')
    if stamp is not None:
        header.stamp = stamp
    return get_message('social_touch_msgs/msg/HapticCommand')(
        header=header, gesture=match.label, command=command, recogniser=recogniser, distance=float(match.distance),
        margin=float(min(match.margin, 3.4e38)), duration_s=float(gesture.duration_s), frames=int(gesture.frames))
