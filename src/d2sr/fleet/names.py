"""Where each recording of a fleet goes in its output folder: a name read from its path, made safe."""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Sequence
from pathlib import Path

from d2sr.errors import D2SRError, InputError
from d2sr.fleet.ledger import LEDGER
from d2sr.frames import detect_format

__all__ = ["output_names"]

_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]")
# A recording read into a folder of outputs (a PNG folder, a ROS 2 bag) loses its file suffix; a ROS 1 bag
# out is a file and keeps it.
_SUFFIXES = (".bag", ".npz", ".mcap", ".db3")


def output_names(recordings: Sequence[Path]) -> list[str]:
    """Each recording's name in the fleet's output folder, in order: its file or folder name (less a file
    suffix where the output is a folder), with characters outside ``[A-Za-z0-9._+-]`` as ``_`` and never
    hidden; recordings of the same name are told apart by their parent folders (``robot1__cam0``), or
    where that is not enough, by a hash of their path. A recording given twice is refused."""
    paths = [Path(r) for r in recordings]
    seen: dict[Path, Path] = {}
    for p in paths:
        key = p.resolve()
        if key in seen:
            raise InputError(f"{p}: given twice (also as {seen[key]})")
        seen[key] = p
    parts = [_parts(p) for p in paths]
    depth = [1] * len(paths)
    while True:
        names = ["__".join(ps[-d:]) for ps, d in zip(parts, depth, strict=True)]
        clash = {n for n in names if names.count(n) > 1}
        if not clash:
            return names
        grown = False
        for i, n in enumerate(names):
            if n in clash and depth[i] < len(parts[i]):
                depth[i] += 1
                grown = True
        if not grown:  # alike once made safe ("a:b", "a;b"): the path's hash tells them apart
            return [f"{n}-{_hash(p)}" if n in clash else n for n, p in zip(names, paths, strict=True)]


def _parts(path: Path) -> list[str]:
    """The recording's path, outermost first, as safe name parts; its own name last (less its suffix where
    its output is a folder)."""
    resolved = path.resolve()
    own = resolved.name
    if own.lower().endswith(_SUFFIXES) and _out_is_folder(path):
        own = own[: own.rfind(".")]
    if own.lower() == LEDGER:  # the fleet's own record has that name in the folder
        own += "_"
    parts = [*resolved.parent.parts[1:], own]
    return [_safe(p) for p in parts]


def _out_is_folder(path: Path) -> bool:
    try:
        return detect_format(path) != "ros1"
    except (D2SRError, OSError):
        return True  # it fails later, as its own recording; its name only has to be stable


def _safe(part: str) -> str:
    name = _UNSAFE.sub("_", part) or "_"
    return "_" + name[1:] if name.startswith(".") else name


def _hash(path: Path) -> str:
    return hashlib.sha256(os.fsencode(path.resolve())).hexdigest()[:8]
