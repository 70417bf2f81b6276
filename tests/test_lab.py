"""The lab (not installed) stays runnable where the product's docs point at it: every ``python -m lab.NAME``
the README, docs/ and the Makefile name is a module of today's lab that compiles, and imports on today's
d2sr (scripts that run at import are only compiled)."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_lab_scripts_the_docs_name_run_on_today_s_d2sr():
    texts = [ROOT / "README.md", ROOT / "Makefile", *(ROOT / "docs").glob("*.md")]
    named = {m for t in texts for m in re.findall(r"python -m lab\.(\w+)", t.read_text())} - {"NAME"}
    assert named, "the docs name no lab script"
    for name in sorted(named):
        path = ROOT / "lab" / f"{name}.py"
        assert path.is_file(), name
        tree = ast.parse(path.read_text())
        guarded = any(
            isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) for n in tree.body
        )  # a main guard: importing runs nothing
        if guarded:
            importlib.import_module(f"lab.{name}")
