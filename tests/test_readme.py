"""The README is for users: short, its links lead somewhere, and its demo table is what `make demo` writes."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from helpers import d2sr_inprocess

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _table(text: str, first: str) -> list[list[str]]:
    """The markdown table whose header row starts with ``| first |``: header and rows, cells stripped."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first} |"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        if not set(line) <= set("|-: "):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def test_readme_is_short():
    words = len(re.sub(r"```.*?```", " ", README, flags=re.S).split()) + len(
        " ".join(re.findall(r"```.*?```", README, flags=re.S)).split()
    )
    assert words <= 1500, words


def test_readme_links_lead_to_files():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README):
        if target.startswith("http"):
            continue
        assert (ROOT / target).exists(), target


@pytest.mark.slow  # the demo itself, 20 simulated seconds of three controllers (about 30 s)
def test_readme_demo_table_is_what_make_demo_writes(tmp_path):
    code, _, err = d2sr_inprocess("demo", "--out", str(tmp_path / "demo"))
    assert code == 0, err
    written = _table((tmp_path / "demo" / "report.md").read_text(), "controller")
    quoted = _table(README, "controller")
    fps = written[0].index("fps")
    assert [r[:fps] + r[fps + 1 :] for r in quoted] == [r[:fps] + r[fps + 1 :] for r in written]
