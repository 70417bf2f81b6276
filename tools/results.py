"""The published figures, written from the committed results and checked against them (issue 45).

The README's results table and the shipped models' cards quote figures; here they are generated from the
JSON files under ``docs/results`` that hold them, never typed. ``make results`` (``python
tools/results.py``) rewrites them; ``--check`` (and the test suite) fails when a card or the README differs
from what the files give, and when a result under ``docs/results`` does not record the command and commit
that made it (unless ``PENDING`` lists it, a list that only shrinks). Repository tooling, not installed.
"""

from __future__ import annotations

import json
import re
import statistics
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from d2sr.contract.catalog import WEIGHTS
from d2sr.errors import InputError
from d2sr.provenance import ROOT

__all__ = [
    "README_ROWS",
    "card_fields",
    "check",
    "readme_table",
    "untraceable",
    "write",
]

RESULTS = ROOT / "docs" / "results"
START = "<!-- written by make results -->"
END = "<!-- end of make results -->"
SETS = "abcdefghi"
OUTSIDE = "docs/results/outside/{set}-{setting}.json"  # make outside's file for one set and one setting
# Results made before provenance was recorded, each waiting for its command to run again: a result missing
# from this list fails the check without provenance, and a listed one that has it must leave the list.
PENDING = "docs/results/PENDING.txt"


def _load(root: Path, rel: str) -> dict:
    path = root / rel
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{rel}: cannot read it ({exc.__class__.__name__}); its command writes it") from None
    if not isinstance(data, dict):
        raise InputError(f"{rel}: not a JSON object")
    return data


def untraceable(root: Path = ROOT) -> tuple[list[str], int]:
    """(the JSON files under ``docs/results`` that do not record a command and a clean commit of this
    repository's history, how many JSON files there are). A commit with ``+changes`` was made from an
    uncommitted tree: no one can make it again."""
    files = sorted((root / "docs" / "results").rglob("*.json"))
    bad, commits = [], {}
    for f in files:
        try:
            data = json.loads(f.read_text())
        except (OSError, ValueError):
            data = None
        ok = isinstance(data, dict) and bool(data.get("command")) and isinstance(data.get("commit"), str)
        commit = str(data.get("commit", "")) if isinstance(data, dict) else ""
        if not ok or not commit or commit.endswith("+changes"):
            bad.append(str(f.relative_to(root)))
        else:
            commits[str(f.relative_to(root))] = commit
    known = _in_history(root, set(commits.values()))
    bad += [f for f, c in commits.items() if known is not None and c not in known]
    return sorted(bad), len(files)


def _script_of(command: str, root: Path) -> Path | None:
    """The lab, bench or tools script a result's command ran (``python -m lab.x``, ``python bench/x.py``), or
    the package (``python -m bench.outside``)."""
    m = re.search(r"python3? (?:-m ((?:lab|bench|tools)(?:\.\w+)+)|((?:lab|bench|tools)/\w+\.py))", command)
    if m is None:
        return None
    module = m.group(1).replace(".", "/") if m.group(1) else None
    if module is not None and (root / module / "__main__.py").is_file():
        return root / module  # a package run with -m: its whole folder
    rel = module + ".py" if module is not None else m.group(2)
    return root / rel if (root / rel).is_file() else None


def stale(root: Path = ROOT, only: list[str] | None = None) -> list[str]:
    """Results made before the last commit that changed the script that makes them (its command's lab,
    bench or tools module): re-make them before they are quoted again. The product's own code changes too
    often to count here; ``make verify-results`` re-makes the cheap results against it. ``only``: these
    results (paths under ``root``) and no others."""
    import subprocess

    out = []
    files = sorted((root / "docs" / "results").rglob("*.json")) if only is None else [root / f for f in only]
    for f in files:
        try:
            data = json.loads(f.read_text())
        except (OSError, ValueError):
            continue
        if not isinstance(data, dict) or not isinstance(data.get("commit"), str):
            continue
        script = _script_of(str(data.get("command", "")), root)
        commit = data["commit"].removesuffix("+changes")
        if script is None or not commit:
            continue
        done = subprocess.run(
            ["git", "-C", str(root), "log", "--format=@@ %h", "-p", "--unified=0", f"{commit}..HEAD", "--",
             str(script)],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        at = _last_change(done.stdout) if done.returncode == 0 else None
        if at:
            out.append(f"{f.relative_to(root)}: {script.relative_to(root)} changed since (at {at})")
    return out


def _last_change(log: str) -> str | None:
    """The newest commit of a ``git log -p`` (commits marked ``@@ <hash>``) that changed more than imports:
    a module that moved leaves the figures its script makes as they were."""
    commit = None
    for line in log.splitlines():
        if line.startswith("@@ ") and not line.startswith("@@ -"):
            commit = line[3:].strip()
        elif line[:1] in "+-" and not line.startswith(("+++", "---")):
            text = line[1:].strip()
            if text and not text.startswith(("import ", "from ")):
                return commit
    return None


def _in_history(root: Path, commits: set[str]) -> set[str] | None:
    """The ones of ``commits`` that name a commit of the repository (``root``'s, else the checkout d2sr runs
    from); None where there is no repository to ask."""
    import subprocess

    repo = root if (root / ".git").exists() else ROOT if (ROOT / ".git").exists() else None
    if repo is None or not commits:
        return None if repo is None else set()
    asked = sorted(commits)
    try:
        out = subprocess.run(
            ["git", "-C", str(repo), "cat-file", "--batch-check"],
            input="".join(f"{c}^{{commit}}\n" for c in asked),
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()
    except (OSError, subprocess.CalledProcessError):
        return None
    return {c for c, line in zip(asked, out, strict=False) if not line.endswith("missing")}


def pending(root: Path = ROOT) -> list[str]:
    """The results listed in ``PENDING`` (first word of each line that is not blank or a # comment)."""
    path = root / PENDING
    if not path.is_file():
        return []
    lines = (ln.split("#", 1)[0].split() for ln in path.read_text().splitlines())
    return [words[0] for words in lines if words]


# ---- the README's results table ----


@dataclass(frozen=True)
class Row:
    """One line of the README's results table: what is measured, the paper's figure, the file that holds
    ours, how to read it there, and the command that writes the file."""

    measure: str
    paper: str
    source: str
    figure: Callable[[dict], str]
    command: str


def _pct(x: float, digits: int = 1, signed: bool = False) -> str:
    return f"{100 * x:{'+' if signed else ''}.{digits}f}%"


def _fig9(d: dict) -> str:
    from d2sr.desync import DEFAULT_CONTROLLER

    cell = "stationary/15fps/2/"
    return f"{_pct(d['fig9'][cell + DEFAULT_CONTROLLER])} ({_pct(d['fig9'][cell + 'static'])})"


def _unet8(which: str) -> Callable[[dict], str]:
    def fig(d: dict) -> str:
        t = d[which]
        return (
            f"{t['identity']['rmse_cm']:.2f} → {t['unet8']['rmse_cm']:.2f} "
            f"({100 * t['unet8']['rmse_vs_identity']:+.1f}%)"
        )

    return fig


def _outside(d: dict) -> str:
    rows = d["settings"]["default (auto)"]
    sets = sum(k.startswith("set ") for k in rows)
    return (
        " / ".join(_pct(rows[k]["rmse_change"], signed=True) for k in ("mean", "worst")) + f" ({sets} sets)"
    )


def _recording(d: dict) -> str:
    mw = d["l515_mean_worst"]["as shipped, primed"]
    change = " / ".join(_pct(mw[k], signed=True) for k in ("rmse_change_mean", "rmse_change_worst"))
    return f"{change}; {mw['frames_worse_most']} ({mw['sets']} sets)"


def _scene_flags(d: dict) -> str:
    mw = d["outside_mean_worst"]["detector + scene, primed (d2sr detect on a recording)"]
    p, r = mw["precision"], mw["recall"]
    sets = len(d["outside"])
    return f"{p['mean']:.3f} / {r['mean']:.3f}; {p['worst']:.3f} / {r['worst']:.3f} ({sets} sets)"


README_ROWS = (
    Row(
        "frames interfered, 2 LiDARs at 15 fps, with the controller (static)",
        "29.7%",
        "docs/results/paper/results.json",
        _fig9,
        "`make eval-paper`",
    ),
    Row(
        "detector precision / recall",
        "0.98 / 0.82",
        "docs/results/paper/detector/detector.json",
        lambda d: f"{d['detector/l515']['precision']:.3f} / {d['detector/l515']['recall']:.3f}",
        "`make eval-paper`",
    ),
    Row(
        "UNet8 RMSE, static sensor (cm)",
        "60.64 → 38.79 (-36%)",
        "docs/results/paper/recovery/recovery.json",
        _unet8("l515"),
        "`make eval-paper`",
    ),
    Row(
        "UNet8 RMSE, moving robot (cm)",
        "53.89 → 40.45 (-25%)",
        "docs/results/paper/recovery/recovery.json",
        _unet8("moving"),
        "`make eval-paper`",
    ),
    Row(
        "`d2sr recover` on recordings, outside sets (development): RMSE change mean / worst; most frames "
        "worse in a set",
        "—",
        "docs/results/recover_recording.json",
        _recording,
        "`python -m lab.scene_repair --what recording`",
    ),
    Row(
        "the models alone on every frame (`--repair all --no-scene`), outside sets (development): RMSE "
        "mean / worst",
        "—",
        "docs/results/outside_sets.json",
        _outside,
        "`make outside`",
    ),
    Row(
        "detector + scene on recordings, outside sets (development): precision / recall, mean / worst",
        "—",
        "docs/results/scene_reference.json",
        _scene_flags,
        "`python -m lab.scene_reference`",
    ),
    Row(
        "real Kinect v2 interference (development), scene stored from 3 clean frames, truth the other 3: "
        "put back (> 2 cm), "
        "`recover` / `--repair all`; frames worse; `detect` recall; without the stored scene, the same three",
        "—",
        "docs/results/kinect2_cam0.json",
        lambda d: (
            f"{_pct(d['settings']['as shipped, stored scene']['put_back'])} / "
            f"{_pct(d['settings']['--repair all, stored scene']['put_back'])}; "
            f"{d['settings']['as shipped, stored scene']['frames_worse']} / "
            f"{d['settings']['--repair all, stored scene']['frames_worse']} of 50; "
            f"{d['settings']['detection']['detect, stored scene']['recall']:.2f} "
            f"({d['settings']['detection']['frames_over_100_moved']} frames); "
            f"{_pct(d['settings']['as shipped']['put_back'])}, "
            f"{d['settings']['as shipped']['frames_worse']} worse, "
            f"{d['settings']['detection']['detect']['recall']:.2f}"
        ),
        "`python -m lab.kinect2_cam0`",
    ),
    Row(
        "stored scene, L515 outside sets (development): RMSE, recall, mean / worst",
        "—",
        "docs/results/stored_scene_l515.json",
        lambda d: (
            f"{_pct(d['mean_worst']['stored']['rmse_change']['mean'])} / "
            f"{_pct(d['mean_worst']['stored']['rmse_change']['worst'])}; "
            f"{d['mean_worst']['stored']['recall']['mean']:.3f} / "
            f"{d['mean_worst']['stored']['recall']['worst']:.3f}"
        ),
        "`python -m lab.stored_scene_l515 --repair`",
    ),
    Row(
        "latency per 640x480 frame, detector / UNet8",
        "2.6 / 6.1 ms (AGX Orin GPU)",
        "docs/results/paper/results.json",
        lambda d: (
            f"{d['latency_ms']['detector']['onnxruntime']:.2f} / "
            f"{d['latency_ms']['unet8']['onnxruntime']:.2f} ms (2-core CPU)"
        ),
        "`make eval-paper`",
    ),
    Row(
        "`recover --repair all`, 60 frames 640x480: whole process; marginal rate; x the PNG I/O floor",
        "—",
        "docs/results/bench_speed.json",
        lambda d: (
            f"{statistics.median(d['worst']['seconds']['recover 60']):.2f} s; "
            f"{d['worst']['recover_fps']:.1f} fps; {d['worst']['ratio_to_floor']:.2f}x ({d['cpu']})"
        ),
        "`python -m lab.speed`",
    ),
    Row(
        "ROS 2 node, 640x480 at 30 Hz, half interfered: back, dropped, median in node",
        "—",
        "docs/results/ros2_loopback.json",
        lambda d: (
            f"{d['rate_30hz']['repaired_received']} of {d['rate_30hz']['published']}, "
            f"{d['rate_30hz']['node_counts']['dropped_while_behind']}, "
            f"{d['rate_30hz']['node_latency']['median_ms']:.1f} ms ({d['cpu'].replace(' Processor', '')})"
        ),
        "`python -m lab.ros2_loopback`",
    ),
    Row(
        "every frame interfered, `--model unet8-fast`: back, median / p99 in node",
        "—",
        "docs/results/ros2_loopback_every_fast.json",
        lambda d: (
            f"{d['rate_30hz']['repaired_received']} of {d['rate_30hz']['published']}, "
            f"{d['rate_30hz']['node_latency']['median_ms']:.1f} / "
            f"{d['rate_30hz']['node_latency']['p99_ms']:.1f} ms "
            f"({d['cpu'].replace(' Processor', '')})"
        ),
        "`... --every --model unet8-fast`",
    ),
)


def readme_table(root: Path = ROOT) -> str:
    """The README's results table, each figure linked to the file that holds it."""
    lines = [START, "| measure | paper | d2sr | command |", "|---|---|---|---|"]
    for row in README_ROWS:
        data = _load(root, row.source)
        try:
            figure = row.figure(data)
        except (KeyError, TypeError, StopIteration) as exc:
            raise InputError(f"{row.source}: no {exc} in it for {row.measure!r}") from None
        lines.append(f"| {row.measure} | {row.paper} | [{figure}]({row.source}) | {row.command} |")
    return "\n".join([*lines, END])


def _with_table(readme: str, table: str) -> str:
    if START not in readme or END not in readme:
        raise InputError(f"README.md: no results table markers ({START!r} ... {END!r})")
    head, rest = readme.split(START, 1)
    return _with_inline(head + table + rest.split(END, 1)[1], ROOT)


def _none_of(flagged: int, frames: int) -> str:
    return f"{'none' if flagged == 0 else flagged} of {frames}"


def _pixels_changed(others: dict) -> str:
    worst = max(v.get("changed_worst", v.get("changed", 0.0)) for v in others.values())
    return "changed no pixel" if worst == 0 else f"changed at most {worst:.2%} of a frame's pixels"


# Figures quoted in the README's prose, between <!--fig:NAME--> and <!--/fig-->, written from results as the
# table's rows are: (the result, what it gives).
INLINE: dict[str, tuple[str, Callable[[dict], str]]] = {
    "repair-all-worse": ("docs/results/outside/h-auto.json", lambda d: str(d["l515"]["frames_worse"])),
    "d435-flagged": (
        "docs/results/library_bars.json",
        lambda d: _none_of(d["other_sensors"]["d435"]["flagged"], d["other_sensors"]["d435"]["frames"]),
    ),
    "others-changed": ("docs/results/library_bars.json", lambda d: _pixels_changed(d["other_sensors"])),
}
_FIG = re.compile(r"<!--fig:([\w-]+)-->(.*?)<!--/fig-->", re.S)


def _with_inline(readme: str, root: Path) -> str:
    """``readme`` with each quoted figure (``INLINE``) as its result gives it; an unknown name is an error."""

    def figure(m: re.Match[str]) -> str:
        if m.group(1) not in INLINE:
            raise InputError(f"README.md: no figure named {m.group(1)!r} (tools/results.py INLINE)")
        rel, give = INLINE[m.group(1)]
        return f"<!--fig:{m.group(1)}-->{give(json.loads((root / rel).read_text()))}<!--/fig-->"

    return _FIG.sub(figure, readme)


# ---- the models' cards ----

# Each shipped model's card: what no figure says, in words (figures come from the files, never from here).
NOTES = {
    "unet8": "Trained on generated frames only. Most of the error left from outside is in pixels the mask "
    "misses. On clean D435 frames recover changes nothing; on another sensor, fit it with d2sr adapt.",
    "unet16": "Trained on generated frames only; started as the shipped unet8 widened to the same function "
    "(d2sr.models.widen) and trained on its recipe. About as good as unet8 from outside, and slower: the "
    "default stays unet8.",
    "unet32": "Trained on generated frames only; started as the shipped unet8 widened to the same function "
    "and trained on its recipe. Its weights are stored in float16 (models.store.HALF_ABOVE) and computed in "
    "float32. Slower than unet8: the default stays unet8.",
    "unet8-temporal": "Trained on generated frame pairs only; recover's default (auto) uses it where the "
    "last clean frame lines up with the frame.",
    "unet8-fast": "Started from the shipped unet8 and trained on generated frames only, distilled from "
    "unet8's two passes. One pass in about half the time of one unet8 pass; it repairs less than the "
    "default on every outside set, so it is not the default: choose it where frames must come back at the "
    "camera's rate (docs/ros2.md).",
    "detector": "Trained on generated frames only. Interference that leaves a plausible surface (a "
    "constant offset on stripes, a smooth swing) is rarely flagged from outside; nor is a continuous-wave "
    "ToF neighbour's offset of a few centimetres on a surface, which only a scene tells (real Kinect v2, "
    "above).",
    "paper-detector": "The paper's detector layout, trained on generated frames only; kept for comparison.",
}
CALIBRATION = (
    "The weights never saw a real frame, but the simulator that generated their data has its L515 noise "
    "model fitted to the real L515 captures (dev0, dev1) that the real-L515 figures and every outside set "
    "use: those figures are on frames the simulator was calibrated on. Fitted to one view alone, a detector "
    "trained from scratch on that fit's data scores the other view as well as its own (make overlap, "
    "docs/results/overlap/overlap.json). For recovery there is no consistent gap: of two unet8s trained "
    "from scratch on one-view fits, one repairs its held-out view less than its fitted one (mask F1 0.46 to "
    "0.29), the other slightly more (0.12 to 0.16), and both stay far below the shipped model."
)
RECOVERY = "docs/results/recovery/recovery.json"
DETECTOR = "docs/results/detector/detector.json"
KINECT2 = "docs/results/kinect2_cam0.json"
#: ``lab.kinect2_cam0``'s detection settings, as the detector's card names them.
KINECT2_DETECT = {
    "detect --no-scene": "the detector alone (--no-scene)",
    "detect": "with the scene learned from the frames (as shipped, no stored scene)",
    "detect, stored scene": "with a scene stored from 3 of its frames alone (--scene-from)",
}


def _kinect2_detection(d: dict) -> dict[str, str]:
    """Per detection setting of the real Kinect v2 result: frames flagged of those with over 100 pixels moved
    by more than 2 cm, and of the frames alone."""
    det = d["settings"]["detection"]
    n = det["frames_over_100_moved"]
    return {
        label: f"{round(det[k]['recall'] * n)} of {n} flagged; of the frames alone: {det[k]['alone_flagged']}"
        for k, label in KINECT2_DETECT.items()
    }


def _set_label(d: dict) -> str:
    data = d.get("data")
    if not isinstance(data, dict):
        data = {}
    status = str(data.get("status", "unknown status")).split(":", 1)[0]
    name = re.sub(
        r", (bench|lab)/\w+\.py$", "", str(data.get("set", "unknown set"))
    )  # the set, not its script
    return f"{name} [{status}]"


def _counted(r: dict) -> str:
    """How many frames a figure counts: the interfered ones, and apart those the set's corruption left
    unchanged (issue 45: set A's recall once counted 47 of 60 without saying so)."""
    apart = (
        f"; {r['left_unchanged']} corrupted but left unchanged, not counted"
        if r.get("left_unchanged")
        else ""
    )
    return f"({r['interfered']} interfered frames of {r['frames']}{apart})"


def _repair_figures(r: dict) -> str:
    return (
        f"RMSE {100 * r['rmse_change']:+.1f}%, mask F1 {r['mask_f1']:.2f}, "
        f"{_pct(r['clean_changed'], 2)} of clean pixels changed {_counted(r)}"
    )


def _detector_figures(r: dict) -> str:
    return f"precision {r['detector_precision']:.2f} / recall {r['detector_recall']:.2f} {_counted(r)}"


def _outside_sets(
    root: Path, setting: str, figures: Callable[[dict], str]
) -> tuple[dict[str, str], list[str]]:
    """Per outside set, ``figures`` of ``make outside``'s SET-setting.json; the files read."""
    rows, sources = {}, []
    for s in SETS:
        rel = OUTSIDE.format(set=s, setting=setting)
        if (root / rel).is_file():
            d = _load(root, rel)
            rows[_set_label(d)] = figures(d["l515"])
            sources.append(rel)
    return rows, sources


def card_fields(name: str, root: Path = ROOT) -> dict:
    """The fields of ``name``'s card that quote figures, from the files that hold them: ``metrics`` and
    ``evaluation`` (the eval's JSON and its recorded command), ``outside`` (``make outside``), ``limits``
    (``NOTES`` and the calibration overlap) and ``sources``."""
    from d2sr.eval.learned import detector_metrics_card, recovery_metrics_card

    detector = name in ("detector", "paper-detector")
    rel = DETECTOR if detector else RECOVERY
    d = _load(root, rel)
    if detector:
        metrics = detector_metrics_card(d, name)
        outside, sources = _outside_sets(root, "auto", _detector_figures) if name == "detector" else ({}, [])
    else:
        metrics = recovery_metrics_card({k: d[k] for k in ("generated", "l515", "moving") if k in d}, name)
        outside, sources = _outside_sets(root, name, _repair_figures)
    if not metrics:
        raise InputError(f"{rel}: no figures for {name}")
    fields: dict = {
        "metrics": metrics,
        "evaluation": d.get("command", "unknown"),
        "limits": f"{NOTES[name]} {CALIBRATION}",
        "sources": [rel, *sources],
    }
    if outside:
        fields["outside"] = outside
    if name == "detector":
        fields["real"] = _kinect2_detection(_load(root, KINECT2))
        fields["sources"].append(KINECT2)
    return fields


def _card_names(weights: Path) -> list[str]:
    return [n for n in NOTES if (weights / f"{n}.card.json").is_file()]


# ---- writing and checking ----


def check(root: Path = ROOT, weights: Path = WEIGHTS) -> list[str]:
    """What disagrees with the committed results, one line each: a card field or the README's table that
    differs from what its files give, or too few results that record their command and commit."""
    problems = []
    bad, _ = untraceable(root)
    waiting = pending(root)
    for f in sorted(set(bad) - set(waiting)):
        problems.append(f"{f}: records no command and clean commit of this history (its command writes them)")
    for f in sorted(set(waiting) - set(bad)):
        problems.append(f"{PENDING}: {f} is traceable now or gone; take it off the list")
    readme = (root / "README.md").read_text()
    if _with_table(readme, readme_table(root)) != readme:
        problems.append("README.md: its results table differs from docs/results (run make results)")
    from d2sr.models.store import render_card

    for name in _card_names(weights):
        card = json.loads((weights / f"{name}.card.json").read_text())
        for key, value in card_fields(name, root).items():
            if card.get(key) != value:
                problems.append(f"{name}.card.json: {key} differs from its sources (run make results)")
        md = weights / f"{name}.md"
        if not md.is_file() or md.read_text() != render_card(card, name):
            problems.append(f"{name}.md: differs from {name}.card.json (run make results)")
    return problems


def write(root: Path = ROOT, weights: Path = WEIGHTS) -> list[str]:
    """Rewrite the README's results table and the cards' figure fields from the files; the files changed."""
    from d2sr.atomic import atomic_write
    from d2sr.models.store import read_card, render_card, write_card

    changed = []
    readme = (root / "README.md").read_text()
    new = _with_table(readme, readme_table(root))
    if new != readme:
        atomic_write(root / "README.md", new)
        changed.append("README.md")
    for name in _card_names(weights):
        fields = card_fields(name, root)
        path = weights / f"{name}.safetensors"
        card = read_card(path)
        md = weights / f"{name}.md"
        stale = not md.is_file() or md.read_text() != render_card(card | fields, name)
        if stale or any(card.get(k) != v for k, v in fields.items()):
            write_card(path, **fields)
            changed.append(f"{name}.card.json")
    return changed


def digits_in(text: str) -> list[str]:
    """The numbers in ``text`` (a hand-written note must quote none)."""
    return re.findall(r"(?<![A-Za-z\d.])\d+(?:\.\d+)?", text)  # not part of a name: D435, unet8


def main(argv: list[str] | None = None) -> int:
    """Write the README's results table and the shipped models' cards from the committed results under
    docs/results; with --check, change nothing and exit 2 where they disagree."""
    import argparse

    ap = argparse.ArgumentParser(prog="python tools/results.py", description=main.__doc__)
    ap.add_argument("--check", action="store_true", help="change nothing; exit 2 on any disagreement")
    args = ap.parse_args(argv)
    if not RESULTS.is_dir():
        print(f"results: runs in a d2sr checkout: no {RESULTS}")
        return 2
    if args.check:
        problems = check()
        for problem in problems:
            print(problem)
        if problems:
            print(f"results: {len(problems)} published figure(s) disagree with docs/results")
            return 2
        bad, total = untraceable()
        print(
            f"README and cards agree with docs/results; {total - len(bad)} of {total} results record their "
            f"command and commit ({len(bad)} listed in {PENDING})"
        )
        old = stale()
        for line in old:
            print(f"stale: {line}")
        print(f"{len(old)} results were made before their script last changed")
        return 0
    changed = write()
    print("Rewrote " + ", ".join(changed) if changed else "Nothing to change")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
