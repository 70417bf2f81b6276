"""Image sizes read from an encoded image's header, before it is decoded: a PNG or JPEG that claims more
pixels than d2sr takes (a decompression bomb, or a damaged header) is refused without allocating them."""

from __future__ import annotations

import struct

from d2sr.errors import InputError

__all__ = ["check_encoded", "check_pixels", "encoded_size"]

MAX_SIDE = 16384  # pixels a side: no depth camera comes near (libpng itself decodes at most 10^6)
MAX_PIXELS = 4096 * 4096  # about 4.5 GB of working memory (frames.base.WORK_BYTES); larger ones are refused
_PNG = b"\x89PNG\r\n\x1a\n"
_JPEG = b"\xff\xd8"
# JPEG start-of-frame markers (baseline, progressive, ...): the ones that carry the image size.
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def check_pixels(height: int, width: int, where: str) -> None:
    """An image of ``width`` x ``height`` is one d2sr takes: both sides above zero, at most MAX_PIXELS."""
    if height <= 0 or width <= 0:
        raise InputError(f"{where}: an image of {width}x{height} pixels has no pixels")
    if height * width > MAX_PIXELS:
        raise InputError(
            f"{where}: {width}x{height} pixels; d2sr takes images up to {MAX_PIXELS // 10**6} MP"
        )
    if max(height, width) > MAX_SIDE:
        raise InputError(
            f"{where}: {width}x{height} pixels; d2sr takes images up to {MAX_SIDE} pixels a side"
        )


def encoded_size(data: bytes | memoryview) -> tuple[int, int] | None:
    """(height, width) from a PNG's IHDR or a JPEG's start-of-frame; None for anything else."""
    head = bytes(data[:24])
    if head.startswith(_PNG):
        if len(head) < 24 or head[12:16] != b"IHDR":
            return None
        w, h = struct.unpack(">II", head[16:24])
        return h, w
    if head.startswith(_JPEG):
        i, n = 2, len(data)
        while i + 9 <= n:
            if data[i] != 0xFF:
                return None
            marker = data[i + 1]
            if marker == 0xFF:  # fill byte
                i += 1
                continue
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                i += 2
                continue
            (length,) = struct.unpack(">H", bytes(data[i + 2 : i + 4]))
            if marker in _SOF:
                h, w = struct.unpack(">HH", bytes(data[i + 5 : i + 9]))
                return h, w
            if length < 2:
                return None
            i += 2 + length
        return None
    return None


def check_encoded(data: bytes | memoryview, where: str, what: str = "PNG") -> tuple[int, int]:
    """The size an encoded PNG (or JPEG, where ``what`` allows it) claims, checked before decoding."""
    size = encoded_size(data)
    if size is None:
        raise InputError(f"{where}: corrupt {what} (no readable image header)")
    check_pixels(size[0], size[1], where)
    return size
