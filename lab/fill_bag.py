"""Benchmark (issue 43, the loop's paths): ``d2sr run BAG --fill --colour-topic`` on a duty-cycled recording.
The real hand-held D435 RGB-D sequence (``../shared/data/d435``, depth aligned to colour) is written into a
temporary ROS 2 bag as a duty-cycled sensor would have recorded it: colour (bgr8) in every slot at 30 Hz,
depth (16UC1, mm) only in slots 0..n-1 of every 30. ``d2sr run`` (detect, de-synchronize, repair where
flagged) fills every colour frame that came without depth. Reports, for n = 15 and 6: the synthesized
frames' RMSE and coverage against the real frames they stand for (the pooling of ``lab/fill_d435.py``),
hold-last's, the largest difference from ``d2sr fill``'s frames for the same slots, and frames out a second
of the whole command (bag reading and PNG writing included).

Run:  python -m lab.fill_bag --data ../shared/data --json docs/results/fill_bag.json
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import used_models
from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_typestore

from d2sr.atomic import write_result
from d2sr.desync import TOTAL_FRAMES
from d2sr.synth import FillSettings, fill_recording
from lab.fill_d435 import read
from lab.fill_eval import PooledError

FAR_MM = 8000
DEPTH, COLOUR = "/d435/depth/image_rect_raw", "/d435/color/image_raw"
STEP_NS = 33_333_333


def write_bag(path: Path, depth: list[Path], colour: list[Path], active: int) -> None:
    """The sequence as a duty-cycled sensor records it (colour every slot, depth in the window only)."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    image = ts.types["sensor_msgs/msg/Image"]

    def header(ns: int) -> object:
        t = ts.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        return ts.types["std_msgs/msg/Header"](stamp=t, frame_id="d435")

    with Writer(path, version=9) as bag:
        dc = bag.add_connection(DEPTH, "sensor_msgs/msg/Image", typestore=ts)
        cc = bag.add_connection(COLOUR, "sensor_msgs/msg/Image", typestore=ts)
        for i, (d, c) in enumerate(zip(depth, colour, strict=False)):
            ns = 10**9 + i * STEP_NS
            rgb = cv2.imread(str(c), cv2.IMREAD_COLOR)
            h, w = rgb.shape[:2]
            m = image(header(ns), h, w, "bgr8", 0, w * 3, rgb.reshape(-1))
            bag.write(cc, ns, ts.serialize_cdr(m, "sensor_msgs/msg/Image"))
            if i % TOTAL_FRAMES < active:
                px = cv2.imread(str(d), cv2.IMREAD_UNCHANGED)
                m = image(header(ns), h, w, "16UC1", 0, w * 2, np.frombuffer(px.tobytes(), np.uint8))
                bag.write(dc, ns, ts.serialize_cdr(m, "sensor_msgs/msg/Image"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    seq = args.data / "d435"
    depth = sorted(seq.glob("depth*.png"))
    colour = sorted((seq / "rgb").iterdir())[: len(depth)]
    real = [read(f) for f in depth]
    result: dict = {
        "data": f"{seq} ({len(depth)} frames, hand-held D435, depth aligned to colour; development "
        "sequence), written into a duty-cycled ROS 2 bag",
        "runs": [],
    }
    for n in (15, 6):
        with tempfile.TemporaryDirectory() as tmp:
            bag, out, ref = Path(tmp) / "bag", Path(tmp) / "run", Path(tmp) / "fill"
            write_bag(bag, depth, colour, n)
            cmd = [sys.executable, "-m", "d2sr", "run", str(bag), "--topic", DEPTH, "--fill",
                   "--colour-topic", COLOUR, "--active-frames", str(n), "--depth-scale", "1000",
                   "--out", str(out)]  # fmt: skip
            t = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            seconds = time.perf_counter() - t
            fill_recording(seq, ref, FillSettings(active_frames=n, colour=seq / "rgb"))
            rows = list(csv.DictReader((out / "log.csv").open()))
            synth = [r for r in rows if r["synthesized"] == "1"]
            ours, hold = PooledError(1000, FAR_MM), PooledError(1000, FAR_MM)
            diff, flagged = 0.0, sum(r["flagged"] == "1" for r in rows)
            for r in synth:
                i = round((float(r["time_s"]) - 1.0) * 1e9 / STEP_NS)
                got = read(out / "sensor0" / "depth" / f"{r['frame']}.png")
                ours.add(got, real[i])
                hold.add(real[(i // TOTAL_FRAMES) * TOTAL_FRAMES + n - 1], real[i])
                diff = max(diff, float(np.abs(got - read(ref / depth[i].name)).max()))
        result["runs"].append({
            "active_frames": n,
            "real_frames": len(rows) - len(synth),
            "flagged": flagged,
            "synthesized": len(synth),
            "rmse_cm": ours.rmse_cm(),
            "hold_last_rmse_cm": hold.rmse_cm(),
            "rmse_vs_hold_last": round(ours.rmse_cm() / hold.rmse_cm(), 3),
            "coverage_vs_hold_last": round(ours.coverage() / hold.coverage(), 3),
            "max_mm_from_d2sr_fill": diff,
            "frames_per_second": round(len(rows) / seconds, 1),
        })  # fmt: skip
        print(result["runs"][-1], flush=True)
    print(write_result(result, args.json, models=used_models(None)))


if __name__ == "__main__":
    main()
