"""Published figures come from the committed results: the README's table and the models' cards are written
from docs/results, and a figure that drifts from its file, or a result with no command and commit, fails."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from tools import results

from d2sr.contract.catalog import WEIGHTS
from d2sr.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def test_readme_and_cards_agree_with_docs_results():
    assert results.check() == []


def test_the_check_agrees_and_exits_zero(capsys):
    assert results.main(["--check"]) == 0
    assert "agree" in capsys.readouterr().out


@pytest.fixture
def copy(tmp_path: Path) -> tuple[Path, Path]:
    """The README, the results its table and the cards read, and the cards, in a scratch checkout."""
    root, weights = tmp_path / "repo", tmp_path / "weights"
    (root / "docs").mkdir(parents=True)
    shutil.copy(ROOT / "README.md", root / "README.md")
    shutil.copytree(ROOT / "docs" / "results", root / "docs" / "results")
    weights.mkdir()
    for card in WEIGHTS.glob("*.card.json"):
        shutil.copy(card, weights / card.name)
        md = card.name.replace(".card.json", ".md")
        shutil.copy(WEIGHTS / md, weights / md)
    assert results.check(root, weights) == []
    return root, weights


def _edit(path: Path, change) -> None:
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def test_a_figure_changed_in_its_file_is_caught_in_the_readme_and_on_the_card(copy):
    root, weights = copy
    recovery = root / results.RECOVERY

    def worse(d: dict) -> None:
        d["l515"]["unet8"]["mask_f1"] = 0.5

    _edit(recovery, worse)
    problems = results.check(root, weights)
    assert any(p.startswith("unet8.card.json: metrics") for p in problems), problems
    assert results.write(root, weights) == ["unet8.card.json"]
    card = json.loads((weights / "unet8.card.json").read_text())
    assert any("/ 0.500 /" in v for v in card["metrics"].values())
    assert results.check(root, weights) == []

    paper = root / "docs/results/paper/results.json"
    _edit(paper, lambda d: d["latency_ms"]["unet8"].update(onnxruntime=1.0))
    assert any(p.startswith("README.md") for p in results.check(root, weights))
    results.write(root, weights)
    assert "/ 1.00 ms (2-core CPU)](docs/results/paper/results.json)" in (root / "README.md").read_text()


def test_a_hand_edited_figure_on_a_card_or_its_page_is_caught(copy):
    root, weights = copy
    card = weights / "detector.card.json"
    _edit(card, lambda d: d["metrics"].update({next(iter(d["metrics"])): "0.999 / 0.999 / 0.000"}))
    assert any(p.startswith("detector.card.json: metrics") for p in results.check(root, weights))
    page = weights / "unet8.md"
    page.write_text(page.read_text().replace("Limits", "Limits (RMSE -90%)"))
    assert "unet8.md: differs from unet8.card.json (run make results)" in results.check(root, weights)


def test_a_result_without_command_and_commit_fails_unless_it_is_pending(copy):
    root, weights = copy
    (root / "docs" / "results" / "typed.json").write_text('{"rmse": 1.0}')  # a figure typed by hand
    typed = "docs/results/typed.json: records no command and clean commit of this history"
    assert any(p.startswith(typed) for p in results.check(root, weights))
    head = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout
    for commit in ("abc", "0" * 40, head.strip() + "+changes"):  # not in the history, or not clean
        (root / "docs" / "results" / "typed.json").write_text(
            json.dumps({"command": "d2sr x", "commit": commit, "rmse": 1.0})
        )
        assert any(p.startswith(typed) for p in results.check(root, weights)), commit
    (root / "docs" / "results" / "typed.json").write_text(
        json.dumps({"command": "d2sr x", "commit": head.strip(), "rmse": 1.0})
    )
    assert results.check(root, weights) == []
    waiting = results.pending(root)
    if waiting:  # a pending result regenerated must leave the list
        (root / waiting[0]).write_text(json.dumps({"command": "d2sr x", "commit": head.strip()}))
        assert any("take it off the list" in p for p in results.check(root, weights))


def test_notes_on_cards_quote_no_figures():
    """Figures on a card come from files; the hand-written notes beside them carry none."""
    for name, note in results.NOTES.items():
        assert results.digits_in(note) == [], name


def test_a_missing_source_is_one_line(copy):
    root, weights = copy
    (root / "docs/results/ros2_loopback.json").unlink()
    with pytest.raises(InputError, match=r"ros2_loopback\.json: cannot read it"):
        results.check(root, weights)


def test_figures_quoted_in_the_readme_prose_come_from_their_results():
    readme = (results.ROOT / "README.md").read_text()
    assert all(f"<!--fig:{name}-->" in readme for name in results.INLINE)
    edited = readme.replace("<!--fig:d435-flagged-->none of", "<!--fig:d435-flagged-->2 of", 1)
    assert edited != readme and results._with_inline(edited, results.ROOT) == readme  # put back from the file
    with pytest.raises(InputError, match="no figure named 'nope'"):
        results._with_inline("<!--fig:nope-->1<!--/fig-->", results.ROOT)


def test_a_result_made_before_its_script_changed_is_listed_as_stale():
    assert results._script_of("python -m lab.kinect2_cam0 --data x", results.ROOT).name == "kinect2_cam0.py"
    assert results._script_of("python bench/models.py --json x", results.ROOT).name == "models.py"
    assert results._script_of("d2sr eval recovery --real x", results.ROOT) is None
    assert results._script_of("python -m bench.outside --set a", results.ROOT).name == "outside"  # a package
    listed = results.stale(only=["docs/results/kinect2_cam0.json", "docs/results/frame_latency.json"])
    # made at 1e3e99f, after lab/kinect2_cam0.py last changed: not listed; frame_latency.json was made
    # before lab/frame_latency.py kept freed buffers (abb380d): listed
    assert len(listed) == 1 and listed[0].startswith("docs/results/frame_latency.json: lab/frame_latency.py")


def test_a_script_whose_imports_alone_changed_leaves_its_results_fresh():
    log = "@@ abc1234\n@@ -1 +1 @@\n-from d2sr.eval.speed import x\n+from d2sr.provenance import x\n"
    assert results._last_change(log) is None
    log = "@@ def5678\n@@ -9 +9 @@\n-    x = 1\n+    x = 2\n" + log
    assert results._last_change(log) == "def5678"
