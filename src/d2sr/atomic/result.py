"""A JSON result, stamped with the run that made it and written whole."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from d2sr.atomic.placing import atomic_write
from d2sr.provenance import stamp

__all__ = ["write_result"]


def write_result(
    result: dict[str, Any],
    path: Path | None,
    *,
    models: Iterable[str | Path] = (),
    folder: Path | None = None,
    data: str | dict[str, Any] | None = None,
) -> str:
    """The result as JSON text, stamped with its provenance (``d2sr.provenance.record``: this process's
    command, commit, version, ``models`` hashed in ``folder``, ``data``, CPU, date); also written atomically
    to ``path`` when given."""
    text = json.dumps(stamp(result, models=models, folder=folder, data=data), indent=1)
    if path is not None:
        atomic_write(path, text + "\n")
    return text
