"""The README is for users: short, and its links lead somewhere (its demo table is checked against what
`make demo` writes in tests/cli/test_cli.py, where the demo runs)."""

from __future__ import annotations

import re

from helpers import ROOT

README = (ROOT / "README.md").read_text()


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
