"""A folder's manifest (``.d2sr-manifest.json``): the files d2sr made there. It is data: an entry that is
not a plain relative path inside its folder refuses the whole folder."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterable
from pathlib import Path

from d2sr.atomic.naming import MANIFEST
from d2sr.atomic.oserrors import writing
from d2sr.config import read_json
from d2sr.errors import OutputError

MANIFEST_BYTES = 64 << 20  # a manifest of a million frames' names: larger is no manifest of ours

__all__ = ["confined", "empty_dirs", "files_under", "listed", "made", "prune", "record_manifest"]


def confined(folder: Path, entry: object) -> str:
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


def made(folder: Path) -> set[str]:
    """The files d2sr made in an existing output folder (its manifest); refuses a folder it did not make,
    and a manifest that names anything outside it."""
    if not any(folder.iterdir()):
        return set()
    try:
        listed = read_json(folder / MANIFEST, MANIFEST_BYTES)["files"]
    except (OSError, ValueError, KeyError, TypeError):
        raise OutputError(
            f"{folder} holds files d2sr did not make (no valid {MANIFEST}); not replaced"
        ) from None
    if not isinstance(listed, list):
        raise OutputError(f"{folder / MANIFEST}: 'files' is not a list; the folder is refused")
    return {confined(folder, f) for f in listed}


def files_under(root: Path) -> list[str]:
    """Every file and link under ``root``, relative, without following links."""
    found = []
    for top, dirs, files in os.walk(root):
        rel = Path(top).relative_to(root)
        found += [str(rel / f) for f in files]
        found += [str(rel / d) for d in dirs if (Path(top) / d).is_symlink()]
    return sorted(os.path.normpath(f) for f in found)


def empty_dirs(root: Path) -> list[str]:
    """Folders under ``root`` (not ``root``) that hold nothing, relative."""
    found = []
    for top, dirs, files in os.walk(root):
        if Path(top) != root and not dirs and not files:
            found.append(os.path.normpath(str(Path(top).relative_to(root))))
    return sorted(found)


def listed(folder: Path) -> set[str]:
    """The files ``folder``'s manifest says d2sr made there (none without a manifest)."""
    return made(folder) if (folder / MANIFEST).is_file() else set()


def record_manifest(folder: Path, files: Iterable[str] | None = None) -> None:
    """Write ``folder``'s manifest. ``files=None``: everything in it (a fresh temporary folder, all
    d2sr's); else the files named, added to those the manifest already lists (a folder written in place,
    where a user may have put files of their own)."""
    from d2sr.provenance import stamp

    if files is None:
        listed = {f for f in files_under(folder) if f != MANIFEST}
    else:
        listed = (made(folder) if (folder / MANIFEST).is_file() else set()) | {
            confined(folder, f) for f in files
        }
    text = json.dumps(stamp({"files": sorted(listed)}), indent=1)
    with writing(folder):
        (folder / MANIFEST).write_text(text + "\n", errors="surrogateescape")


def prune(root: Path) -> None:
    """Remove the folders under ``root`` (and ``root``) that are empty, deepest first."""
    for top, _dirs, _names in sorted(os.walk(root), key=lambda t: -len(t[0])):
        with contextlib.suppress(OSError):
            Path(top).rmdir()
