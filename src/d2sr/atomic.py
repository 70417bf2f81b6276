"""Outputs: written under a temporary name and renamed at the end (a failed or killed run leaves nothing
half-written), and never at the cost of a file d2sr did not make.

The policy, one place for every command:

- ``check_out`` runs before any work: ``--out`` may not be the input, inside it or around it, nor the
  current folder or one of its parents; an existing non-empty output is refused unless ``overwrite``.
- A folder d2sr writes carries a manifest (``.d2sr-manifest.json``: the files it made). ``commit``
  replaces only those files when it writes the folder again; every other file in it is kept. A
  non-empty folder without a manifest is never replaced.
- A single file is replaced (with ``overwrite``) only when it is recognisably d2sr's (``made_by_d2sr``:
  its header or metadata says so); a user's file of that name is refused.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
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
    "made_by_d2sr",
    "record_manifest",
    "temp_for",
]

MANIFEST = ".d2sr-manifest.json"
CALLER = "/d2sr"  # the caller id of the connections d2sr adds to a ROS 1 bag
CSV_HEADERS = ("frame,score,interfered",)  # the first lines of the CSV files d2sr writes
_PNG_TEXT = b"tEXtSoftware\x00d2sr"  # matplotlib's metadata={"Software": "d2sr ..."}
_PEEK = 1 << 16  # bytes read to recognise a file


def made_by_d2sr(path: Path) -> bool:
    """Whether the existing file ``path`` is one d2sr wrote, by what it says of itself: a CSV's header, a
    JSON object's ``made_by``, a PNG's Software text, a Rerun recording's application id, a ROS 1 bag's
    connection from ``CALLER``."""
    from d2sr.provenance import MADE_BY  # the key stamp writes (provenance stamps what atomic commits)

    suffix = path.suffix.lower()
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
    if not (path.exists() or path.is_symlink()):
        return path
    if is_dir:
        if not path.is_dir() or path.is_symlink():
            raise OutputError(f"{option} {out} exists and is not a folder; name a new folder")
        if not any(path.iterdir()):
            return path
        mine = (path / MANIFEST).is_file()
        if resume and mine:
            return path
        if not overwrite:
            raise OutputError(
                f"{option} {out} exists and is not empty; pass --overwrite to replace what d2sr wrote there "
                "(other files are kept), or name a new folder"
            )
        if not mine:
            raise OutputError(
                f"{option} {out} holds files d2sr did not make (no {MANIFEST}); name a new folder"
            )
        return path
    if path.is_dir() or path.is_symlink():
        raise OutputError(f"{option} {out} is a folder or a link; name a file")
    if not made_by_d2sr(path):
        raise OutputError(f"{option} {out} exists and d2sr did not write it; name a new file")
    if not overwrite:
        raise OutputError(f"{option} {out} exists; pass --overwrite to replace it")
    return path


def temp_for(path: Path, is_dir: bool) -> Path:
    """A fresh temporary file or folder next to ``path`` (same file system, so the rename is atomic)."""
    path = _abs(path)
    if not path.name:
        raise OutputError(f"{path}: not a usable output path")
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


def _files(root: Path) -> list[str]:
    """Every file and link under ``root``, relative, without following links."""
    found = []
    for top, dirs, files in os.walk(root):
        rel = Path(top).relative_to(root)
        found += [str(rel / f) for f in files]
        found += [str(rel / d) for d in dirs if (Path(top) / d).is_symlink()]
    return sorted(os.path.normpath(f) for f in found)


def _made(folder: Path) -> set[str]:
    """The files d2sr made in an existing output folder (its manifest); refuses a folder it did not make."""
    if not any(folder.iterdir()):
        return set()
    try:
        listed = json.loads((folder / MANIFEST).read_text())["files"]
    except (OSError, ValueError, KeyError, TypeError):
        raise OutputError(
            f"{folder} holds files d2sr did not make (no valid {MANIFEST}); not replaced"
        ) from None
    return {os.path.normpath(f) for f in listed if isinstance(f, str)}


def record_manifest(folder: Path, files: Iterable[str] | None = None) -> None:
    """Write ``folder``'s manifest. ``files=None``: everything in it (a fresh temporary folder, all
    d2sr's); else the files named, added to those the manifest already lists (a folder written in place,
    where a user may have put files of their own)."""
    from d2sr.provenance import stamp

    if files is None:
        listed = {f for f in _files(folder) if f != MANIFEST}
    else:
        listed = (_made(folder) if (folder / MANIFEST).is_file() else set()) | {
            os.path.normpath(f) for f in files
        }
    text = json.dumps(stamp({"files": sorted(listed)}), indent=1)
    (folder / MANIFEST).write_text(text + "\n")


def _prune(root: Path) -> None:
    """Remove the folders under ``root`` (and ``root``) that are empty, deepest first."""
    for top, _dirs, _files in sorted(os.walk(root), key=lambda t: -len(t[0])):
        with contextlib.suppress(OSError):
            Path(top).rmdir()


def commit(tmp: Path, path: Path) -> None:
    """Move a finished temporary output into place. A file replaces a file; a folder replaces only what
    d2sr made in an old folder of that name, and keeps everything else in it."""
    path = _abs(path)
    if not tmp.is_dir():
        if path.is_dir():
            raise OutputError(f"{path} is a folder; not replaced by a file")
        tmp.replace(path)
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
    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
    old.rmdir()
    path.rename(old)
    tmp.rename(path)
    for f in keep:  # the user's files go back where they were
        (path / f).parent.mkdir(parents=True, exist_ok=True)
        (old / f).rename(path / f)
    for f in [*made, MANIFEST]:
        if (old / f).is_file() or (old / f).is_symlink():
            (old / f).unlink()
    _prune(old)


def discard(tmp: Path) -> None:
    if tmp.is_dir() and not tmp.is_symlink():
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
    """Yield a fresh temporary folder; on success it becomes ``path`` (see ``commit``)."""
    return _atomic(path, is_dir=True)


def atomic_write(path: Path, text: str) -> None:
    """Write a text file atomically."""
    with atomic_file(path) as tmp:
        tmp.write_text(text)
