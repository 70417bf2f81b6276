"""Names and marks: what d2sr calls the temporaries beside an output, and how it tells a file, a
temporary or a working folder of its own from a user's."""

from __future__ import annotations

import json
import os
import re
import secrets
from pathlib import Path

__all__ = [
    "CALLER",
    "CSV_HEADERS",
    "HTML_MARK",
    "MANIFEST",
    "MARK",
    "absolute",
    "alive",
    "cell",
    "journal",
    "journals",
    "made_by_d2sr",
    "ours",
    "real",
    "sibling",
    "temporaries",
    "token",
]

MANIFEST = ".d2sr-manifest.json"
CALLER = "/d2sr"  # the caller id of the connections d2sr adds to a ROS 1 bag
# The first lines of the CSV files d2sr writes: today's first, then those earlier versions wrote.
CSV_HEADERS = ("frame,score,interfered,reason", "frame,score,interfered")
_PNG_TEXT = b"tEXtSoftware\x00d2sr"  # matplotlib's metadata={"Software": "d2sr ..."}
_PEEK = 1 << 16  # bytes read to recognise a file
MARK = "d2sr"  # in the name of every temporary d2sr leaves beside an output
HTML_MARK = b"<meta name='generator' content='d2sr'>"  # in the head of every page d2sr writes


def made_by_d2sr(path: Path) -> bool:
    """Whether the existing file ``path`` is one d2sr wrote, by what it says of itself: a CSV's header, a
    JSON object's ``made_by``, a PNG's Software text, a Rerun recording's application id, a ROS 1 bag's
    connection from ``CALLER``, an HTML report's generator (``HTML_MARK``), a stored scene's format."""
    from d2sr.provenance import MADE_BY  # the key stamp writes (provenance stamps what atomic commits)

    suffix = path.suffix.lower()
    if path.is_symlink() or not path.is_file():
        return False
    if suffix == ".json":
        from d2sr.config import read_json

        try:
            data = read_json(Path(path))
        except (OSError, ValueError):  # too large, too deep or no JSON: no file of ours
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
    if suffix == ".html":
        return head.startswith(b"<!doctype html>") and HTML_MARK in head[:512]
    if suffix == ".npz":
        return _npz_by_d2sr(path)
    return False


def _npz_by_d2sr(path: Path) -> bool:
    """A stored scene's ``meta`` says it is d2sr's (read as data: no pickle)."""
    import zipfile

    import numpy as np

    try:
        with np.load(path, allow_pickle=False) as z:
            # A stored scene's meta is a few hundred bytes: a larger member is no scene of ours, and is not
            # read (510 kB of it took 1.1 GB and 15 s).
            if "meta" not in z.files or z.zip.getinfo("meta.npy").file_size > 1 << 16:
                return False
            meta = json.loads(z["meta"].tobytes().decode())
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, UnicodeDecodeError, RecursionError):
        return False
    return isinstance(meta, dict) and str(meta.get("format", "")).startswith("d2sr")


def _bag_by_d2sr(path: Path) -> bool:
    try:
        from rosbags.rosbag1 import Reader

        with Reader(path) as bag:
            return any(getattr(c.ext, "callerid", None) == CALLER for c in bag.connections)
    except Exception:  # rosbags raises its own errors on a damaged bag: then it is not ours to replace
        return False


def cell(text: str) -> str:
    """A name as a CSV cell a spreadsheet shows as text: one that starts as a formula would (=, +, -, @, a
    tab or carriage return) gets a leading apostrophe, as spreadsheets expect for text that looks like a
    formula (a frame named ``=HYPERLINK(...)`` ran as one)."""
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def absolute(path: Path) -> Path:
    """Absolute and normalized, without following links (``.`` and ``..`` resolved)."""
    return Path(os.path.abspath(os.fspath(path)))


def real(path: Path) -> Path:
    return Path(os.path.realpath(os.fspath(path)))


def token() -> str:
    return f"{MARK}-{os.getpid()}-{secrets.token_hex(4)}"


def sibling(path: Path, kind: str) -> Path:
    """A fresh name beside ``path`` that carries d2sr's marker: ``.<name>.d2sr-<pid>-<random>.<kind>``."""
    path = absolute(path)
    return path.with_name(f".{path.name}.{token()}.{kind}")


def ours(path: Path, kinds: tuple[str, ...] = ("tmp", "old")) -> tuple[str, int] | None:
    """``(kind, pid)`` when ``path``'s name is one of d2sr's temporaries (``.<name>.d2sr-<pid>-<hex>.<kind>``
    with ``kind`` in ``kinds``), else None."""
    m = re.fullmatch(rf"\..+\.{MARK}-(\d+)-[0-9a-f]+\.([a-z]+)(?:\..*)?", path.name)
    if m is None or m.group(2) not in kinds:
        return None
    return m.group(2), int(m.group(1))


def alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid < 2**31  # another user's process: leave its files alone
    return True


def temporaries(path: Path) -> list[Path]:
    prefix = f".{path.name}.{MARK}-"
    try:
        names = [n for n in os.listdir(path.parent) if n.startswith(prefix)]
    except OSError:
        return []
    return [path.parent / n for n in sorted(names)]


def journal(path: Path) -> Path:
    """A folder commit's journal beside ``path``: one per run (``ours`` reads its pid, kind ``journal``), so
    that two runs replacing one output never share one."""
    return sibling(path, "journal.json")


def journals(path: Path) -> list[Path]:
    """The commit journals beside ``path`` of runs that ended, or of this process (``placing`` leaves out
    those of its commits in progress): a kill interrupted their commit."""
    found = []
    for p in temporaries(path):
        kind = ours(p, ("journal",))
        if kind is not None and (kind[1] == os.getpid() or not alive(kind[1])):
            found.append(p)
    return found
