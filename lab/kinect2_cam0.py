"""The real Kinect v2 multi-camera interference (``kinect2_multicam/cam0``, issue 65): ``d2sr recover`` as
shipped and with ``--repair all``, each without and with a scene learned from 3 of the camera's 6 frames
alone (``d2sr scene learn``, ``--scene-from``). Truth: the per-pixel median of the other 3 (disjoint from
the scene's). Per setting: of the
pixels the interference moved by more than 2 cm (valid in both), the share put back within 2 cm; interfered
frames whose RMSE against the truth got worse; frames flagged; and the frames alone run through the same
setting: pixels changed. Detection (``d2sr detect``: the detector alone, ``--no-scene``; with the scene it
learns on the way, as shipped; with the stored scene): of the interfered
frames with more than 100 valid pixels moved by more than 2 cm, the share flagged (recall), and the frames
alone flagged.

Run:  python -m lab.kinect2_cam0 --data ../shared/data [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np


def _read(folder: Path) -> dict[str, np.ndarray]:
    return {f.name: cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in sorted(folder.glob("*.png"))}


def _recover(src: Path, out: Path, *args: str) -> None:
    cmd = [
        sys.executable,
        "-m",
        "d2sr",
        "recover",
        str(src),
        "--depth-scale",
        "1000",
        "--out",
        str(out),
        *args,
    ]
    subprocess.run([*cmd, "--no-report"], check=True, capture_output=True)


def _flags(src: Path, csv: Path, *args: str) -> dict[str, bool]:
    """``d2sr detect``'s verdict per frame file name."""
    import csv as csvlib

    cmd = [
        sys.executable,
        "-m",
        "d2sr",
        "detect",
        str(src),
        "--depth-scale",
        "1000",
        "--out",
        str(csv),
        *args,
    ]
    subprocess.run([*cmd, "--overwrite"], check=True, capture_output=True)
    with csv.open() as f:
        return {Path(r["frame"]).stem: r["interfered"] in ("1", "True", "true") for r in csvlib.DictReader(f)}


def detection(
    cam: Path, truth: np.ndarray, bad: dict[str, np.ndarray], root: Path, scene: Path, models: list[str]
) -> dict:
    """Recall on the frames with more than 100 valid pixels moved by more than 2 cm; frames alone flagged:
    the detector alone (``--no-scene``), with the scene learned on the way, with the stored scene."""
    hit = []
    for f, x in bad.items():
        x32 = x.astype(np.float32)
        moved = (truth > 0) & (x32 > 0) & (np.abs(x32 - truth) > 20)
        if int(moved.sum()) > 100:
            hit.append(Path(f).stem)
    out = {"frames_over_100_moved": len(hit)}
    settings = {
        "detect --no-scene": ["--no-scene"],
        "detect": [],
        "detect, stored scene": ["--scene-from", str(scene)],
    }
    for name, args in settings.items():
        flags = _flags(cam / "interf", root / "i.csv", *args, *models)
        alone = _flags(cam / "ref", root / "r.csv", *args, *models)
        out[name] = {
            "recall": round(sum(flags[h] for h in hit) / max(len(hit), 1), 4),
            "flagged_of_50": sum(flags.values()),
            "alone_flagged": sum(alone.values()),
        }
    return out


def measure(data: Path, model: list[str] | None = None, models: list[str] | None = None) -> dict:
    """``model``: recover's model options (``--model``, ``--models``) for every setting [its own];
    ``models``: detect's (``--models``)."""
    cam = data / "kinect2_multicam" / "cam0"
    ref, bad = _read(cam / "ref"), _read(cam / "interf")
    # Disjoint frames alone: every other one is the truth (a pixel with at least two returns of three: their
    # median), the others are what the stored scene learns from.
    names = sorted(ref)
    stack = np.stack([ref[n] for n in names[1::2]]).astype(np.float32)
    truth = np.where((stack > 0).sum(0) >= 2, np.median(np.where(stack > 0, stack, np.nan), axis=0), 0)
    truth = np.nan_to_num(truth)
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        learn = root / "learn"
        learn.mkdir()
        for n in names[::2]:
            (learn / n).write_bytes((cam / "ref" / n).read_bytes())
        scene = root / "cam0.npz"
        cmd = [sys.executable, "-m", "d2sr", "scene", "learn", str(learn), "--depth-scale", "1000"]
        subprocess.run([*cmd, "--out", str(scene)], check=True, capture_output=True)
        settings = {
            "--no-scene": ["--no-scene"],
            "as shipped": [],
            "as shipped, stored scene": ["--scene-from", str(scene)],
            "--repair all": ["--repair", "all"],
            "--repair all, stored scene": ["--repair", "all", "--scene-from", str(scene)],
        }
        for name, args in settings.items():
            _recover(cam / "interf", root / "i", *args, *(model or []))
            _recover(cam / "ref", root / "r", *args, *(model or []))
            fixed, alone = _read(root / "i"), _read(root / "r")
            moved = back = worse = flagged = 0
            se_in = se_out = n_px = 0.0
            for f, x in bad.items():
                y = fixed[f].astype(np.float32)
                x32 = x.astype(np.float32)
                valid = (truth > 0) & (x32 > 0)
                m = valid & (np.abs(x32 - truth) > 20)
                moved += int(m.sum())
                back += int((m & (y > 0) & (np.abs(y - truth) <= 20)).sum())
                flagged += bool((y != x32).any())
                both = (truth > 0) & (x32 > 0) & (y > 0)
                rmse = lambda a: float(np.sqrt(np.mean((a[both] - truth[both]) ** 2))) if both.any() else 0.0
                worse += rmse(y) > rmse(x32) + 1e-6
                se_in += float(((x32 - truth)[both] ** 2).sum())
                se_out += float(((y - truth)[both] ** 2).sum())
                n_px += float(both.sum())
            changed = sum(int((alone[f] != x).sum()) for f, x in ref.items())
            out[name] = {
                "moved_2cm": moved,
                "put_back": round(back / max(moved, 1), 4),
                "frames_changed": flagged,
                "frames_worse": worse,
                "camera_rmse_mm": {  # all interfered frames pooled, against the frames alone's median
                    "before": round(float(np.sqrt(se_in / max(n_px, 1))), 3),
                    "after": round(float(np.sqrt(se_out / max(n_px, 1))), 3),
                },
                "alone_pixels_changed": changed,
            }
            for p in (root / "i", root / "r"):
                subprocess.run(["rm", "-rf", str(p)], check=True)
        out["detection"] = detection(cam, truth, bad, root, scene, models or [])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--model", default=None, help="recover's --model (default: its own)")
    ap.add_argument("--models", type=Path, default=None, help="recover's --models (default: the shipped)")
    args = ap.parse_args()
    folder = ["--models", str(args.models)] if args.models else []
    model = (["--model", args.model] if args.model else []) + folder
    # No "data" key of its own: it would replace the record of the files read (``provenance.stamp``).
    result = {"settings": measure(args.data, model, folder)}
    text = json.dumps(result, indent=1)
    print(text)
    if args.json:
        from d2sr.atomic import write_result
        from d2sr.provenance import data_read

        cam = args.data / "kinect2_multicam" / "cam0"
        read = sorted((cam / "ref").glob("*.png")) + sorted((cam / "interf").glob("*.png"))
        what = "kinect2_multicam/cam0: 50 interfered frames, 6 alone"
        write_result(result, args.json, data=data_read(what, read, args.data))


if __name__ == "__main__":
    main()
