"""``d2sr eval generalization``: the learned stages on what they were not trained on.

1. **Real clean frames of every sensor in the shared data**, at their true scales: the share of frames the
   detector flags, and the share of valid pixels that ``recover`` (flagged frames) and ``recover --repair
   all`` (every frame) move by more than 5 cm. Every flag and every moved pixel here is a false alarm.
2. **Each interference family alone on real L515 frames** (seeds no model trained on): detector recall
   and false alarms, and ``recover --repair all``'s RMSE change, mask F1 and clean pixels changed. With
   ``lofo``, also each family scored by a detector trained without it (leave-one-family-out); with
   ``lofo_recovery``, the mask F1 of a recovery model trained without it, beside one trained by the same
   recipe on every family.

The worst cell of each column is reported beside the mean.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from d2sr.contract.catalog import padded
from d2sr.contract.metrics import RepairSums
from d2sr.contract.repair import repair_frame
from d2sr.errors import InputError
from d2sr.frames import open_frames
from d2sr.frames.base import to_metres
from d2sr.runtime.backends import Backend
from d2sr.sim.families import FAMILIES, WideSettings, wide_interference

__all__ = ["FAMILY_SEED", "RealSet", "family_rows", "real_clean_sets", "real_rows"]

FAMILY_SEED = 3_000_000  # interference seeds of this evaluation: training and other tests never draw them
VISIBLE = 0.01  # recall is also reported on frames with at least this share of valid pixels hit
MOVED_M = 0.05  # a valid pixel moved by more than this counts as changed (the 5 cm)
L515_STRIDE = 3  # every third L515 frame: consecutive static frames add little


@dataclass
class RealSet:
    name: str
    sensor: str
    frames: list[np.ndarray]  # uint16
    scale: float
    sequence: bool = False  # frames in time order: a temporal detector sees each one's predecessor


def _sun(raw: np.ndarray) -> np.ndarray:
    r = raw.astype(np.uint32)
    return (((r >> 3) | (r << 13)) & 0xFFFF).astype(np.uint16)


def _nyu(raw: np.ndarray) -> np.ndarray:
    r = raw.byteswap().astype(np.float32)
    with np.errstate(divide="ignore"):
        m = np.where((r < 2047) & (r < 1092), 351.3 / (1092.5 - r), 0)
    return np.clip(np.rint(m * 1000), 0, 65535).astype(np.uint16)


def _image(path: Path, decode: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None or img.dtype != np.uint16 or img.ndim != 2:
        raise InputError(f"{path}: not a 16-bit depth image")
    return decode(img) if decode else img


def real_clean_sets(root: Path) -> list[RealSet]:
    """Every clean depth frame of ``root`` (../shared/data) at its true scale; missing parts are skipped."""
    out = []
    for cap in ("dev0", "dev1"):
        if (root / "l515" / cap).is_dir():
            r = open_frames(root / "l515" / cap)
            frames = [f.depth for f in r][::L515_STRIDE]
            out.append(RealSet(f"L515 {cap}", "L515 (lidar)", frames, r.depth_scale or 4000.0, True))
    if (root / "d435").is_dir():
        frames = [f.depth for f in open_frames(root / "d435")]
        out.append(RealSet("D435", "D435 (active stereo)", frames, 1000.0, True))
    azure = "Azure Kinect (ToF)"
    singles = [
        ("Azure Kinect 640x576", azure, "azure_kinect/depth_640x576_mm.png", 1000.0, None),
        ("Azure Kinect crop", azure, "azure_kinect/depth_640x480_centercrop_mm.png", 1000.0, None),
        ("TUM", "Kinect v1 (structured light)", "open3d_rgbd/TUM_depth.png", 5000.0, None),
        ("SUN", "structured light", "open3d_rgbd/SUN_depth.png", 1000.0, _sun),
        ("NYU", "Kinect v1 (structured light)", "open3d_rgbd/NYU_depth.pgm", 1000.0, _nyu),
        ("Open3D other", "unknown", "open3d_rgbd/unknown_origin_depth.png", 1000.0, None),
    ]
    for name, sensor, rel, scale, decode in singles:
        if (root / rel).is_file():
            out.append(RealSet(name, sensor, [_image(root / rel, decode)], scale))
    if not out:
        raise InputError(f"{root}: none of the shared real data sets found")
    return out


def _metres(frame: np.ndarray, scale: float) -> np.ndarray:
    return padded(to_metres(frame, scale)[None])


def _run(
    net: Backend, frame: np.ndarray, scale: float, before: np.ndarray | None = None, score: bool = True
) -> tuple[float, np.ndarray, np.ndarray]:
    """(score, repaired frame as ``recover --repair all`` writes it, mask of pixels repaired) for one frame;
    ``before``: the frame delivered before it (uint16), for a temporal detector; ``score=False``: a
    recovery model alone (the score is nan)."""
    h, w = frame.shape
    x = _metres(frame, scale)
    p = None if before is None else _metres(before, scale)
    s = float(net.scores(x, p)[0]) if score else float("nan")
    pred, mask = net.recover(x)
    out, kept = repair_frame(frame, pred[0, :h, :w], mask[0, :h, :w], scale)
    return s, out, kept


def real_rows(net: Backend, sets: list[RealSet], tick: Callable[[], None] | None = None) -> list[dict]:
    """Per real clean set: frames flagged, valid pixels moved > 5 cm by recover (flagged) and --repair all."""
    rows = []
    for s in sets:
        flagged = moved_all = moved_flagged = valid = 0.0
        worst = 0.0
        for k, f in enumerate(s.frames):
            score, out, _ = _run(net, f, s.scale, s.frames[k - 1] if s.sequence and k else None)
            ok = f > 0
            moved = ok & (np.abs(out.astype(np.float32) - f) / s.scale > MOVED_M)
            n = float(moved.sum())
            flagged += score >= net.threshold
            moved_all += n
            moved_flagged += n if score >= net.threshold else 0
            valid += float(ok.sum())
            worst = max(worst, n / max(float(ok.sum()), 1))
            if tick:
                tick()
        rows.append(
            {
                "set": s.name,
                "sensor": s.sensor,
                "frames": len(s.frames),
                "scale": s.scale,
                "flagged": round(flagged / len(s.frames), 4),
                "moved_recover": round(moved_flagged / max(valid, 1), 5),
                "moved_recover_all": round(moved_all / max(valid, 1), 5),
                "moved_recover_all_worst_frame": round(worst, 5),
            }
        )
    return rows


def _family_frames(sets: list[RealSet], family: str) -> Iterator[tuple[np.ndarray, np.ndarray, float]]:
    """(frame, clean, scale): the L515 frames, every other one interfered by ``family`` alone."""
    k = 0
    for s in sets:
        for f in s.frames:
            k += 1
            if k % 2:
                yield f, f, s.scale
                continue
            bad, _, _ = wide_interference(f, s.scale, FAMILY_SEED + k, WideSettings(families=(family,)))
            yield bad, f, s.scale


def family_rows(
    net: Backend,
    sets: list[RealSet],
    lofo: dict[str, Backend] | None = None,
    families: tuple[str, ...] = FAMILIES,
    tick: Callable[[], None] | None = None,
    lofo_recovery: dict[str, Backend] | None = None,
) -> list[dict]:
    """Per interference family on the real L515 frames: detector recall and false alarms (also by the
    detector trained without that family, from ``lofo``), and recover --repair all on the interfered frames
    (also by a recovery model trained without the family, ``lofo_recovery[family]``, beside one trained the
    same way on every family, ``lofo_recovery["all"]``)."""
    rec_lofo = lofo_recovery or {}
    l515 = [s for s in sets if s.name.startswith("L515")]
    if not l515:
        raise InputError("the family table needs the real L515 captures (../shared/data/l515)")
    rows = []
    for fam in families:
        scores, left_out, labels, shares = [], [], [], []
        ident, sums = RepairSums(), RepairSums()
        pair = [rec_lofo[k] for k in (fam, "all") if k in rec_lofo] if fam in rec_lofo else []
        pair_sums = [RepairSums() for _ in pair]
        for bad, clean, scale in _family_frames(l515, fam):
            interfered = bool((bad != clean).any())
            score, out, kept = _run(net, bad, scale)
            scores.append(score)
            labels.append(interfered)
            shares.append(float((bad != clean).sum()) / max(float((clean > 0).sum()), 1))
            if lofo and fam in lofo:
                left_out.append(float(lofo[fam].scores(_metres(bad, scale))[0]))
            if interfered:
                s = np.float32(scale)
                x, y = bad.astype(np.float32) / s, clean.astype(np.float32) / s
                true = bad != clean
                ident.add(x, np.zeros_like(true), x, y, true)
                sums.add(out.astype(np.float32) / s, kept, x, y, true)
                for b, acc in zip(pair, pair_sums, strict=True):
                    _, o, k = _run(b, bad, scale, score=False)
                    acc.add(o.astype(np.float32) / s, k, x, y, true)
            if tick:
                tick()
        lab = np.array(labels)
        big = lab & (np.array(shares) >= VISIBLE)
        pred = np.array(scores) >= net.threshold
        r = sums.result()
        base = max(ident.result()["rmse_cm"], 1e-9)
        row = {
            "family": fam,
            "frames": len(lab),
            "recall": round(float(pred[lab].mean()), 4),
            "recall_1pct": round(float(pred[big].mean()), 4) if big.any() else None,
            "false_alarms": round(float(pred[~lab].mean()), 4),
            "rmse_vs_identity": round(r["rmse_cm"] / base - 1, 4),
            "mask_f1": round(r["mask_f1"], 4),
            "clean_changed": round(r["clean_changed"], 5),
        }
        if left_out:
            cut = lofo[fam].threshold if lofo else net.threshold
            row["recall_left_out"] = round(float((np.array(left_out) >= cut)[lab].mean()), 4)
        for key, acc in zip(("mask_f1_left_out", "mask_f1_same_recipe"), pair_sums, strict=False):
            row[key] = round(acc.result()["mask_f1"], 4)
        rows.append(row)
    return rows


def summary(real: list[dict], fams: list[dict]) -> dict:
    """Mean and worst of each column (worst: the highest false-alarm or change, the lowest recall or F1)."""
    out: dict = {}
    for key in ("flagged", "moved_recover", "moved_recover_all"):
        v = [r[key] for r in real]
        worst = max(real, key=lambda r: r[key])
        out[key] = {"mean": round(float(np.mean(v)), 5), "worst": worst[key], "worst_set": worst["set"]}
    for key, low in (
        ("recall", True),
        ("recall_1pct", True),
        ("recall_left_out", True),
        ("false_alarms", False),
        ("rmse_vs_identity", False),
        ("mask_f1", True),
        ("mask_f1_left_out", True),
        ("clean_changed", False),
    ):
        have = [r for r in fams if r.get(key) is not None]
        if not have:
            continue
        worst = (min if low else max)(have, key=lambda r: r[key])
        out[key] = {
            "mean": round(float(np.mean([r[key] for r in have])), 5),
            "worst": worst[key],
            "worst_family": worst["family"],
        }
    return out


def table(real: list[dict], fams: list[dict], worst: dict) -> str:
    """The committed README's tables (markdown)."""
    lines = [
        "### Real clean frames (false alarms)",
        "",
        "| set | sensor | frames | flagged | px moved >5 cm (recover) | (--repair all) | worst frame |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in real:
        lines.append(
            f"| {r['set']} | {r['sensor']} | {r['frames']} | {r['flagged']:.1%} | {r['moved_recover']:.2%} "
            f"| {r['moved_recover_all']:.2%} | {r['moved_recover_all_worst_frame']:.2%} |"
        )
    lines += [
        "",
        "### Each interference family alone on real L515 frames",
        "",
        "| family | frames | recall | recall, >=1% hit | recall, trained without it | false alarms "
        "| RMSE vs identity | mask F1 | mask F1, trained without it (with it) | clean px changed |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in fams:
        lo = f"{r['recall_left_out']:.3f}" if "recall_left_out" in r else "n/a"
        mlo = f"{r['mask_f1_left_out']:.3f}" if "mask_f1_left_out" in r else "n/a"
        if "mask_f1_same_recipe" in r:
            mlo += f" ({r['mask_f1_same_recipe']:.3f})"
        lines.append(
            f"| {r['family']} | {r['frames']} | {r['recall']:.3f} | {r['recall_1pct'] or 0:.3f} | {lo} "
            f"| {r['false_alarms']:.3f} "
            f"| {r['rmse_vs_identity']:+.1%} | {r['mask_f1']:.3f} | {mlo} | {r['clean_changed']:.2%} |"
        )
    lines += ["", "### Worst cells", "", "| measure | mean | worst | where |", "|---|---|---|---|"]
    for k, v in worst.items():
        where = v.get("worst_set", v.get("worst_family"))
        lines.append(f"| {k} | {v['mean']:.4g} | {v['worst']:.4g} | {where} |")
    return "\n".join(lines) + "\n"
