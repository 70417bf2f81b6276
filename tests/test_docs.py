"""The documentation runs: docs/api.md's examples in order, in a fresh folder."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_api_examples_run(tmp_path, monkeypatch):
    blocks = _blocks((DOCS / "api.md").read_text())
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {"__name__": "api_md"}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        for i, code in enumerate(blocks):
            try:
                exec(compile(code, f"docs/api.md block {i + 1}", "exec"), scope)
            except Exception as exc:
                raise AssertionError(f"docs/api.md block {i + 1} fails: {exc!r}\n{code}") from exc
    printed = out.getvalue()
    assert "frame,score,interfered" in printed and "float32" in printed
    assert "depth must be a 2-D image" in printed
    assert printed.startswith("True")  # the example frame is flagged, and repaired closer to the truth
    before, after = re.search(r"(\d+) mm -> (\d+) mm", printed).groups()
    assert int(after) < int(before) / 2
    assert (tmp_path / "repaired" / "masks").is_dir() and (tmp_path / "flags.csv").is_file()
