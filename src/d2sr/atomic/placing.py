"""Placing an output: a fresh temporary beside it, moved into place whole (``commit``) or removed
(``discard``); a commit a kill interrupted is finished or undone by the next run (``tidy``)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

from d2sr.atomic.manifest import empty_dirs, files_under, listed, made, prune, record_manifest
from d2sr.atomic.naming import MANIFEST, absolute, alive, journal, journals, ours, temporaries, token
from d2sr.atomic.oserrors import writing
from d2sr.config import read_json
from d2sr.errors import OutputError

__all__ = ["atomic_dir", "atomic_file", "atomic_write", "commit", "discard", "state", "temp_for", "tidy"]


def temp_for(path: Path, is_dir: bool) -> Path:
    """A fresh temporary file or folder next to ``path`` (same file system, so the rename is atomic), named
    ``.<name>.d2sr-<pid>-<random>.tmp`` so that a later run can tell it is d2sr's and whether its process
    still runs."""
    path = absolute(path)
    if not path.name:
        raise OutputError(f"{path}: not a usable output path")
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        tidy(path)  # what a killed run left for this output goes before a new temporary comes
        mask = _umask()  # outputs get the usual permissions (umask applies)
        for _ in range(100):
            tmp = path.with_name(f".{path.name}.{token()}.tmp{'' if is_dir else path.suffix}")
            try:
                if is_dir:
                    tmp.mkdir(mode=0o777 & ~mask)
                else:
                    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 & ~mask))
            except FileExistsError:
                continue
            return tmp
    raise OutputError(f"{path}: could not make a temporary name beside it")  # pragma: no cover


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def tidy(path: Path) -> None:
    """Before writing ``path``: finish or undo a folder commit that a kill interrupted (its journal says
    which), then remove the temporaries of ``path`` that d2sr made in a process that has ended. A
    leftover that may hold a user's file is never removed; it is named in a warning instead."""
    path = absolute(path)
    if not path.parent.is_dir():
        return
    _resume_commit(path)
    left = []
    for tmp in temporaries(path):
        kind = ours(tmp)
        if kind is None or alive(kind[1]):
            continue
        with contextlib.suppress(OSError):
            if kind[0] == "tmp":
                discard(tmp)
            elif tmp.is_dir() and not tmp.is_symlink():
                prune(tmp)  # an old folder left empty; one that holds files stays
        if kind[0] == "old" and tmp.exists():
            left.append(tmp)
    if left:
        from d2sr.ui import warn

        warn(f"{left[0]} holds files an interrupted run of d2sr moved aside; look there before deleting it")


@contextlib.contextmanager
def _no_interrupt() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT, SIGTERM) until the block is done: a commit is not left half-way by a key press."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        for s in old:
            signal.signal(s, lambda n, _f: got.append(n))
    except ValueError:  # pragma: no cover - not the main interpreter
        yield
        return
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if got:
            signal.raise_signal(got[0])


#: What ``state`` says of a path that does not exist.
ABSENT = None


def state(path: Path) -> tuple[int, ...] | None:
    """What identifies ``path`` as it is now (not following a link): None where nothing is; a folder by its
    inode alone (its files change as d2sr writes beside them), a file by its inode, size and time too."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return ABSENT
    except OSError:
        return (-1,)  # there, but unreadable: never taken for absent
    if os.path.isdir(path) and not os.path.islink(path):
        return (st.st_dev, st.st_ino)
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


_UNKNOWN = (-2,)  # commit's ``before`` when the caller did not say


def commit(tmp: Path, path: Path, before: tuple[int, ...] | None = _UNKNOWN) -> None:
    """Move a finished temporary output into place. A file replaces a file; a folder replaces only what
    d2sr made in an old folder of that name, and keeps everything else in it. ``before``: ``state(path)``
    when the run began; what appeared or changed there since (a user's file, another run's output) is
    never replaced (an OutputError), and a new output is placed so that nothing can take its place
    meanwhile."""
    path = absolute(path)
    with _no_interrupt(), writing(path):
        if before is not _UNKNOWN and state(path) != before:
            raise OutputError(
                f"{path} appeared or changed while this run wrote it: left as it is, this run's output "
                "not kept"
            )
        if not tmp.is_dir():
            if path.is_dir():
                raise OutputError(f"{path} is a folder; not replaced by a file")
            if before is ABSENT:
                _place_new(tmp, path)
            else:
                os.replace(tmp, path)
            return
        if not path.exists() and not path.is_symlink():
            record_manifest(tmp)
            _place_new(tmp, path)
            return
        if not path.is_dir() or path.is_symlink():
            raise OutputError(f"{path} exists and is not a folder; not replaced")
        mine = made(path)
        keep = [f for f in files_under(path) if f not in mine and f != MANIFEST]
        clash = [f for f in keep if (tmp / f).exists() or (tmp / f).is_symlink()]
        if clash:
            raise OutputError(f"{path / clash[0]} is not d2sr's and the new output has a file of that name")
        record_manifest(tmp)
        old = path.with_name(f".{path.name}.{token()}.old")
        log = journal(path)
        _COMMITTING.add(log)
        try:
            _write_journal(log, {"old": old.name, "tmp": tmp.name})
            path.rename(old)
            tmp.rename(path)
            _settle(path, old)
            log.unlink()
        finally:
            _COMMITTING.discard(log)


#: The journals of this process's folder commits in progress (another thread's tidy leaves them alone).
_COMMITTING: set[Path] = set()


def _place_new(tmp: Path, path: Path) -> None:
    """Rename ``tmp`` to ``path``, which must not exist: never over something that appeared there since it
    was checked (Linux's renameat2 with RENAME_NOREPLACE; a hard link for a file where that is missing)."""
    if _rename_noreplace(tmp, path):
        return
    if not tmp.is_dir():
        try:
            os.link(tmp, path)  # fails where anything is: the check and the placing are one step
        except FileExistsError:
            raise _appeared(path) from None
        except OSError:  # a file system without hard links: the checked rename below
            pass
        else:
            os.unlink(tmp)
            return
    if path.exists() or path.is_symlink():
        raise _appeared(path)
    os.rename(tmp, path)


def _appeared(path: Path) -> OutputError:
    return OutputError(f"{path} appeared while this run wrote it: left as it is")


def _rename_noreplace(tmp: Path, path: Path) -> bool:
    """renameat2(RENAME_NOREPLACE) where the C library has it: True once done, False where unsupported, an
    OutputError where ``path`` exists."""
    import ctypes
    import errno

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, noreplace = -100, 1
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if fn(at_fdcwd, os.fsencode(tmp), at_fdcwd, os.fsencode(path), noreplace) == 0:
        return True
    err = ctypes.get_errno()
    if err == errno.EEXIST:
        raise _appeared(path)
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False  # the file system or kernel cannot: the caller's fallback
    raise OSError(err, os.strerror(err), str(path))


def _write_journal(log: Path, entries: dict[str, str]) -> None:
    from d2sr.provenance import MADE_BY

    tmp = log.with_name(f"{log.name}.{token()}.tmp.json")
    tmp.write_text(json.dumps({MADE_BY: "d2sr", **entries}) + "\n")
    os.replace(tmp, log)


def _settle(path: Path, old: Path) -> None:
    """The second half of a folder commit: the user's files and empty folders go back from ``old`` into
    the new ``path``; what d2sr made there goes; ``old`` goes once empty."""
    mine = listed(old)
    for f in [f for f in files_under(old) if f not in mine and f != MANIFEST]:
        if (path / f).exists() or (path / f).is_symlink():
            continue  # cannot happen after commit's clash check; never overwrite, leave it in old
        (path / f).parent.mkdir(parents=True, exist_ok=True)
        (old / f).rename(path / f)
    for d in empty_dirs(old):
        if not (path / d).exists():
            (path / d).mkdir(parents=True, exist_ok=True)
    for f in [*mine, MANIFEST]:
        if (old / f).is_file() or (old / f).is_symlink():
            (old / f).unlink()
    for d in empty_dirs(old):  # what is left empty now is d2sr's folders (the user's were copied)
        prune(old / d)
    prune(old)


def _resume_commit(path: Path) -> None:
    """Finish a folder commit a kill interrupted. Its journal names the old folder: if the new output never
    arrived, the old one goes back as it was; if it did, the user's files move over from the old one."""
    for log in journals(path):
        if log not in _COMMITTING:
            _resume_one(path, log)


def _resume_one(path: Path, log: Path) -> None:
    if not log.is_file() or log.is_symlink():
        return
    try:
        data = read_json(log)
        old = path.with_name(str(data["old"]))
    except (OSError, ValueError, KeyError, TypeError):
        return
    kind = ours(old, ("old",))
    if kind is None or old.parent != path.parent or not old.is_dir() or old.is_symlink():
        with contextlib.suppress(OSError):
            if not old.exists():
                log.unlink()
        return
    with _no_interrupt():
        if not path.exists() and not path.is_symlink():
            old.rename(path)  # the new output never arrived: the previous one comes back whole
        elif path.is_dir() and not path.is_symlink():
            _settle(path, old)
        else:
            return
        log.unlink()


def discard(tmp: Path) -> None:
    with _no_interrupt():
        if tmp.is_dir() and not tmp.is_symlink():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()


@contextlib.contextmanager
def _atomic(path: Path, is_dir: bool) -> Iterator[Path]:
    tmp = temp_for(path, is_dir)
    before = state(absolute(path))
    try:
        with writing(path):
            yield tmp
        commit(tmp, path, before)
    except BaseException:
        discard(tmp)
        raise


def atomic_file(path: Path) -> contextlib.AbstractContextManager[Path]:
    """Yield a temporary path next to ``path``; on success it replaces ``path``, on error it is removed."""
    return _atomic(path, is_dir=False)


def atomic_dir(path: Path) -> contextlib.AbstractContextManager[Path]:
    """Yield a fresh temporary folder; on success it becomes ``path`` (see ``commit``)."""
    return _atomic(path, is_dir=True)


def atomic_write(path: Path, text: str) -> None:
    """Write a text file atomically."""
    with atomic_file(path) as tmp:
        tmp.write_text(text, errors="surrogateescape")
