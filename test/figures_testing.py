"""Checks of report figures shared by the figure tests: a valid PNG of the promised size, no metadata."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

__all__ = ['MAX_BYTES', 'assert_report_png', 'png_info']

MAX_BYTES = 150_000


def png_info(path: Path) -> dict:
    """Width, height and text chunks of a PNG, checking its signature and every chunk's CRC."""
    data = path.read_bytes()
    assert data[:8] == b'\x89PNG\r\n\x1a\n', f'{path} is not a PNG'
    pos, chunks, texts = 8, [], []
    while pos < len(data):
        (length,) = struct.unpack('>I', data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack('>I', data[pos + 8 + length:pos + 12 + length])
        assert zlib.crc32(kind + body) == crc, f'{path}: bad CRC in a {kind!r} chunk'
        chunks.append(kind)
        if kind in (b'tEXt', b'iTXt', b'zTXt'):
            texts.append(body)
        pos += 12 + length
    assert chunks[0] == b'IHDR' and chunks[-1] == b'IEND'
    width, height = struct.unpack('>II', data[16:24])
    return {'width': width, 'height': height, 'texts': texts, 'bytes': len(data)}


def assert_report_png(path: Path) -> dict:
    """A report figure: a valid PNG, under the size budget, no metadata (no version, no time)."""
    info = png_info(path)
    assert info['bytes'] < MAX_BYTES, f'{path.name} is {info["bytes"]} bytes'
    assert info['texts'] == [], info['texts']
    assert 200 <= info['width'] <= 1600 and 200 <= info['height'] <= 1200, info
    return info
