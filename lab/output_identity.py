"""What ``d2sr recover`` (as shipped and ``--repair all``) and ``d2sr detect`` write on held-out frames, hashed: the
repaired pixels, the masks and the CSV of scores, per input. Run it with two trees' d2sr first on the path;
the same hashes mean the same outputs, bit for bit (issue 64's bar for a redesign that changes no output).
``--src OTHER/src``: the commands run on that tree's d2sr (the inputs are made with this one's).

Inputs: the first 60 L515 dev1 frames each corrupted by the outside interference (``bench.outside``'s ``worst_case``),
every other frame of outside sets G and D (120 frames each), the first 80 L515 dev0 frames, and the Kinect
v2's interfered frames (``kinect2_multicam/cam0/interf``, 1000 units per metre).

Run:  python -m lab.output_identity --data ../shared/data [--src OTHER/src]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
from bench.outside.sets import every_other, outside_set, worst_case


def _inputs(data: Path, root: Path) -> dict[str, tuple[Path, float]]:
    """Each input folder (written under ``root`` where it is made here) and its depth scale."""
    made = {"worst": list(worst_case(data))}
    clean = outside_set(data)
    for which in ("g", "d"):
        made[which] = [(f"{i:05d}.png", f) for i, f in enumerate(every_other(clean, 4000.0, which)[:120])]
    made["dev0"] = [
        (f.name, cv2.imread(str(f), cv2.IMREAD_UNCHANGED))
        for f in sorted((data / "l515" / "dev0").glob("*.png"))[:80]
    ]
    out = {}
    for name, frames in made.items():
        folder = root / name
        folder.mkdir()
        for file, frame in frames:
            cv2.imwrite(str(folder / file), frame)
        out[name] = (folder, 4000.0)
    out["k2"] = (data / "kinect2_multicam" / "cam0" / "interf", 1000.0)
    return out


def _hash(path: Path) -> str:
    h = hashlib.sha256()
    files = sorted(path.rglob("*")) if path.is_dir() else [path]
    for f in files:
        if f.suffix == ".png":
            h.update(f.relative_to(path).as_posix().encode())
            h.update(cv2.imread(str(f), cv2.IMREAD_UNCHANGED).tobytes())
        elif f.suffix == ".csv":
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--src", type=Path, default=None, help="run the commands on this tree's d2sr")
    args = ap.parse_args()
    env = dict(os.environ) | ({"PYTHONPATH": str(args.src.resolve())} if args.src else {})
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "in").mkdir()
        for name, (folder, scale) in _inputs(args.data, root / "in").items():
            runs = {
                "rec": ["recover", "--out", str(root / f"{name}-rec")],
                "all": ["recover", "--repair", "all", "--out", str(root / f"{name}-all")],
                "det": ["detect", "--out", str(root / f"{name}-det.csv")],
            }
            for kind, words in runs.items():
                cmd = [
                    sys.executable,
                    "-m",
                    "d2sr",
                    words[0],
                    str(folder),
                    "--depth-scale",
                    str(scale),
                    *words[1:],
                ]
                got = subprocess.run(cmd, capture_output=True, text=True, env=env)
                if got.returncode == 2 and "--repair" in got.stderr:  # a tree before recover --repair: --all
                    cmd = [w for w in cmd if w != "--repair"]
                    cmd[cmd.index("all")] = "--all"
                    got = subprocess.run(cmd, capture_output=True, text=True, env=env)
                if got.returncode:
                    raise SystemExit(f"{' '.join(cmd)}: {got.stderr.strip()}")
                print(name, kind, _hash(Path(words[-1])))


if __name__ == "__main__":
    main()
