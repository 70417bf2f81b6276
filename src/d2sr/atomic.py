"""Write outputs under a temporary name and rename at the end, so a failed or killed run leaves nothing
half-written: either the old output, or the complete new one."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_dir", "atomic_file", "atomic_write", "commit", "discard", "temp_for"]


def temp_for(path: Path, is_dir: bool) -> Path:
    """A fresh temporary file or folder next to ``path`` (same file system, so the rename is atomic)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # tempfile creates private (0600/0700) entries; outputs get the usual permissions (umask applies).
    mask = _umask()
    if is_dir:
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
        tmp.chmod(0o777 & ~mask)
        return tmp
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp" + path.suffix, dir=path.parent)
    os.fchmod(fd, 0o666 & ~mask)
    os.close(fd)
    return Path(name)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def commit(tmp: Path, path: Path) -> None:
    """Move a finished temporary output into place, replacing an old file or folder."""
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        old = path.with_name(f".{path.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        path.rename(old)
        tmp.rename(path)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.replace(path)


def discard(tmp: Path) -> None:
    if tmp.is_dir():
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def _atomic(path: Path, is_dir: bool) -> Iterator[Path]:
    tmp = temp_for(path, is_dir)
    try:
        yield tmp
        commit(tmp, path)
    except BaseException:
        discard(tmp)
        raise


def atomic_file(path: Path) -> contextlib.AbstractContextManager[Path]:
    """Yield a temporary path next to ``path``; on success it replaces ``path``, on error it is removed."""
    return _atomic(path, is_dir=False)


def atomic_dir(path: Path) -> contextlib.AbstractContextManager[Path]:
    """Yield a fresh temporary folder; on success it becomes ``path`` (replacing an old one)."""
    return _atomic(path, is_dir=True)


def atomic_write(path: Path, text: str) -> None:
    """Write a text file atomically."""
    with atomic_file(path) as tmp:
        tmp.write_text(text)
