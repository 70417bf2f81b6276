"""What a committed result records about the run that made it, so that a reader can trace every published
figure to one run: the exact command, the git commit of the tree it ran in, the d2sr version, the models
and their hashes, the data set and its status, the CPU and the date (issue 45).

Every JSON result d2sr writes (``d2sr.atomic.write_result``, the folders' manifests, ``eval`` outputs) calls
``record``; ``python tools/results.py --check`` fails on a result under ``docs/results`` without it.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Iterable, Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path

from d2sr.version import WEIGHTS, __version__

__all__ = [
    "KEYS",
    "MADE_BY",
    "command_as",
    "command_line",
    "cpu",
    "data_read",
    "git_commit",
    "model_hashes",
    "record",
    "stamp",
]

MADE_BY = "made_by"  # the key heading every JSON file d2sr writes ("d2sr <version>"): how it knows its own
# The keys ``record`` writes; a result holding at least "command" and "commit" is traceable.
KEYS = ("command", "commit", "version", "models", "data", "cpu", "date")
ROOT = Path(__file__).resolve().parents[2]  # the checkout, when d2sr runs from one (else no commit)
TRACKED = ("src", "bench", "configs", "lab", "tools")  # a change here changes what a run computes


def cpu() -> str:
    """The cores this process may use and the processor's name: runs on different machines differ by 3x."""
    name = platform.processor()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            name = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), name)
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return f"{cores} cores, {name or 'unknown'}"


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", *args], capture_output=True, text=True, cwd=ROOT, check=False)
    except OSError:
        return None
    return done.stdout.strip() if done.returncode == 0 else None


@functools.cache
def git_commit() -> str:
    """The commit of the checkout d2sr runs from, with ``+changes`` when its tracked code (``TRACKED``)
    differed from it; ``unknown`` for an installed package."""
    if not (ROOT / ".git").exists():
        return "unknown"
    commit = _git("rev-parse", "HEAD")
    if not commit:
        return "unknown"
    if _git("status", "--porcelain", "--untracked-files=no", *TRACKED):
        commit += "+changes"
    return commit


_ARGV: list[Sequence[str]] = []  # ``command_as``'s, innermost last


@contextlib.contextmanager
def command_as(argv: Sequence[str]) -> Iterator[None]:
    """Record ``argv`` as the command (instead of this process's ``sys.argv``) while the block runs: a
    fleet's worker process writes what the user's ``d2sr fleet`` command made, not the worker's own argv."""
    _ARGV.append(list(argv))
    try:
        yield
    finally:
        _ARGV.pop()


def command_line(argv: Sequence[str] | None = None) -> str:
    """The command as a user would type it again: ``d2sr ...`` for the CLI, ``python SCRIPT ...`` for a
    script (its path relative to the checkout), ``python -m PACKAGE.MODULE ...`` for a module of a package
    in the checkout (the lab's, run from its root)."""
    argv = list(argv if argv is not None else _ARGV[-1] if _ARGV else sys.argv)
    if not argv:
        return ""
    head, rest = argv[0], argv[1:]
    rel = None
    with contextlib.suppress(ValueError):
        rel = Path(head).resolve().relative_to(ROOT)
    # A module of a package in the checkout (``lab``, ``bench.outside``; not d2sr's own, under ``src``); a
    # package's ``__main__`` is the package.
    if rel is not None and rel.parts[0] != "src" and (ROOT / rel.parent / "__init__.py").is_file():
        parts = rel.with_suffix("").parts
        return shlex.join(["python", "-m", ".".join(parts[:-1] if parts[-1] == "__main__" else parts), *rest])
    if Path(head).name in ("d2sr", "__main__.py") or head in ("-m", "-c"):
        return shlex.join(["d2sr", *rest])
    return shlex.join(["python", str(rel) if rel is not None else head, *rest])


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:16]


def model_hashes(models: Iterable[str | Path], folder: Path | None = None) -> dict[str, str | None]:
    """Each model's weights file hashed (first 16 hex digits of its SHA-256): a registry name is looked up
    as ``NAME.safetensors`` in ``folder`` (default: the shipped weights), a path is hashed as it is;
    ``None`` when there is no such file."""
    out: dict[str, str | None] = {}
    for m in models:
        path = Path(m) if Path(m).suffix else (folder or WEIGHTS) / f"{m}.safetensors"
        out[str(m)] = _sha256(path) if path.is_file() else None
    return out


def data_read(name: str, files: Iterable[Path], root: Path) -> dict:
    """What a result read, so that one made on other data is told apart: ``name`` (the set in words), the
    files (paths under ``root``, in order), their count and bytes, and one SHA-256 over their names and
    contents."""
    digest, names, size = hashlib.sha256(), [], 0
    for f in files:
        rel = Path(f).relative_to(root).as_posix()
        body = Path(f).read_bytes()
        digest.update(rel.encode() + b"\0" + len(body).to_bytes(8, "little") + body)
        names.append(rel)
        size += len(body)
    return {"name": name, "files": names, "count": len(names), "bytes": size, "sha256": digest.hexdigest()}


def record(
    argv: Sequence[str] | None = None,
    *,
    models: Iterable[str | Path] = (),
    folder: Path | None = None,
    data: str | dict | None = None,
) -> dict:
    """The provenance of a run (``KEYS``): ``argv`` (default ``sys.argv``) as a command, the commit, the
    version, ``models`` hashed (``model_hashes``, in ``folder``), ``data`` (a set's name and status), the
    CPU and the UTC date."""
    return {
        "command": command_line(argv),
        "commit": git_commit(),
        "version": __version__,
        "models": model_hashes(models, folder),
        "data": data,
        "cpu": cpu(),
        "date": datetime.now(UTC).strftime("%Y-%m-%d"),
    }


def stamp(
    result: dict,
    *,
    models: Iterable[str | Path] = (),
    folder: Path | None = None,
    data: str | dict | None = None,
) -> dict:
    """``result`` headed by ``made_by`` and its provenance (``record``); a ``data`` key of the result's own
    replaces the record's, unless ``data`` is given too (the files read would be hidden). Any other key the
    record writes is refused: it would hide the provenance."""
    head = record(models=models, folder=folder, data=data)
    clash = set(result) & (set(head) - ({"data"} if data is None else set()))
    if clash:
        raise ValueError(f"result keys {sorted(clash)} are provenance keys")
    return {MADE_BY: f"d2sr {__version__}", **head, **result}
