"""Where the chunk records of an MCAP file lie (for flipping bits in them)."""

from __future__ import annotations

from pathlib import Path

from mcap.records import Chunk
from mcap.stream_reader import StreamReader

__all__ = ['chunk_spans']


def chunk_spans(path: str | Path) -> list[tuple[int, int]]:
    """``(offset, length)`` of the records inside every chunk of an MCAP file, in file order."""
    out = []
    with Path(path).open('rb') as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                out.append((f.tell() - len(record.data), len(record.data)))
    return out
