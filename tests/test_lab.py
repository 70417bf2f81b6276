"""The lab runs or leaves (issue 82): every script kept in lab/ imports on today's d2sr and answers --help
(without running: a script that does its work at import has left the lab)."""

from __future__ import annotations

import contextlib
import importlib
import io
import sys
from pathlib import Path

import pytest

LAB = Path(__file__).resolve().parents[1] / "lab"
SCRIPTS = sorted(p.stem for p in LAB.glob("*.py") if '__name__ == "__main__"' in p.read_text())
HELPERS = sorted(p.stem for p in LAB.glob("*.py") if p.stem not in SCRIPTS and p.name != "__init__.py")


def test_every_lab_module_is_a_script_or_a_helper_that_runs_nothing_at_import():
    assert len(SCRIPTS) >= 40
    assert HELPERS == ["fill_eval", "moving_set"]  # imported by scripts; they define, they do not run


@pytest.mark.parametrize("name", SCRIPTS + HELPERS)
def test_a_lab_module_imports_and_a_script_answers_help(name, monkeypatch):
    module = importlib.import_module(f"lab.{name}")
    if name in HELPERS:
        return
    monkeypatch.setattr(sys, "argv", [f"lab.{name}", "--help"])
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as done:
        module.main()
    assert done.value.code in (0, None) and "usage:" in out.getvalue()
