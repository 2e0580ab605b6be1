"""Helpers for tests of the skin's command node: a codebook and command map written for a test."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from touch_gestures.skin.codebook import save_codebook
from touch_graph.runtime import Parameter


def command_node_parameters(tmp_path: Path, model: Any, commands: dict[str, str], **codebook: Any) -> list[Parameter]:
    """``codebook`` and ``commands`` parameters of a haptic_commands node: ``model`` saved as a codebook
    (``codebook``: save_codebook's keywords) and a command map of ``commands`` (gesture -> command)."""
    path = save_codebook(tmp_path / 'symbols.npz', model, **codebook)
    command_file = tmp_path / 'commands.yaml'
    command_file.write_text('format_version: 1\ncommands:\n' + ''.join(f'  {g}: {c}\n' for g, c in commands.items()))
    return [Parameter('codebook', value=str(path)), Parameter('commands', value=str(command_file))]
