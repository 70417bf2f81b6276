"""Shared test helpers (pytest puts this folder on sys.path)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def d2sr(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the real console entry point in a fresh interpreter, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "d2sr", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        timeout=300,
    )


def d2sr_inprocess(*args: str) -> tuple[int, str, str]:
    """The console entry point in this process (fast, for many runs): (exit code, stdout with rich's line
    wrapping undone, stderr)."""
    import io
    from contextlib import redirect_stderr, redirect_stdout

    from d2sr.cli import main

    out, err = io.StringIO(), io.StringIO()
    argv, sys.argv = sys.argv, ["d2sr", *args]
    try:
        with redirect_stderr(err), redirect_stdout(out):
            main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    finally:
        sys.argv = argv
    return code, " ".join(out.getvalue().split()), err.getvalue()


def room(seed: int = 0, shape: tuple[int, int] = (480, 640), scale: float = 4000.0):
    """A wall, a floor and a box in L515 units (``scale`` per metre), with the sensor's missing returns."""
    import numpy as np

    h, w = shape
    rng = np.random.default_rng(seed)
    rows = np.arange(h, dtype=np.float32)[:, None]
    metres = np.broadcast_to(np.where(rows > h * 0.6, 1.2 + 2.0 * (h - rows) / h, 3.2), shape).copy()
    metres[h // 3 : h // 2, w // 4 : w // 2] = 1.8
    metres += rng.normal(0, 0.003, shape).astype(np.float32)
    metres[rng.random(shape) < 0.3] = 0
    return (metres * scale).astype(np.uint16)
