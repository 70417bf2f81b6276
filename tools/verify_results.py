"""Re-make the committed results cheap enough to re-run here (a minute or so each) and compare them with the
committed files figure by figure (issue 81): a figure edited by hand, or made by code or data other than
today's, fails naming the file and the figure. Provenance (who, when, where, which commit) is not a figure.
Repository tooling, not installed.

Run:  python tools/verify_results.py [--data ../shared/data] [--only kinect2_cam0]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: Committed result -> the arguments to ``python`` that re-make it (``{data}``, ``{out}`` filled in).
CHEAP: dict[str, list[str]] = {
    "docs/results/kinect2_cam0.json": ["-m", "lab.kinect2_cam0", "--data", "{data}", "--json", "{out}"],
    "docs/results/repeating.json": ["-m", "lab.repeating", "--data", "{data}", "--json", "{out}"],
    "docs/results/library_bars.json": ["-m", "lab.library_bars", "--data", "{data}", "--json", "{out}"],
    "docs/results/stored_scene_l515.json": [
        "-m", "lab.stored_scene_l515", "--data", "{data}", "--repair", "--json", "{out}",
    ],
}  # fmt: skip
# The demo table is re-made by the suite (tests/cli/test_cli.py compares it with the README's).
#: What a result records about the run that made it, not what it measured.
STAMP = frozenset({"made_by", "command", "commit", "version", "models", "cpu", "date"})
RELATIVE = 1e-9  # figures are made with fixed seeds and steps: equal, up to float printing
#: Timings, wherever they sit in a result: they measure the machine, not the code.
TIMINGS = frozenset({"ms_median"})


def differences(made: Any, kept: Any, where: str = "") -> list[str]:
    """Where ``made`` (re-made now) and ``kept`` (committed) differ, as 'path: kept -> made' lines."""
    if isinstance(made, dict) and isinstance(kept, dict):
        out = []
        for key in sorted(set(made) | set(kept)):
            if (not where and key in STAMP) or key in TIMINGS:
                continue
            at = f"{where}.{key}" if where else str(key)
            if key not in made or key not in kept:
                out.append(f"{at}: {'missing now' if key not in made else 'not committed'}")
            else:
                out += differences(made[key], kept[key], at)
        return out
    if isinstance(made, list) and isinstance(kept, list):
        if len(made) != len(kept):
            return [f"{where}: {len(kept)} items -> {len(made)}"]
        return [
            d
            for i, (m, k) in enumerate(zip(made, kept, strict=True))
            for d in differences(m, k, f"{where}[{i}]")
        ]
    numbers = (int, float)
    if isinstance(made, numbers) and isinstance(kept, numbers) and not isinstance(made, bool):
        if math.isclose(made, kept, rel_tol=RELATIVE, abs_tol=1e-12):
            return []
    elif made == kept:
        return []
    return [f"{where}: {kept!r} -> {made!r}"]


def verify(data: Path, only: str | None = None) -> list[str]:
    """Every cheap result re-made into a temporary folder and compared; the differences, by file."""
    found = []
    with tempfile.TemporaryDirectory() as tmp:
        for rel, args in CHEAP.items():
            if only is not None and only not in rel:
                continue
            out = Path(tmp) / Path(rel).name
            cmd = [sys.executable, *(a.format(data=data, out=out) for a in args)]
            done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
            if done.returncode != 0 or not out.is_file():
                tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
                found.append(f"{rel}: could not be re-made ({tail})")
                continue
            kept = json.loads((ROOT / rel).read_text())
            found += [f"{rel}: {d}" for d in differences(json.loads(out.read_text()), kept)]
            print(f"{rel}: re-made", file=sys.stderr)
    return found


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--only", default=None, help="a part of a result's path: re-make that one only")
    args = ap.parse_args()
    if not args.data.is_dir():
        print(f"verify-results: no data at {args.data}", file=sys.stderr)
        return 2
    found = verify(args.data.resolve(), args.only)
    for line in found:
        print(line)
    print(f"{len(CHEAP) if args.only is None else 1} results re-made; {len(found)} figures differ")
    return 1 if found else 0


if __name__ == "__main__":
    raise SystemExit(main())
