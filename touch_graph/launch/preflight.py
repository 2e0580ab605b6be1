"""Check the config files (``.yaml``, ``.yml``, ``.npz`` values) a launch gives its nodes, before any node starts."""

from __future__ import annotations

import zipfile
from pathlib import Path

from ..errors import ConfigError, LaunchError
from ..yamlconf import load_yaml
from .specs import NodeSpec

__all__ = ['CONFIG_SUFFIXES', 'check_config_files', 'config_parameters']

CONFIG_SUFFIXES = ('.yaml', '.yml', '.npz')


def config_parameters(spec: NodeSpec) -> list[tuple[str, Path]]:
    """``(parameter name, path)`` of the node's parameters that name config files."""
    out = []
    for param in spec.parameter_values():
        value = param.value
        if isinstance(value, str) and '://' not in value and value.strip().lower().endswith(CONFIG_SUFFIXES):
            out.append((param.name, Path(value.strip()).expanduser()))
    return out


def check_config_files(specs: list[NodeSpec]) -> None:
    """Raise :class:`LaunchError` for the first config file that is missing, unreadable or not YAML.

    Each file is read once however many nodes share it.
    """
    checked: set[Path] = set()
    for spec in specs:
        who = spec.full_name or f'{spec.pkg}/{spec.exec}'
        for name, path in config_parameters(spec):
            if path in checked:
                continue
            if not path.is_file():
                raise spec.where.error(f"parameter '{name}' of {who}: no such file: {path} (relative paths start at "
                                       f'{Path.cwd()})')
            try:
                if path.suffix == '.npz':
                    with zipfile.ZipFile(path) as archive:
                        archive.namelist()
                else:
                    load_yaml(path)
            except ConfigError as err:
                raise LaunchError(f"parameter '{name}' of {who} (at {spec.where}): {err}") from err
            except (OSError, zipfile.BadZipFile) as err:
                raise spec.where.error(f"parameter '{name}' of {who}: cannot read {path} as "
                                       f'{"an .npz archive" if path.suffix == ".npz" else "YAML"}: {err}') from err
            checked.add(path)
