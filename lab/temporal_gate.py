"""Diagnostic (in process, not the public CLI): would unet8-temporal help as the default if it ran only
where the last clean frame lines up with the frame (a still sensor), and unet8 everywhere else?

For each interfered frame: the share of pixels returning in both the frame and its last clean frame that
agree within 5 cm + 2% of depth (``contract.agreement``, what ``--model auto`` gates on; 0 when there is no
last clean frame), and the squared error of unet8's and of unet8-temporal's repair (as ``recover`` writes
it). Then, per gate, the RMSE change of the mix that takes the temporal repair where agreement >= gate.
Two sets: the outside L515 set of ``bench.outside`` (a still sensor; last clean frame = the frame before) and
the simulated moving robot of ``d2sr eval recovery`` (its first 60 interfered frames; the true last clean
frame, or none).

Run:  python -m lab.temporal_gate --data ../shared/data \
          --json lab/notes/results/temporal_gate.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args

from d2sr.atomic import write_result
from d2sr.contract.repair import agreement

GATES = (0.0, 0.3, 0.5, 0.6, 0.7, 0.8, 0.9, 1.01)


def squared_error(frame: np.ndarray, clean: np.ndarray, scale: float) -> float:
    """Sum of squared errors (m^2) of a frame against its clean one, over the clean frame's returns."""
    ok = clean > 0
    return float((((frame.astype(np.float64) - clean) / scale)[ok] ** 2).sum())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)

    from bench.outside.draw import SEED
    from bench.outside.sets import outside_set
    from bench.outside.sets_a_i import outside_interference

    from d2sr.contract.catalog import WEIGHTS
    from d2sr.contract.repair import repair_frame
    from d2sr.eval.models import moving_set
    from d2sr.models.inference import TorchBackend

    nets = {m: TorchBackend(None, WEIGHTS / f"{m}.safetensors") for m in ("unet8", "unet8-temporal")}

    def error(name: str, bad: np.ndarray, clean: np.ndarray, prev: np.ndarray | None, scale: float) -> float:
        x = (bad.astype(np.float32) / np.float32(scale))[None]
        pred, mask = nets[name].recover(x, None if prev is None else prev[None])
        return squared_error(repair_frame(bad, pred[0], mask[0], scale)[0], clean, scale)

    frames = outside_set(args.data)
    s = 4000.0
    outside = [
        (outside_interference(frames[i], s, SEED + i), frames[i], frames[i - 1].astype(np.float32) / s, s)
        for i in range(1, len(frames), 2)
    ]
    ms = moving_set()
    moving = [
        (ms.frames[i], ms.clean[i], ms.previous(int(i)), ms.scale_at(int(i)))
        for i in np.flatnonzero(ms.labels)[:60]
    ]
    result: dict = {"gate_rule": "temporal where agreement >= gate, unet8 elsewhere"}
    for name, items in (("outside_l515", outside), ("moving", moving)):
        items = [it for it in items if (it[0] != it[1]).any()]
        rows = []
        for bad, clean, prev, scale in items:
            rows.append(
                (
                    agreement(bad.astype(np.float32) / np.float32(scale), prev),
                    squared_error(bad, clean, scale),
                    error("unet8", bad, clean, None, scale),
                    error("unet8-temporal", bad, clean, prev, scale),
                )
            )
        r = np.array(rows)
        gates = {}
        for g in GATES:
            use = r[:, 0] >= g
            err = np.where(use, r[:, 3], r[:, 2]).sum()
            gates[f"{g:g}"] = {
                "temporal_share": round(float(use.mean()), 3),
                "rmse_change": round(float(np.sqrt(err / r[:, 1].sum()) - 1), 4),
            }
        result[name] = {
            "frames": len(items),
            "no_last_clean": sum(it[2] is None for it in items),
            "agreement_quartiles": [round(float(q), 3) for q in np.percentile(r[:, 0], [0, 25, 50, 75, 100])],
            "gates": gates,
        }
        print(name, result[name], flush=True)
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
