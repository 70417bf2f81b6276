"""Outputs: written under a temporary name and renamed at the end (a failed or killed run leaves nothing
half-written), and never at the cost of a file d2sr did not make.

The policy, one place for every command:

- ``check_out`` runs before any work: ``--out`` may not be the input, inside it or around it, nor the
  current folder or one of its parents; an existing non-empty output is refused unless ``overwrite``.
  It first ``tidy``-es the output's place: a commit a kill interrupted is finished or rolled back, and
  temporaries a killed run left are removed.
- Every temporary d2sr makes beside an output carries its marker in its name
  (``.<name>.d2sr-<pid>-<random>.tmp``); only such names are ever removed, and only once their process
  has ended.
- A folder d2sr writes carries a manifest (``.d2sr-manifest.json``: the files it made). ``commit``
  replaces only those files when it writes the folder again; every other file and folder in it is kept.
  A non-empty folder without a manifest is never replaced, and a manifest is data: an entry that is not
  a plain relative path inside its folder refuses the whole folder, and nothing is deleted.
- Replacing a folder takes two renames; a journal written before them lets the next run on the same
  output finish the commit or undo it, so a kill at any point loses nothing of the user's.
- A single file is replaced (with ``overwrite``) only when it is recognisably d2sr's (``made_by_d2sr``:
  its header or metadata says so); a user's file of that name is refused.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import shutil
import signal
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path

from d2sr.errors import OutputError

__all__ = [
    "CALLER",
    "CSV_HEADERS",
    "MANIFEST",
    "atomic_dir",
    "atomic_file",
    "atomic_write",
    "check_out",
    "commit",
    "discard",
    "listed",
    "made_by_d2sr",
    "ours",
    "record_manifest",
    "sibling",
    "temp_for",
    "tidy",
    "writing",
]

MANIFEST = ".d2sr-manifest.json"
CALLER = "/d2sr"  # the caller id of the connections d2sr adds to a ROS 1 bag
CSV_HEADERS = ("frame,score,interfered", "frame,score,interfered,reason")  # CSV files d2sr writes
_PNG_TEXT = b"tEXtSoftware\x00d2sr"  # matplotlib's metadata={"Software": "d2sr ..."}
_PEEK = 1 << 16  # bytes read to recognise a file
_MARK = "d2sr"  # in the name of every temporary d2sr leaves beside an output


def made_by_d2sr(path: Path) -> bool:
    """Whether the existing file ``path`` is one d2sr wrote, by what it says of itself: a CSV's header, a
    JSON object's ``made_by``, a PNG's Software text, a Rerun recording's application id, a ROS 1 bag's
    connection from ``CALLER``."""
    from d2sr.provenance import MADE_BY  # the key stamp writes (provenance stamps what atomic commits)

    suffix = path.suffix.lower()
    if path.is_symlink() or not path.is_file():
        return False
    if suffix == ".json":
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, ValueError):
            return False
        return isinstance(data, dict) and str(data.get(MADE_BY, "")).startswith("d2sr")
    try:
        with open(path, "rb") as fh:
            head = fh.read(_PEEK)
    except OSError:
        return False
    if suffix == ".csv":
        return head.split(b"\n", 1)[0].rstrip(b"\r").decode("utf-8", "replace") in CSV_HEADERS
    if suffix == ".png":
        return head.startswith(b"\x89PNG") and _PNG_TEXT in head
    if suffix == ".rrd":
        return head.startswith(b"RRF") and b"d2sr" in head
    if suffix == ".bag":
        return head.startswith(b"#ROSBAG V2.0") and _bag_by_d2sr(path)
    return False


def _bag_by_d2sr(path: Path) -> bool:
    try:
        from rosbags.rosbag1 import Reader

        with Reader(path) as bag:
            return any(getattr(c.ext, "callerid", None) == CALLER for c in bag.connections)
    except Exception:  # rosbags raises its own errors on a damaged bag: then it is not ours to replace
        return False


def _abs(path: Path) -> Path:
    """Absolute and normalized, without following links (``.`` and ``..`` resolved)."""
    return Path(os.path.abspath(os.fspath(path)))


def _real(path: Path) -> Path:
    return Path(os.path.realpath(os.fspath(path)))


def check_out(
    out: Path,
    *,
    is_dir: bool,
    overwrite: bool = False,
    inputs: Iterable[Path | None] = (),
    resume: bool = False,
    option: str = "--out",
) -> Path:
    """Refuse an output path that would destroy something d2sr did not make; the absolute path otherwise.

    ``resume``: an existing folder d2sr made is taken as it is (a run folder a command resumes)."""
    if not os.fspath(out).strip():
        raise OutputError(f"{option} is empty; name a new file or folder")
    if "\x00" in os.fspath(out):
        raise OutputError(f"{option} holds a NUL character; name a new file or folder")
    path = _abs(out)
    real, cwd = _real(path), _real(Path.cwd())
    if real == Path(real.anchor) or real == cwd or real in cwd.parents or real == _real(Path.home()):
        raise OutputError(
            f"{option} {out} is the current folder, one of its parents or your home; name a new one"
        )
    for src in inputs:
        if src is None:
            continue
        s = _real(Path(src))
        if real == s or s in real.parents or real in s.parents:
            how = "is" if real == s else "is inside" if s in real.parents else "contains"
            raise OutputError(f"{option} {out} {how} the input ({src}); d2sr never writes over its input")
    if path.parent.exists() and not path.parent.is_dir():
        raise OutputError(f"{option} {out}: {path.parent} is a file, not a folder")
    tidy(path)
    if not (path.exists() or path.is_symlink()):
        _check_writable(path.parent, option, out)
        return path
    if is_dir:
        if not path.is_dir() or path.is_symlink():
            raise OutputError(f"{option} {out} exists and is not a folder; name a new folder")
        if not any(path.iterdir()):
            _check_writable(path.parent, option, out)
            return path
        if not (path / MANIFEST).is_file():
            raise OutputError(
                f"{option} {out} exists and holds files d2sr did not make (no {MANIFEST}); d2sr never "
                "replaces such a folder: name a new or empty folder"
            )
        _made(path)  # a manifest that names anything outside its folder is refused here, before any work
        if resume:
            return path
        if not overwrite:
            raise OutputError(
                f"{option} {out} exists and is not empty; pass --overwrite to replace what d2sr wrote there "
                "(other files are kept), or name a new folder"
            )
        _check_writable(path.parent, option, out)
        return path
    if path.is_dir() or path.is_symlink():
        raise OutputError(f"{option} {out} is a folder or a link; name a file")
    if not made_by_d2sr(path):
        raise OutputError(f"{option} {out} exists and d2sr did not write it; name a new file")
    if not overwrite:
        raise OutputError(f"{option} {out} exists; pass --overwrite to replace it")
    _check_writable(path.parent, option, out)
    return path


def _check_writable(parent: Path, option: str, out: Path) -> None:
    """The folder an output lands in can take it (checked before any work, not after)."""
    while not parent.exists():
        parent = parent.parent
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {out}: cannot write in {parent} (permission denied)")


def _token() -> str:
    return f"{_MARK}-{os.getpid()}-{secrets.token_hex(4)}"


def sibling(path: Path, kind: str) -> Path:
    """A fresh name beside ``path`` that carries d2sr's marker: ``.<name>.d2sr-<pid>-<random>.<kind>``."""
    path = _abs(path)
    return path.with_name(f".{path.name}.{_token()}.{kind}")


def temp_for(path: Path, is_dir: bool) -> Path:
    """A fresh temporary file or folder next to ``path`` (same file system, so the rename is atomic), named
    ``.<name>.d2sr-<pid>-<random>.tmp`` so that a later run can tell it is d2sr's and whether its process
    still runs."""
    path = _abs(path)
    if not path.name:
        raise OutputError(f"{path}: not a usable output path")
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        tidy(path)  # what a killed run left for this output goes before a new temporary comes
        mask = _umask()  # outputs get the usual permissions (umask applies)
        for _ in range(100):
            tmp = path.with_name(f".{path.name}.{_token()}.tmp{'' if is_dir else path.suffix}")
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


def ours(path: Path, kinds: tuple[str, ...] = ("tmp", "old")) -> tuple[str, int] | None:
    """``(kind, pid)`` when ``path``'s name is one of d2sr's temporaries (``.<name>.d2sr-<pid>-<hex>.<kind>``
    with ``kind`` in ``kinds``), else None."""
    m = re.fullmatch(rf"\..+\.{_MARK}-(\d+)-[0-9a-f]+\.([a-z]+)(?:\..*)?", path.name)
    if m is None or m.group(2) not in kinds:
        return None
    return m.group(2), int(m.group(1))


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid < 2**31  # another user's process: leave its files alone
    return True


def _temporaries(path: Path) -> list[Path]:
    prefix = f".{path.name}.{_MARK}-"
    try:
        names = [n for n in os.listdir(path.parent) if n.startswith(prefix)]
    except OSError:
        return []
    return [path.parent / n for n in sorted(names)]


def _journal(path: Path) -> Path:
    return path.with_name(f".{path.name}.{_MARK}-commit.json")


def tidy(path: Path) -> None:
    """Before writing ``path``: finish or undo a folder commit that a kill interrupted (its journal says
    which), then remove the temporaries of ``path`` that d2sr made in a process that has ended. A
    leftover that may hold a user's file is never removed; it is named in a warning instead."""
    path = _abs(path)
    if not path.parent.is_dir():
        return
    _resume_commit(path)
    for tmp in _temporaries(path):
        kind = ours(tmp)
        if kind is None or _alive(kind[1]):
            continue
        with contextlib.suppress(OSError):
            if kind[0] == "tmp":
                discard(tmp)
            elif tmp.is_dir() and not tmp.is_symlink():
                _prune(tmp)  # an old folder left empty; one that holds files stays
    left = [t for t in _temporaries(path) if (k := ours(t)) and k[0] == "old" and not _alive(k[1])]
    if left:
        from d2sr.ui import warn

        warn(f"{left[0]} holds files an interrupted run of d2sr moved aside; look there before deleting it")


def _confined(folder: Path, entry: object) -> str:
    """A manifest entry as a plain relative path inside ``folder``; OutputError for anything else."""
    bad = OutputError(
        f"{folder / MANIFEST} lists {entry!r}, which is not a file inside {folder}; the folder is "
        "refused and nothing is deleted"
    )
    if not isinstance(entry, str) or not entry or "\x00" in entry or os.path.isabs(entry):
        raise bad
    norm = os.path.normpath(entry)
    parts = Path(norm).parts
    if not parts or norm in (".", MANIFEST) or ".." in parts or parts[0] in ("/", "\\"):
        raise bad
    parent = folder
    for part in parts[:-1]:  # no link on the way: the entry must live in this folder, not behind a link
        parent = parent / part
        if parent.is_symlink():
            raise bad
    return norm


def _made(folder: Path) -> set[str]:
    """The files d2sr made in an existing output folder (its manifest); refuses a folder it did not make,
    and a manifest that names anything outside it."""
    if not any(folder.iterdir()):
        return set()
    try:
        listed = json.loads((folder / MANIFEST).read_text())["files"]
    except (OSError, ValueError, KeyError, TypeError):
        raise OutputError(
            f"{folder} holds files d2sr did not make (no valid {MANIFEST}); not replaced"
        ) from None
    if not isinstance(listed, list):
        raise OutputError(f"{folder / MANIFEST}: 'files' is not a list; the folder is refused")
    return {_confined(folder, f) for f in listed}


def _files(root: Path) -> list[str]:
    """Every file and link under ``root``, relative, without following links."""
    found = []
    for top, dirs, files in os.walk(root):
        rel = Path(top).relative_to(root)
        found += [str(rel / f) for f in files]
        found += [str(rel / d) for d in dirs if (Path(top) / d).is_symlink()]
    return sorted(os.path.normpath(f) for f in found)


def _empty_dirs(root: Path) -> list[str]:
    """Folders under ``root`` (not ``root``) that hold nothing, relative."""
    found = []
    for top, dirs, files in os.walk(root):
        if Path(top) != root and not dirs and not files:
            found.append(os.path.normpath(str(Path(top).relative_to(root))))
    return sorted(found)


def listed(folder: Path) -> set[str]:
    """The files ``folder``'s manifest says d2sr made there (none without a manifest)."""
    return _made(folder) if (folder / MANIFEST).is_file() else set()


def record_manifest(folder: Path, files: Iterable[str] | None = None) -> None:
    """Write ``folder``'s manifest. ``files=None``: everything in it (a fresh temporary folder, all
    d2sr's); else the files named, added to those the manifest already lists (a folder written in place,
    where a user may have put files of their own)."""
    from d2sr.provenance import stamp

    if files is None:
        listed = {f for f in _files(folder) if f != MANIFEST}
    else:
        listed = (_made(folder) if (folder / MANIFEST).is_file() else set()) | {
            _confined(folder, f) for f in files
        }
    text = json.dumps(stamp({"files": sorted(listed)}), indent=1)
    with writing(folder):
        (folder / MANIFEST).write_text(text + "\n", errors="surrogateescape")


def _prune(root: Path) -> None:
    """Remove the folders under ``root`` (and ``root``) that are empty, deepest first."""
    for top, _dirs, _files in sorted(os.walk(root), key=lambda t: -len(t[0])):
        with contextlib.suppress(OSError):
            Path(top).rmdir()


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


def commit(tmp: Path, path: Path) -> None:
    """Move a finished temporary output into place. A file replaces a file; a folder replaces only what
    d2sr made in an old folder of that name, and keeps everything else in it."""
    path = _abs(path)
    with _no_interrupt(), writing(path):
        if not tmp.is_dir():
            if path.is_dir():
                raise OutputError(f"{path} is a folder; not replaced by a file")
            os.replace(tmp, path)
            return
        if not path.exists() and not path.is_symlink():
            record_manifest(tmp)
            tmp.rename(path)
            return
        if not path.is_dir() or path.is_symlink():
            raise OutputError(f"{path} exists and is not a folder; not replaced")
        made = _made(path)
        keep = [f for f in _files(path) if f not in made and f != MANIFEST]
        clash = [f for f in keep if (tmp / f).exists() or (tmp / f).is_symlink()]
        if clash:
            raise OutputError(f"{path / clash[0]} is not d2sr's and the new output has a file of that name")
        record_manifest(tmp)
        old = path.with_name(f".{path.name}.{_token()}.old")
        _write_journal(path, {"old": old.name, "tmp": tmp.name})
        path.rename(old)
        tmp.rename(path)
        _settle(path, old)
        _journal(path).unlink()


def _write_journal(path: Path, entries: dict[str, str]) -> None:
    from d2sr.provenance import MADE_BY

    tmp = path.with_name(f".{path.name}.{_token()}.tmp.json")
    tmp.write_text(json.dumps({MADE_BY: "d2sr", **entries}) + "\n")
    os.replace(tmp, _journal(path))


def _settle(path: Path, old: Path) -> None:
    """The second half of a folder commit: the user's files and empty folders go back from ``old`` into
    the new ``path``; what d2sr made there goes; ``old`` goes once empty."""
    made = _made(old) if (old / MANIFEST).is_file() else set()
    for f in [f for f in _files(old) if f not in made and f != MANIFEST]:
        if (path / f).exists() or (path / f).is_symlink():
            continue  # cannot happen after commit's clash check; never overwrite, leave it in old
        (path / f).parent.mkdir(parents=True, exist_ok=True)
        (old / f).rename(path / f)
    for d in _empty_dirs(old):
        if not (path / d).exists():
            (path / d).mkdir(parents=True, exist_ok=True)
    for f in [*made, MANIFEST]:
        if (old / f).is_file() or (old / f).is_symlink():
            (old / f).unlink()
    for d in _empty_dirs(old):  # what is left empty now is d2sr's folders (the user's were copied)
        _prune(old / d)
    _prune(old)


def _resume_commit(path: Path) -> None:
    """Finish a folder commit a kill interrupted. Its journal names the old folder: if the new output never
    arrived, the old one goes back as it was; if it did, the user's files move over from the old one."""
    journal = _journal(path)
    if not journal.is_file() or journal.is_symlink():
        return
    try:
        data = json.loads(journal.read_text())
        old = path.with_name(str(data["old"]))
    except (OSError, ValueError, KeyError, TypeError):
        return
    kind = ours(old, ("old",))
    if kind is None or old.parent != path.parent or not old.is_dir() or old.is_symlink():
        with contextlib.suppress(OSError):
            if not old.exists():
                journal.unlink()
        return
    with _no_interrupt():
        if not path.exists() and not path.is_symlink():
            old.rename(path)  # the new output never arrived: the previous one comes back whole
        elif path.is_dir() and not path.is_symlink():
            _settle(path, old)
        else:
            return
        journal.unlink()


def discard(tmp: Path) -> None:
    with _no_interrupt():
        if tmp.is_dir() and not tmp.is_symlink():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()


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


@contextlib.contextmanager
def _atomic(path: Path, is_dir: bool) -> Iterator[Path]:
    tmp = temp_for(path, is_dir)
    try:
        with writing(path):
            yield tmp
        commit(tmp, path)
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
