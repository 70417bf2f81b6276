"""Benchmark: ``d2sr recover --repair all --model auto`` (unet8-temporal where the last clean frame lines up with the
frame, unet8 elsewhere) against each model alone, from outside, on two sequences:

* ``still``: the outside L515 set of ``bench.outside`` (a sensor that held still; every other frame corrupted by
  interference written apart from the generator);
* ``moving``: the simulated robot driving among three fixed sensors of ``d2sr eval recovery`` (a held-out
  room), every frame in order, as the robot delivered it.

Per model and sequence: ``d2sr recover --repair all``'s RMSE change, mask F1 and clean pixels changed on the frames
that differ from their clean version (``bench.outside``'s ``scored``). And do no harm: on the real clean sequences of
../shared/data (L515 dev0 and dev1, D435), the share of valid pixels ``recover --repair all`` moves by more than
5 cm, over the sequence and in its worst frame; and every pixel it changes at all (no-return pixels it fills
included), as a share of the valid-pixel count.

Run:  python -m lab.auto_gate --data ../shared/data --json docs/results/auto_gate.json
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.score import d2sr, moved_5cm, scored
from bench.outside.sets import SETS, every_other, outside_set

from d2sr.atomic import write_result

MODELS = ("unet8", "unet8-temporal", "auto")
CLEAN = (("l515/dev0", 4000.0), ("l515/dev1", 4000.0), ("d435", 1000.0))


def moved(folder: Path, scale: float, out: Path, args: list[str]) -> dict:
    """``d2sr recover --repair all`` on a clean sequence: pixels moved > 5 cm, in all and in its worst frame."""
    d2sr("recover", str(folder), "--repair", "all", "--out", str(out), "--depth-scale", f"{scale:g}", *args)
    share, worst, changed = moved_5cm(folder, out, scale)
    return {
        "moved_5cm": round(share, 5),
        "worst_frame": round(worst, 5),
        "changed": round(changed, 5),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--models", type=Path, default=None, help="a model folder (default: the shipped models)")
    ap.add_argument("--mask-logit", type=float, default=None, help="recover's --mask-logit for every model")
    ap.add_argument(
        "--set", choices=sorted(SETS), default="a", help="bench/outside's outside set for `still`"
    )
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)

    from d2sr.eval.models import moving_set

    folder = ["--models", str(args.models)] if args.models else []
    logit = ["--mask-logit", f"{args.mask_logit:g}"] if args.mask_logit is not None else []
    clean = outside_set(args.data)
    still = (every_other(clean, 4000.0, args.set), clean)
    ms = moving_set()
    scales = np.unique(np.asarray(ms.scale))
    if scales.size != 1:
        raise SystemExit(f"the moving set has several depth scales: {scales}")
    sets = {"still": (*still, 4000.0), "moving": (list(ms.frames), list(ms.clean), float(scales[0]))}
    result: dict = {
        "model_folder": str(args.models or "shipped"),
        "set": args.set,
        "mask_logit": args.mask_logit,
    }
    with tempfile.TemporaryDirectory() as t:
        for name, (bad, good, scale) in sets.items():
            hit = sum(bool((b != c).any()) for b, c in zip(bad, good, strict=True))
            result[name] = {"frames": len(bad), "interfered": hit}
            for m in MODELS:
                r = scored(Path(t) / m, name, bad, good, scale, folder, ["--model", m, *logit])
                result[name][m] = {k: r[k] for k in ("rmse_change", "mask_f1", "clean_changed")}
                print(name, m, result[name][m], flush=True)
        for sub, scale in CLEAN:
            result[sub] = {}
            for m in MODELS:
                out = Path(t) / m / sub.replace("/", "-")
                result[sub][m] = moved(args.data / sub, scale, out, [*folder, "--model", m, *logit])
                print(sub, m, result[sub][m], flush=True)
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
