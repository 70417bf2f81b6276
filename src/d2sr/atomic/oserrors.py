"""The operating system's refusals while writing an output, as one line."""

from __future__ import annotations

import contextlib
import errno
from collections.abc import Iterator
from pathlib import Path

from d2sr.errors import OutputError

__all__ = ["writing"]

_NO_SPACE = (errno.ENOSPC, errno.EDQUOT)


@contextlib.contextmanager
def writing(where: Path) -> Iterator[None]:
    """Turn the operating system's refusals while writing an output (no permission, a full disk, a
    read-only file system) into one OutputError naming ``where``."""
    try:
        yield
    except OutputError:
        raise
    except OSError as exc:
        if exc.errno in _NO_SPACE:
            why = "the disk is full"
        elif exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
            why = "permission denied" if exc.errno != errno.EROFS else "read-only file system"
        else:
            why = exc.strerror or type(exc).__name__
        raise OutputError(f"cannot write {exc.filename or where}: {why}") from None
