"""Probe (issue 42, development): does a coherent shift against the scene tell a CW-ToF camera's light from
the sensor's noise, where the scene reference's per-pixel test does not?

Set G's surfaces are read 2-5 cm off, mostly inside the tolerance ``SceneReference.evidence`` judges each
pixel by, so ``detect --scene`` found 42% of its frames (decisions.md, 2026-11-26). Averaged over a window,
a shift of 2 cm stands far above the noise of single pixels. Per frame: the signed difference from the
per-pixel median of the clean frames before it (the last 16 of the same camera, every other frame, as the
outside sets lay them out; an oracle reference, not the online one), over the pixels that returned in at
least 90% of them; its mean over each ``window`` x ``window`` neighbourhood (at least half of it such
pixels); the share of those pixels where the mean is more than ``cm`` off. A frame is flagged at a share of
``area`` or more. No model runs.

Reported per outside set (every other frame corrupted) and on the clean L515 sequences (every frame, each
against the 16 before it: dev0 has a person walking through): frames flagged, recall and false alarms. The
settings were read off set G, a development set since it was opened: these are development figures.

Run:  python -m lab.shift_probe --json lab/notes/results/shift_probe.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import OUTSIDE_CAMERAS, SETS, every_other, outside_set

from d2sr.atomic import write_result
from d2sr.scene.stats import stack_stats

SCALE = 4000.0
REFERENCE = 16  # clean frames in the reference
AREAS = (0.003, 0.01, 0.02, 0.05)


def shifted_share(frame: np.ndarray, before: list[np.ndarray], window: int, cm: float) -> float:
    """The share of the frame's steady pixels whose windowed mean difference from ``before``'s median is
    more than ``cm`` off."""
    st = stack_stats(np.stack(before))
    med, rate = st["nz_median"] / SCALE, st["rate"]
    m = frame.astype(np.float32) / np.float32(SCALE)
    ok = (m > 0) & (rate >= 0.9) & (med > 0)
    r = np.where(ok, m - med, 0).astype(np.float32)
    n = cv2.blur(ok.astype(np.float32), (window, window))
    mean = cv2.blur(r, (window, window)) / np.maximum(n, 1e-6)
    hit = (np.abs(mean) > cm / 100) & (n >= 0.5) & ok
    return float(hit.sum()) / max(int(ok.sum()), 1)


def _rates(shares: list[float], truth: list[bool]) -> dict:
    s, t = np.array(shares), np.array(truth)
    out = {}
    for a in AREAS:
        p = s >= a
        out[f"area {a:g}"] = {
            "recall": round(float((p & t).sum()) / max(int(t.sum()), 1), 4),
            "false_alarms": f"{int((p & ~t).sum())} of {int((~t).sum())}",
        }
    return out


def outside(data: Path, which: str, window: int, cm: float) -> dict:
    clean = outside_set(data)
    bad = every_other(clean, SCALE, which)
    shares, truth = [], []
    for i, f in enumerate(bad):
        first = OUTSIDE_CAMERAS.index(OUTSIDE_CAMERAS[i])
        before = [bad[j] for j in range(first, i) if j % 2 == 0][-REFERENCE:]  # the clean frames
        if len(before) < 4:
            continue
        shares.append(shifted_share(f, before, window, cm))
        truth.append(bool((f != clean[i]).any()))
    return {"frames": len(shares), "interfered": int(sum(truth))} | _rates(shares, truth)


def clean_sequence(folder: Path, window: int, cm: float) -> dict:
    frames = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in sorted(folder.glob("*.png"))]
    shares = [
        shifted_share(frames[i], frames[max(0, i - REFERENCE) : i], window, cm) for i in range(4, len(frames))
    ]
    return {"frames": len(shares)} | {
        f"area {a:g}": f"{int((np.array(shares) >= a).sum())} of {len(shares)} flagged" for a in AREAS
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--window", type=int, default=15)
    ap.add_argument("--cm", type=float, default=1.0)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    if not (args.data / "l515" / "dev0").is_dir():
        ap.error(f"{args.data}/l515/dev0: no such folder (the real L515 captures)")
    result = {
        "settings": {"window": args.window, "cm": args.cm, "reference_frames": REFERENCE, "areas": AREAS},
        "sets": {s: outside(args.data, s, args.window, args.cm) for s in SETS},
        "clean": {v: clean_sequence(args.data / "l515" / v, args.window, args.cm) for v in ("dev0", "dev1")},
    }
    print(write_result(result, args.json, data="real L515 dev0, dev1; outside sets A-G (development)"))


if __name__ == "__main__":
    main()
