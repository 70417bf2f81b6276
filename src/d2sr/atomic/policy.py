"""The check every command makes of its output before any work (``check_out``)."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from d2sr.atomic.manifest import made
from d2sr.atomic.naming import MANIFEST, absolute, made_by_d2sr, real
from d2sr.atomic.placing import tidy
from d2sr.config import check_paths
from d2sr.errors import OutputError

__all__ = ["check_out"]


def check_out(
    out: Path,
    *,
    is_dir: bool,
    overwrite: bool = False,
    inputs: Iterable[Path | None] = (),
    resume: bool = False,
    name: str = "out",
) -> Path:
    """Refuse an output path that would destroy something d2sr did not make; the absolute path otherwise.

    ``resume``: an existing folder d2sr made is taken as it is (a run folder a command resumes). ``name``: the
    output's name, first in every error (the command line names its flag)."""
    inputs = list(inputs)
    check_paths(**{name: out}, **{f"input {k}": p for k, p in enumerate(inputs) if p is not None})
    if not os.fspath(out).strip():
        raise OutputError(f"{name} is empty; name a new file or folder")
    if "\x00" in os.fspath(out):
        raise OutputError(f"{name} holds a NUL character; name a new file or folder")
    path = absolute(out)
    resolved, cwd = real(path), real(Path.cwd())
    if resolved == Path(resolved.anchor) or resolved in (cwd, real(Path.home())) or resolved in cwd.parents:
        raise OutputError(
            f"{name} {out} is the current folder, one of its parents or your home; name a new one"
        )
    for src in inputs:
        if src is None:
            continue
        s = real(Path(src))
        if resolved == s or s in resolved.parents or resolved in s.parents:
            how = "is" if resolved == s else "is inside" if s in resolved.parents else "contains"
            raise OutputError(f"{name} {out} {how} the input ({src}); d2sr never writes over its input")
    if path.parent.exists() and not path.parent.is_dir():
        raise OutputError(f"{name} {out}: {path.parent} is a file, not a folder")
    tidy(path)
    if not (path.exists() or path.is_symlink()):
        _check_writable(path.parent, name, out)
        return path
    if is_dir:
        if not path.is_dir() or path.is_symlink():
            raise OutputError(f"{name} {out} exists and is not a folder; name a new folder")
        if not any(path.iterdir()):
            _check_writable(path.parent, name, out)
            return path
        if not (path / MANIFEST).is_file():
            raise OutputError(
                f"{name} {out} exists and holds files d2sr did not make (no {MANIFEST}); d2sr never "
                "replaces such a folder: name a new or empty folder"
            )
        made(path)  # a manifest that names anything outside its folder is refused here, before any work
        if resume:
            return path
        if not overwrite:
            raise OutputError(
                f"{name} {out} exists and is not empty; allow overwrite to replace what d2sr wrote there "
                "(other files are kept), or name a new folder",
                "overwrite",
            )
        _check_writable(path.parent, name, out)
        return path
    if path.is_dir() or path.is_symlink():
        raise OutputError(f"{name} {out} is a folder or a link; name a file")
    if not made_by_d2sr(path):
        raise OutputError(f"{name} {out} exists and d2sr did not write it; name a new file")
    if not overwrite:
        raise OutputError(f"{name} {out} exists; allow overwrite to replace it", "overwrite")
    _check_writable(path.parent, name, out)
    return path


def _check_writable(parent: Path, name: str, out: Path) -> None:
    """The folder an output lands in can take it (checked before any work, not after)."""
    while not parent.exists():
        parent = parent.parent
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{name} {out}: cannot write in {parent} (permission denied)")
