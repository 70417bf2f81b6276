"""A fleet's record of what it did (``fleet.json`` in its output folder): what each recording came to, the
settings it ran with, and the provenance. Rewritten whole after each recording, so a run that is stopped
and started again knows what is done. Read as data only: names in it are compared, never followed."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from d2sr.atomic import atomic_write
from d2sr.errors import OutputError
from d2sr.provenance import MADE_BY, stamp

__all__ = ["LEDGER", "Ledger", "Outcome", "fingerprint"]

LEDGER = "fleet.json"
MAX_BYTES = 64 << 20  # a fleet's record of a few thousand recordings is a few MB; a larger file is not one
LINE = 500  # characters a reason or warning keeps
WARNINGS = 100  # warnings a recording keeps


class Outcome(BaseModel):
    """What one recording came to: ``done`` (its output is whole) or ``failed`` (``reason``, one line)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(description="its output in the fleet's folder")
    input: str = Field(description="the recording, as given")
    status: Literal["done", "failed"]
    frames: int = Field(0, ge=0)
    flagged: int = Field(0, ge=0)
    repaired: int = Field(0, ge=0, description="frames given to the repair (the flagged ones, or all)")
    changed: int = Field(0, ge=0, description="of them, frames whose depth changed")
    pixels: int = Field(0, ge=0, description="pixels changed")
    seconds: float = Field(0.0, ge=0, description="wall time of its task, start-up included")
    reason: str = ""
    report: str | None = Field(None, description="its report.html, relative to the fleet's folder")
    # A failure of the recording's own (a broken file, a wrong scale): the recording as it was then
    # (``fingerprint``). Run again on the same recording, it would fail the same way: it is not redone.
    fingerprint: str | None = None
    warnings: list[str] = Field(default_factory=list, description="what d2sr warned of, one line each")

    @field_validator("reason")
    @classmethod
    def _one_line(cls, v: str) -> str:
        return printable(v)

    @field_validator("warnings")
    @classmethod
    def _lines(cls, v: list[str]) -> list[str]:
        """Read back from a file anyone may have written: printed, so bounded and without control codes."""
        return [printable(w) for w in v[:WARNINGS]]


def printable(text: str) -> str:
    """``text`` as one line a terminal shows as it is: control characters (an escape sequence, a carriage
    return) written as Python escapes, at most ``LINE`` characters."""
    out = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text[: 4 * LINE])
    return out if len(out) <= LINE else out[: LINE - 1] + "…"


class Ledger(BaseModel):
    """``fleet.json``: the run's settings (as the library's settings objects dump them) and outcomes."""

    model_config = ConfigDict(extra="ignore")

    settings: dict[str, Any]
    recordings: list[Outcome]

    @classmethod
    def read(cls, folder: Path) -> Ledger | None:
        """The ledger in ``folder`` (None where there is none); one that d2sr did not write is refused."""
        path = folder / LEDGER
        if not path.exists() and not path.is_symlink():
            return None
        try:
            if path.is_symlink() or not path.is_file():
                raise ValueError("not a plain file")
            if path.stat().st_size > MAX_BYTES:
                raise ValueError(f"larger than {MAX_BYTES >> 20} MB")
            data = json.loads(path.read_text(errors="strict"))
            if not isinstance(data, dict) or not str(data.get(MADE_BY, "")).startswith("d2sr "):
                raise ValueError("not written by d2sr")
            return cls.model_validate(data)
        except (OSError, UnicodeError, ValueError, RecursionError, ValidationError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise OutputError(
                f"{path}: not a d2sr fleet's record ({reason}); name a new output folder or remove it", "out"
            ) from None

    def settled(self) -> dict[str, Outcome]:
        """The outcomes a run need not redo: those done, and failures of a recording's own."""
        return {o.name: o for o in self.recordings if o.status == "done" or o.fingerprint is not None}

    def write(self, folder: Path, totals: dict[str, Any] | None = None) -> None:
        body: dict[str, Any] = {"settings": self.settings}
        if totals is not None:
            body["totals"] = totals
        body["recordings"] = [o.model_dump() for o in self.recordings]
        atomic_write(folder / LEDGER, json.dumps(stamp(body), indent=1) + "\n")


def fingerprint(path: Path) -> str:
    """What a recording is on disk, cheaply: the names, sizes and times of its file, or of the entries of
    its folder (not their contents)."""
    h = hashlib.sha256()
    try:
        st = path.stat()
        h.update(f"{st.st_size}:{st.st_mtime_ns}".encode())
        if path.is_dir():
            with os.scandir(path) as it:
                for e in sorted(it, key=lambda e: e.name):
                    es = e.stat(follow_symlinks=False)
                    h.update(f"{e.name}\0{es.st_size}:{es.st_mtime_ns}\0".encode("utf-8", "surrogateescape"))
    except OSError as exc:
        h.update(f"unreadable:{exc.errno}".encode())
    return h.hexdigest()[:16]
