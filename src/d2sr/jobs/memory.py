"""Frame loops allocate and free the same frame-size buffers at every frame (numpy temporaries, onnxruntime's
outputs). glibc hands out blocks above its mmap threshold as fresh mappings, and trims freed memory at the
top of its heap back to the system, so each such buffer faults in again, page by page, zeroed by the kernel,
in every frame. Kept on the heap, a freed buffer serves the next frame's."""

from __future__ import annotations

import ctypes
import sys

__all__ = ["reuse_freed_memory"]

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)
MMAP_ABOVE = 32 << 20  # glibc's largest mmap threshold on 64-bit systems
KEEP_FREED = 256 << 20  # freed memory kept for reuse before any is handed back


def reuse_freed_memory() -> bool:
    """On glibc: blocks up to ``MMAP_ABOVE`` come from the heap and up to ``KEEP_FREED`` of freed memory is
    kept for reuse (True). Elsewhere it does nothing (False). Process-wide, and memory that was in use once
    stays with the process: for the CLI's frame loops, never done on import."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt  # the C library the interpreter runs on
    except (OSError, AttributeError):  # pragma: no cover - a libc without mallopt
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_ABOVE)) and bool(mallopt(_M_TRIM_THRESHOLD, KEEP_FREED))
