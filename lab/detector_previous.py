"""Benchmark: a temporal detector scored against its own last clean frame (``TrainSettings.clean_previous``)
beside the shipped detector as the runtime scores it now, in process, each sequence in order.

* ``shipped``: the runtime's way (``FastDetector.forward``): the frame with the frame delivered before it
  and the frame alone, the lower logit.
* ``clean previous``: the frame with the last frame this detector judged clean, where that lines up with it
  (``contract.agreement`` >= ``LINES_UP``), else the frame alone; a frame not flagged becomes the last clean
  one.

On the open outside sets of ``bench.outside`` (recall and precision, 120 L515 frames, every other corrupted),
the clean real sequences (L515 dev0 after the person and dev1, D435: false alarms) and the single clean
frames (Azure Kinect, TUM, Open3D: flagged or not), at threshold 0.5.

Run:  python -m lab.detector_previous --json lab/notes/results/detector_previous.json \
          --weights runs/detector-clean-previous/detector-temporal.safetensors
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from bench.harness import check_output, output_args
from bench.outside.sets import every_other, open_sets, outside_set

from d2sr.atomic import write_result
from d2sr.contract.catalog import THRESHOLD, WEIGHTS, padded
from d2sr.contract.repair import LINES_UP, agreement
from d2sr.errors import D2SRError
from d2sr.eval.generalization import real_clean_sets
from d2sr.frames import open_frames
from d2sr.models.store import load_model

Score = Callable[[list[np.ndarray], float], np.ndarray]


def _logit(net: torch.nn.Module, x: np.ndarray, other: np.ndarray) -> float:
    with torch.no_grad():
        pair = torch.from_numpy(np.stack([x, other])[None])
        return float(net.logit(pair)[0])  # type: ignore[operator]


def shipped(net: torch.nn.Module) -> Score:
    def run(frames: list[np.ndarray], scale: float) -> np.ndarray:
        out, prev = [], None
        for f in frames:
            x = padded(f.astype(np.float32)[None] / np.float32(scale))[0]
            alone = _logit(net, x, x)
            out.append(min(alone, _logit(net, x, prev)) if prev is not None else alone)
            prev = x
        return 1 / (1 + np.exp(-np.array(out)))

    return run


def clean_previous(net: torch.nn.Module) -> Score:
    def run(frames: list[np.ndarray], scale: float) -> np.ndarray:
        out, last = [], None
        for f in frames:
            x = padded(f.astype(np.float32)[None] / np.float32(scale))[0]
            ref = last if last is not None and agreement(x, last) >= LINES_UP else x
            p = 1 / (1 + np.exp(-_logit(net, x, ref)))
            if p < THRESHOLD:
                last = x
            out.append(p)
        return np.array(out)

    return run


Sequence = tuple[str, list[np.ndarray], float, np.ndarray | None]  # name, frames, scale, which are hit


def sequences(data: Path, sets: list[str]) -> list[Sequence]:
    """Every sequence the figures are taken on, read once: the outside sets (with the frames they hit), the
    clean real sequences and the single clean frames."""
    clean = outside_set(data)
    out: list[Sequence] = []
    for which in sets:
        bad = every_other(clean, 4000.0, which)
        hit = np.array([bool((b != c).any()) for b, c in zip(bad, clean, strict=True)])
        out.append((f"set {which}", bad, 4000.0, hit))
    dev0, dev1, d435 = ([f.depth for f in open_frames(data / p)] for p in ("l515/dev0", "l515/dev1", "d435"))
    out += [("clean L515", dev0[45:] + dev1, 4000.0, None), ("clean D435", d435, 1000.0, None)]
    return out + [(s.name, s.frames, s.scale, None) for s in real_clean_sets(data) if len(s.frames) == 1]


def figures(score: Score, seqs: list[Sequence]) -> dict:
    out: dict = {}
    for name, frames, scale, hit in seqs:
        flag = score(frames, scale) >= THRESHOLD
        if hit is not None:
            out[name] = {
                "recall": round(float((flag & hit).sum() / max(hit.sum(), 1)), 4),
                "precision": round(float((flag & hit).sum() / max(flag.sum(), 1)), 4),
            }
        else:
            out[f"{name} flagged"] = bool(flag[0]) if len(frames) == 1 else round(float(flag.mean()), 4)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument(
        "--weights", type=Path, required=True, help="a temporal detector trained with clean_previous"
    )
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    try:
        ours, _ = load_model(WEIGHTS / "detector.safetensors")
        new, name = load_model(args.weights)
    except D2SRError as exc:
        ap.error(str(exc))
    if getattr(new, "frames", 1) != 2:
        ap.error(f"{args.weights}: {name} is not a temporal detector")
    seqs = sequences(args.data, open_sets())
    result = {
        "threshold": THRESHOLD,
        "weights": str(args.weights),
        "shipped": figures(shipped(ours.eval()), seqs),
        "clean previous": figures(clean_previous(new.eval()), seqs),
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
