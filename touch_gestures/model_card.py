"""Model cards: how a model or codebook file was made, and what it scored, stored inside the file.

Every learnt file of the stack is an ``.npz`` read with ``allow_pickle=False`` (the bear's subtype
model, the patch's mixtures, the skin's codebook). A card is one more key, ``model_card``: a str
scalar holding a JSON object. The loaders ignore keys they do not know, so a card changes nothing
for them; :func:`read_card` reads it back, :func:`card_line` is the one line a node logs at start.

Fields (all optional but ``kind``)::

    kind          'bear_subtype_model' | 'patch_gesture_model' | 'skin_codebook'
    created_utc   ISO 8601, when the file was written
    command       the command that wrote it (re-run it to regenerate the file)
    data          {'synthetic': bool, 'source': str, 'people': int, 'trials_per_class': {class: int},
                   'bags': [str], ...}
    evaluation    {'method': str, figure: number, ...}   e.g. leave-one-person-out accuracy
    notes         str

>>> card = make_card('skin_codebook', command='social-touch train skin',
...                  data={'synthetic': True, 'source': 'simulated people', 'people': 4})
>>> card_line(card)
'skin_codebook: SYNTHETIC data (simulated people), 4 people; no evaluation recorded; made by social-touch train skin'
"""

from __future__ import annotations

import datetime
import json
import os
import shlex
import sys
from pathlib import Path
from typing import Any

import numpy as np

from touch_graph.files import replacing

__all__ = ['CARD_KEY', 'KINDS', 'attach_card', 'card_line', 'card_log_line', 'file_kind', 'format_card', 'make_card',
           'read_card', 'this_command']

CARD_KEY = 'model_card'
KINDS = ('bear_subtype_model', 'patch_gesture_model', 'skin_codebook')


def this_command() -> str:
    """The command line of this process, as ``social-touch ...`` (for a card's ``command``)."""
    prog = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else 'social-touch'
    return shlex.join([prog, *sys.argv[1:]])


def make_card(kind: str, *, command: str | None = None, data: dict | None = None, evaluation: dict | None = None,
              notes: str = '') -> dict[str, Any]:
    """A card (module doc); ``command`` defaults to this process's command line."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    card: dict[str, Any] = {
        'kind': kind,
        'created_utc': datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ'),
        'command': command if command is not None else this_command(),
        'data': dict(data or {}),
    }
    if evaluation:
        card['evaluation'] = dict(evaluation)
    if notes:
        card['notes'] = notes
    json.dumps(card)   # ValueError / TypeError now, not when the file is written
    return card


def _load_arrays(path: Path) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` (never unpickling); ValueError naming the file otherwise."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as err:
        raise ValueError(f'{path}: not a readable .npz model file: {err}') from err


def attach_card(path: str | os.PathLike, card: dict[str, Any]) -> None:
    """Store ``card`` in the ``.npz`` at ``path`` (replacing any card), written whole then renamed."""
    path = Path(path)
    arrays = _load_arrays(path)
    arrays[CARD_KEY] = np.array(json.dumps(card, sort_keys=True))
    with replacing(path) as tmp:
        np.savez_compressed(tmp, **arrays)


def read_card(path: str | os.PathLike) -> dict[str, Any] | None:
    """The card of the file at ``path``, or None when it has none.

    Raises:
        ValueError: the file is not a readable ``.npz`` or its card is not a JSON object.
    """
    arrays = _load_arrays(Path(path))
    if CARD_KEY not in arrays:
        return None
    try:
        card = json.loads(str(arrays[CARD_KEY]))
    except json.JSONDecodeError as err:
        raise ValueError(f'{path}: its model card is not JSON: {err}') from err
    if not isinstance(card, dict):
        raise ValueError(f'{path}: its model card is not a JSON object')
    return card


def file_kind(path: str | os.PathLike) -> str | None:
    """Which kind of model file ``path`` is, from its arrays (None when none of ours)."""
    arrays = _load_arrays(Path(path))
    keys = set(arrays)
    fmt = str(arrays['format']) if 'format' in keys else ''
    if fmt == 'social_touch.skin_codebook':
        return 'skin_codebook'
    if fmt.startswith('social_touch.patch'):
        return 'patch_gesture_model'
    if {'feature_names', 'coef', 'intercept', 'trained_at'} <= keys:
        return 'bear_subtype_model'
    return None


def _data_text(data: dict) -> str:
    parts = ['SYNTHETIC data (simulated people)' if data.get('synthetic') else
             f"recorded data ({data.get('source', 'source not recorded')})"]
    if 'people' in data:
        parts.append(f"{data['people']} people")
    return ', '.join(parts)


def _evaluation_text(evaluation: dict | None) -> str:
    if not evaluation:
        return 'no evaluation recorded'
    figures = [f'{k} {v:.3g}' if isinstance(v, float) else f'{k} {v}' for k, v in evaluation.items()
               if k != 'method' and isinstance(v, (int, float, str))]
    return f"{evaluation.get('method', 'evaluation')}: {', '.join(figures[:3])}"


def card_line(card: dict[str, Any] | None) -> str:
    """One line for a node's log: what kind, what data, what score, which command."""
    if card is None:
        return 'no model card (a file made before cards: regenerate it to know how it was made)'
    return (f"{card.get('kind', '?')}: {_data_text(card.get('data', {}))}; "
            f"{_evaluation_text(card.get('evaluation'))}; made by {card.get('command', '?')}")


def card_log_line(path: str | os.PathLike) -> str:
    """``'model card of NAME: ...'`` for a node's start log; never raises (a card only informs)."""
    try:
        return f'model card of {Path(path).name}: {card_line(read_card(path))}'
    except ValueError as err:
        return f'model card of {Path(path).name}: unreadable ({err})'


def format_card(card: dict[str, Any], indent: str = '  ') -> str:
    """The whole card as indented text (``social-touch model info``)."""
    lines = []

    def walk(value: Any, depth: int, key: str) -> None:
        pad = indent * depth
        if isinstance(value, dict):
            lines.append(f'{pad}{key}:')
            for k, v in value.items():
                walk(v, depth + 1, str(k))
        elif isinstance(value, list) and len(value) > 6:
            lines.append(f'{pad}{key}: {len(value)} items: {", ".join(map(str, value[:3]))}, ...')
        else:
            lines.append(f'{pad}{key}: {value}')

    for k in sorted(card, key=lambda k: (k != 'kind', k)):   # the kind first
        walk(card[k], 0, k)
    return '\n'.join(lines)
