"""An outside set through the public CLI: ``d2sr detect`` and ``d2sr recover`` on the corrupted frames, scored
against the clean ones."""

from __future__ import annotations

import csv
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from bench.outside.draw import SEED
from bench.outside.sets import every_other, kind


def _write(folder: Path, frames: list[np.ndarray]) -> None:
    folder.mkdir(parents=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:05d}.png"), f)


def d2sr(*args: str) -> None:
    r = subprocess.run([sys.executable, "-m", "d2sr", *args], capture_output=True, text=True, check=False)
    if r.returncode:
        raise SystemExit(f"d2sr {' '.join(args)} failed: {r.stderr.strip()}")


def _flags(csv_path: Path) -> np.ndarray:
    with csv_path.open() as f:
        return np.array([row["interfered"] == "1" for row in csv.DictReader(f)])


def _scored(
    tmp: Path,
    name: str,
    clean: list[np.ndarray],
    scale: float,
    models: Sequence[str],
    recovery: Sequence[str] = (),
    which: str = "a",
    cameras: Sequence[str] = (),
) -> dict:
    """Every other frame corrupted (set ``which``); detect and recover --repair all (``recovery``: its model
    option) from outside; the figures."""
    kinds = [kind(which, SEED + i) if i % 2 else "" for i in range(len(clean))]
    return scored(tmp, name, every_other(clean, scale, which), clean, scale, models, recovery, kinds, cameras)


def scored(
    tmp: Path,
    name: str,
    bad: list[np.ndarray],
    clean: list[np.ndarray],
    scale: float,
    models: Sequence[str] = (),
    recovery: Sequence[str] = (),
    kinds: Sequence[str] = (),
    cameras: Sequence[str] = (),
) -> dict:
    """A sequence as delivered (``bad``) and without interference (``clean``), written to ``tmp/name``:
    ``d2sr detect`` and ``d2sr recover --repair all`` from outside, scored on the frames that differ. With
    ``kinds`` (each frame's interference model), the detector's recall, the mask's and the RMSE change also
    per model (``by_kind``); with ``cameras`` (each frame's camera), the RMSE change per camera
    (``by_camera``)."""
    truth = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
    counted: dict[str, int] = {}
    if kinds:  # the frames the set meant to corrupt; those the corruption left unchanged count apart
        meant = np.array([bool(k) for k in kinds])
        counted = {"corrupted": int(meant.sum()), "left_unchanged": int((meant & ~truth).sum())}
    _write(tmp / name, bad)
    s = ["--depth-scale", f"{scale:g}", *models]
    # The models alone (--no-scene): the sensor's scene is judged on these sets by lab/scene_reference.py.
    d2sr("detect", str(tmp / name), "--out", str(tmp / f"{name}.csv"), *s, "--no-scene")
    pred = _flags(tmp / f"{name}.csv")
    d2sr("recover", str(tmp / name), "--repair", "all", "--out", str(tmp / f"{name}-fixed"), *s, *recovery)
    tp = fp = fn = 0
    err_in = err_out = valid = changed = clean_px = 0.0
    moved = put_back = worse = 0  # pixels moved > 2 cm, of them put back within 1 cm; frames made worse
    per: dict[str, list[float]] = {}  # kind: frames, flagged, pixels hit, found, error before, after
    cams: dict[str, list[float]] = {}  # camera: frames (all), error before, after
    for i, (b, c) in enumerate(zip(bad, clean, strict=True)):
        out = cv2.imread(str(tmp / f"{name}-fixed" / f"{i:05d}.png"), cv2.IMREAD_UNCHANGED)
        mask = cv2.imread(str(tmp / f"{name}-fixed" / "masks" / f"{i:05d}.png"), cv2.IMREAD_UNCHANGED) > 0
        true = b != c
        ok = c > 0
        e_in = float((((b.astype(np.float64) - c) / scale)[ok] ** 2).sum())
        e_out = float((((out.astype(np.float64) - c) / scale)[ok] ** 2).sum())
        if cameras:  # every frame of the camera, clean ones too: a repair's harm there counts
            cam = cams.setdefault(cameras[i], [0.0] * 3)
            cam[0], cam[1], cam[2] = cam[0] + 1, cam[1] + e_in, cam[2] + e_out
        if truth[i]:
            err_in, err_out = err_in + e_in, err_out + e_out
            far = ok & (b > 0) & (np.abs(b.astype(np.float64) - c) > 0.02 * scale)
            moved += int(far.sum())
            put_back += int((far & (np.abs(out.astype(np.float64) - c) <= 0.01 * scale)).sum())
            worse += int(e_out > e_in)
            valid += float(ok.sum())
            tp += int((mask & true).sum())
            fp += int((mask & ~true).sum())
            fn += int((~mask & true).sum())
            changed += float(((out != b) & ~true).sum())
            clean_px += float((~true).sum())
            if kinds:
                k = per.setdefault(kinds[i], [0.0] * 6)
                k[0] += 1
                k[1] += float(pred[i])
                k[2] += float(true.sum())
                k[3] += float((mask & true).sum())
                k[4] += e_in
                k[5] += e_out
    p = tp / max(tp + fp, 1)
    r = tp / max(tp + fn, 1)
    dp = float((pred & truth).sum()) / max(float(pred.sum()), 1)
    dr = float((pred & truth).sum()) / max(float(truth.sum()), 1)
    return {
        "frames": len(clean),
        "interfered": int(truth.sum()),
        **counted,
        "detector_precision": round(dp, 4),
        "detector_recall": round(dr, 4),
        "rmse_cm_before": round(100 * np.sqrt(err_in / max(valid, 1)), 2),
        "rmse_cm_after": round(100 * np.sqrt(err_out / max(valid, 1)), 2),
        "moved_2cm_put_back": round(put_back / max(moved, 1), 4),  # within 1 cm of the clean depth
        "frames_worse": f"{worse} of {int(truth.sum())}",
        "rmse_change": round(float(np.sqrt(err_out / max(err_in, 1e-12)) - 1), 4),
        "mask_precision": round(p, 4),
        "mask_recall": round(r, 4),
        "mask_f1": round(2 * p * r / max(p + r, 1e-12), 4),
        "clean_changed": round(changed / max(clean_px, 1), 5),
    } | ({"by_kind": {
        name: {"frames": int(k[0]), "detector_recall": round(k[1] / k[0], 4),
               "mask_recall": round(k[3] / max(k[2], 1), 4),
               "rmse_change": round(float(np.sqrt(k[5] / max(k[4], 1e-12)) - 1), 4)}
        for name, k in sorted(per.items())
    }} if per else {}) | ({"by_camera": {
        name: {"frames": int(c[0]), "rmse_change": round(float(np.sqrt(c[2] / max(c[1], 1e-12)) - 1), 4)}
        for name, c in sorted(cams.items())
    }} if cams else {})  # fmt: skip


def _moved(tmp: Path, folder: Path, scale: float, models: list[str], recovery: Sequence[str] = ()) -> dict:
    frames = sorted(folder.glob("*.png"))
    s = ["--depth-scale", f"{scale:g}", *models]
    d2sr("detect", str(folder), "--out", str(tmp / "d435.csv"), *s, "--no-scene")
    # The models alone, unless the run asked for the scene (--scene, --scene-repair): then recover as asked.
    scene = [] if "--scene" in models else ["--no-scene"]
    d2sr("recover", str(folder), "--out", str(tmp / "d435-fixed"), *s, *recovery, *scene)
    share, _, _ = moved_5cm(folder, tmp / "d435-fixed", scale)
    return {"frames": len(frames), "flagged": round(float(_flags(tmp / "d435.csv").mean()), 4),
            "moved_5cm": round(share, 5)}  # fmt: skip


def moved_5cm(folder: Path, fixed: Path, scale: float) -> tuple[float, float, float]:
    """(share of the valid pixels of ``folder``'s frames that ``fixed`` moves by more than 5 cm, the same
    in its worst frame, every pixel it changes at all, filled no-returns included, as a share of the
    valid-pixel count)."""
    moved = valid = worst = touched = 0.0
    for f in sorted(folder.glob("*.png")):
        a = cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float64)
        b = cv2.imread(str(fixed / f.name), cv2.IMREAD_UNCHANGED).astype(np.float64)
        ok = a > 0
        n = float((ok & (np.abs(a - b) / scale > 0.05)).sum())
        moved, valid, worst = moved + n, valid + float(ok.sum()), max(worst, n / max(float(ok.sum()), 1))
        touched += float((a != b).sum())
    return moved / max(valid, 1), worst, touched / max(valid, 1)
