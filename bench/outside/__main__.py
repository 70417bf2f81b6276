"""Benchmark: the shipped (or adapted) models from outside, on the public CLI, against interference written
apart from the project's generator, on real frames of ../shared/data.

The outside interference is not in ``d2sr.sim``: phase-wrapping rings (a time-of-flight camera's depth
folds at its ambiguity range where another camera's modulated light adds in), and sawtooth stripes
(depth scaled by a ramp that repeats across the image). The generator has neither wrapping nor ramps.
``--set b`` (written later, to check a threshold read off set A): Lissajous crosstalk and multipath ghost
tiles (``crosstalk_interference``). ``--set c`` (written after both had judged eight trials, to judge what was
chosen on them): range-gated phantoms and scan-line echo bursts (``echo_interference``). ``--set d`` (sealed
when written, opened 2026-11-26 to confirm unet8-shell, a choice made on sets A and B): emitter bloom and
phase-unwrapping errors (``bloom_interference``). ``--set e`` (written and sealed 2026-11-26, before any
model ran on it, to confirm choices made on sets A-D; ``lab/notes/decisions.md``): moire beats and
row tearing (``beat_interference``). ``--set f`` (written and sealed 2026-11-26, before any model ran on
it):
another sensor's projector, a dot lattice or Gray-code stripes (``projector_interference``). ``--set g``
(written and sealed 2026-11-26, before any model or scene reference ran on it; opened the same day to judge
the scene's repair): another CW-ToF camera's light, a surface read 2-5 cm off with almost no dropouts
(``tof_interference``). ``--set h`` (written and sealed 2026-11-26, before any model or scene reference ran
on it; opened the same day to judge the scene's shifted windows): CW-ToF multipath and phase crosstalk,
surfaces read 1.5-4 cm off (``tof_bias_interference``). ``--set i`` (written and sealed 2026-11-26, before
the guard's lone-return rule ran on it; opened the same day to judge it): lone wrong returns among dropouts,
a blinded region's survivors read too near or another scanner's direct beam (``sparse_interference``).
``--set k`` (written and sealed 2026-11-27, to judge the scene's stillness gate; ``lab/scene_gate.py``
opened it the same day, on the moving D435 as well): flood noise and diagonal scanner combs
(``flood_interference``). ``--set l`` (written and sealed 2026-11-27, to judge the scene's 16-stripe upkeep;
``lab/scene_gate.py --what stripes`` opened it the same day): rows read skewed sideways and a mirror ghost
(``skew_interference``). Sets M-S (2026-11-27), each written and sealed to judge one setting of the scene
and opened once by ``lab/scene_gate.py`` or ``lab/scene_repair.py``: a timing walk and phase wedges
(``walk_interference``), a cover window's ghost and column crosstalk (``window_interference``), flying
edges and blotch fields (``blotch_interference``), spark segments and echo rings (``spark_interference``),
dash rain and grid glints (``rain_interference``), dropouts made to return and edge spray
(``dark_interference``), and stray light as a speckle veil or beam scatter (``veil_interference``);
``STATUS`` says what each judged.

* ``l515``: 120 real L515 frames (dev0 after the person has left, and dev1), every other one corrupted:
  ``d2sr detect`` precision and recall; ``d2sr recover --repair all`` RMSE change, mask F1, clean pixels
  changed.
* ``d435``: the 193 clean D435 frames at scale 1000: frames flagged by ``d2sr detect``, valid pixels
  moved by more than 5 cm by ``d2sr recover``.
* ``adapt`` (with --adapt): ``d2sr adapt`` on the first 100 D435 frames, then the other 93, every other one
  corrupted, through ``--models``: precision, recall, recover --repair all mask F1; and the time adapt took.

Run:  make outside   (every set with recover's default and each shipped recovery model:
                     docs/results/outside/SET-MODEL.json)
      python -m bench.outside --data ../shared/data --set b --model unet8 --adapt \
          --json out/outside_b.json
Each result records its provenance and ``data``: the set, its status (``STATUS``: what it has been used
for) and the calibration overlap. The files under lab/notes/results/ are older runs, kept as the
decisions that cite them saw them.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import cv2
from bench.harness import check_output, output_args
from bench.outside.score import _moved, _scored, d2sr
from bench.outside.sets import OUTSIDE_CAMERAS, SETS, outside_set, set_data, used_models

from d2sr.atomic import write_result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--models", type=Path, default=None, help="a model folder (default: the shipped models)")
    ap.add_argument("--model", default=None, help="recover's --model (default: its own, auto)")
    ap.add_argument(
        "--mask-logit", type=float, default=None, help="recover's --mask-logit (default: the model's)"
    )
    ap.add_argument(
        "--set",
        choices=sorted(SETS),
        default="a",
        help="outside interference: a (rings, sawtooth), b (Lissajous crosstalk, multipath ghost tiles), "
        "c (range-gated phantom, scan-line echo bursts), d (emitter bloom, unwrapping errors), "
        "e (moire beat, row tearing), f (dot lattice, Gray-code stripes), g (CW-ToF surface shifts), "
        "h (CW-ToF multipath, phase crosstalk), i (blackout sparkle, scan ghost)",
    )
    ap.add_argument("--passes", type=int, default=None, help="recover's --passes (default: its own)")
    ap.add_argument("--scene", action="store_true", help="detect and recover with --scene (a still sensor)")
    ap.add_argument("--scene-repair", action="store_true", help="recover also with --scene-repair")
    ap.add_argument("--adapt", action="store_true", help="also run the d2sr adapt bar on the D435 frames")
    ap.add_argument("--minutes", type=float, default=None, help="d2sr adapt's budget (default: its own)")
    ap.add_argument("--keep", type=Path, default=None, help="write the adapted folder here (new) to study it")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    if args.keep is not None and args.keep.exists():
        ap.error(f"--keep {args.keep} exists: give a new folder")
    if args.scene_repair and not args.scene:
        ap.error("--scene-repair needs --scene")
    models = (["--models", str(args.models)] if args.models else []) + (["--scene"] if args.scene else [])
    recovery = (["--model", args.model] if args.model else []) + (
        ["--mask-logit", f"{args.mask_logit:g}"] if args.mask_logit is not None else []
    )
    recovery += ["--scene-repair"] if args.scene_repair else []
    recovery += ["--passes", str(args.passes)] if args.passes is not None else []
    result: dict = {
        "model_folder": str(args.models or "shipped"),
        "model": args.model or "default",
        "set": args.set,
        "scene": "--scene --scene-repair" if args.scene_repair else "--scene" if args.scene else "off",
    }
    if args.mask_logit is not None:
        result["mask_logit"] = args.mask_logit
    if args.passes is not None:
        result["passes"] = args.passes
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        result["l515"] = _scored(
            tmp, "l515", outside_set(args.data), 4000.0, models, recovery, args.set, OUTSIDE_CAMERAS
        )
        print("l515", result["l515"], flush=True)
        result["d435"] = _moved(tmp, args.data / "d435", 1000.0, models, recovery)
        print("d435", result["d435"], flush=True)
        if args.adapt:
            files = sorted((args.data / "d435").glob("*.png"))
            first = tmp / "first100"
            first.mkdir()
            for f in files[:100]:
                (first / f.name).symlink_to(f.resolve())
            t0 = time.perf_counter()
            minutes = ["--minutes", f"{args.minutes:g}"] if args.minutes else []
            adapted = args.keep or tmp / "m"
            d2sr("adapt", "--clean", str(first), "--depth-scale", "1000", "--out", str(adapted), *minutes)
            took = (time.perf_counter() - t0) / 60
            # The plan adapt made of its budget (the same on any machine) and whether it kept its start.
            card = json.loads((adapted / "adapt.json").read_text())
            steps = {"plan": card["plan"], "kept": card["kept"]}
            rest = [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files[100:]]
            result["adapt"] = (
                {"minutes": round(took, 2)}
                | steps
                | _scored(tmp, "d435-rest", rest, 1000.0, ["--models", str(adapted)])
            )
            result["adapt_shipped"] = _scored(tmp, "d435-rest-shipped", rest, 1000.0, models)
            print("adapt", result["adapt"], "shipped", result["adapt_shipped"], flush=True)
    data = set_data(args.set)
    if args.adapt:
        data["adapt"] = "193 clean D435 frames: adapt on the first 100, test on the other 93"
    print(write_result(result, args.json, models=used_models(args.model), folder=args.models, data=data))


if __name__ == "__main__":
    main()
