"""Gesture -> command map: validation with file:line and did-you-mean; the HapticCommand message."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from touch_gestures.skin import Match, TouchGesture, haptic_command, load_command_map
from touch_graph.errors import ConfigError

GOOD = 'format_version: 1\ncommands:\n  line_right: move_right\n  one: select_task_1\n'


def write(tmp_path, text):
    path = tmp_path / 'cmds.yaml'
    path.write_text(text)
    return path


def test_the_project_command_map_is_valid():
    config = Path(__file__).resolve().parent.parent / 'config' / 'skin_commands.yaml'
    from touch_sim.skin.synthetic import SHAPES

    commands = load_command_map(config, gestures=SHAPES)
    assert commands.command_for('line_right') == 'move_right' and commands.command_for(None) is None


def test_unknown_gesture_names_file_line_and_a_suggestion(tmp_path):
    path = write(tmp_path, GOOD)
    with pytest.raises(ConfigError, match=r"cmds.yaml:3: gesture 'line_right' is not in the codebook.*"
                                          r"did you mean 'line_rigth'") as info:
        load_command_map(path, gestures=['line_rigth', 'one'])
    assert info.value.line == 3


@pytest.mark.parametrize('text, message', [
    ('format_version: 1\ncommand:\n  a: b\n', "unknown key 'command'.*did you mean 'commands'"),
    ('format_version: 2\ncommands:\n  a: b\n', 'format_version 2 is not supported'),
    ('format_version: 1\ncommands:\n  a: Move Left\n', "command of 'a' must be an identifier"),
    ('format_version: 1\ncommands: []\n', 'non-empty mapping'),
    ('format_version: 1\ncommands:\n  a: b\n  a: c\n', 'duplicate key'),
])
def test_malformed_maps(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message):
        load_command_map(write(tmp_path, text))


def test_haptic_command_message_carries_distance_and_margin(tmp_path):
    commands = load_command_map(write(tmp_path, GOOD))
    gesture = TouchGesture.from_trajectory(np.array([[1.0, 1.0], [9.0, 1.0]]), np.array([0.0, 0.4]))
    msg = haptic_command(Match('line_right', 0.12, 0.3, 'line_right'), gesture, commands, 'trace')
    assert (msg.gesture, msg.command, msg.recogniser, msg.frames) == ('line_right', 'move_right', 'trace', 2)
    assert msg.distance == pytest.approx(0.12) and msg.margin == pytest.approx(0.3)
    assert msg.duration_s == pytest.approx(0.4)
    one_class = haptic_command(Match('one', 0.1, float('inf'), 'one'), gesture, commands, 'trace')
    assert np.isfinite(one_class.margin)
    assert haptic_command(Match(None, 0.9, 0.0, 'one', 'distance'), gesture, commands, 'trace') is None
    assert haptic_command(Match('circle', 0.1, 0.5, 'circle'), gesture, commands, 'trace') is None
