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
    assert "[('recording', 'done', 3)]" in printed and (tmp_path / "fleet" / "fleet.json").is_file()
    assert "2.0 0.25 0.0" in printed  # depth carried along the colour, not across its edge
    assert re.search(r"d2sr \d+\.\d% of frames interfered\nrobust \d+\.\d% of frames interfered", printed)


FIGURE = re.compile(
    r"\d+\.\d+ ?(%|(ms|fps|cm|min)\b)"  # a measured decimal
    r"|(?<![\w.-])-\d+(\.\d+)?%"  # a signed change (not a range such as 40-80%)
    r"|\b\d+ of \d+ (frames|cells|checks|configurations)\b"  # a count
)
DATED = re.compile(r"\b20\d\d-\d\d-\d\d\b|\b0\.\d+\.\d+\b|\bat [0-9a-f]{7}\b|\bdata version \d+\b")


def _paragraphs(text: str) -> list[str]:
    """Prose paragraphs; a table, or a block after a paragraph that ends in a colon, belongs to the paragraph
    before it (its caption); code is left out."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    out: list[str] = []
    for block in re.split(r"\n\s*\n", text):
        lines = [ln for ln in block.splitlines() if not ln.startswith("#")]
        if not lines:
            continue
        if out and (lines[0].startswith("|") or out[-1].endswith(":")):
            out[-1] += "\n" + "\n".join(lines)
        else:
            out.append("\n".join(lines))
    return out


def test_figures_quoted_in_prose_carry_their_date_or_version():
    """Issue 45: a measured figure in the user docs says when (a date, a release, or the commit) it was
    measured, in its own paragraph or its table's caption."""
    undated = [
        f"{page.name}: {para.splitlines()[0][:80]}"
        for page in sorted(DOCS.glob("*.md"))
        for para in _paragraphs(page.read_text())
        if FIGURE.search(para) and not DATED.search(para)
    ]
    assert not undated, "undated figures:\n" + "\n".join(undated)


def test_the_dating_rule_sees_an_undated_figure():
    assert FIGURE.search("RMSE -63.0% on set A") and not DATED.search("RMSE -63.0% on set A")
    assert _paragraphs("Caption (2026-11-26).\n\n| a | 1.5 ms |\n\n## H\nText 2.0 ms.") == [
        "Caption (2026-11-26).\n| a | 1.5 ms |",
        "Text 2.0 ms.",
    ]


def test_every_relative_link_in_the_docs_and_the_lab_notes_resolves():
    """A newcomer found 10 links in README and docs/ that led nowhere (docs/fill.md to lab/notes/decisions.md,
    written from a folder it was not in), and the lab notes' moved with them."""
    root = DOCS.parent
    pages = [root / "README.md", root / "CHANGELOG.md", *DOCS.rglob("*.md"), *(root / "lab").rglob("*.md")]
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue  # a web address, a mail, an anchor on the page
            if not (page.parent / target.split("#")[0]).exists():
                broken.append(f"{page.relative_to(root)}: {target}")
    assert not broken, broken


def test_no_two_commands_of_one_example_write_the_same_output():
    """docs/fill.md's two examples both wrote --out filled/: run in turn, the second was refused."""
    root = DOCS.parent
    clashes = []
    for page in [root / "README.md", *DOCS.rglob("*.md")]:
        for block in re.findall(r"```bash\n(.*?)```", page.read_text(), flags=re.S):
            outs = re.findall(r"^d2sr .*?--out (\S+)", block, flags=re.M)
            clashes += [f"{page.name}: {o}" for o in set(outs) if outs.count(o) > 1]
    assert not clashes, clashes
