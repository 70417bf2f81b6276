"""Benchmark: the library against the command line, on real L515 frames with interference the project's
generator never made (``bench.outside``'s ``worst_case``: 60 dev1 frames, each corrupted by the outside interference).

* ``repair``: ``d2sr.repair(frame, depth_scale=4000)`` against ``d2sr recover`` on a one-frame folder (a
  subprocess, the public CLI) for the first ``--frames`` frames: identical depth and mask, uint16 out.
* ``metres``: the same frames as float32 metres with NaN where there is no return: float32 out, every
  pixel outside the mask as it went in (NaN kept), and how far the repair lies from the uint16 one.
* ``pipeline``: ``d2sr.Pipeline(depth_scale=4000)``, primed as ``d2sr recover`` primes a recording
  (``Pipeline.prime``), over the 60 frames in order against ``d2sr recover``
  on the folder of them: identical frames, and the frames a second the pipeline took in this process.
* ``other_sensors``: the library's defaults on real clean frames of sensors the models never saw
  (``Pipeline`` over the hand-held D435 sequence; ``repair`` on the Azure Kinect, TUM and Open3D frames):
  frames flagged and the share of valid pixels changed, mean and worst frame.

Run:  python -m lab.library_bars --data ../shared/data --json docs/results/library_bars.json
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets import worst_case

import d2sr
from d2sr.atomic import write_result
from d2sr.runtime.loop import PRIME_FRAMES

HERE = Path(__file__).resolve().parents[1]


def recover(folder: Path, out: Path) -> None:
    args = [sys.executable, "-m", "d2sr", "recover", str(folder), "--depth-scale", "4000", "--out", str(out)]
    r = subprocess.run(args, capture_output=True, text=True, check=False)
    if r.returncode:
        raise SystemExit(f"d2sr recover failed: {r.stderr.strip()}")


def read(path: Path) -> np.ndarray:
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=5, help="frames checked one at a time against the CLI")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    frames = worst_case(args.data)
    result: dict = {
        "frames": len(frames),
    }
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        rows = []
        for i, (name, frame) in enumerate(frames[: args.frames]):
            one = root / f"one{i}"
            one.mkdir()
            cv2.imwrite(str(one / name), frame)
            recover(one, root / f"out{i}")
            r = d2sr.repair(frame, depth_scale=4000)
            metres = frame.astype(np.float32) / np.float32(4000)
            metres[frame == 0] = np.nan
            m = d2sr.repair(metres)
            both = m.mask & r.mask
            rows.append(
                {
                    "frame": name,
                    "interfered": r.interfered,
                    "repaired_share": round(float(r.mask.mean()), 5),
                    "uint16_out": r.depth.dtype == np.uint16,
                    "identical_to_recover": bool(
                        np.array_equal(r.depth, read(root / f"out{i}" / name))
                        and np.array_equal(r.mask, read(root / f"out{i}" / "masks" / name) > 0)
                    ),
                    "metres_float32_out": m.depth.dtype == np.float32,
                    "metres_untouched_outside_mask": bool(
                        np.array_equal(m.depth[~m.mask], metres[~m.mask], equal_nan=True)
                    ),
                    "metres_mask_agrees": round(float((m.mask == r.mask).mean()), 6),
                    "metres_max_diff_m": round(float(np.abs(m.depth[both] - r.depth[both] / 4000).max()), 6)
                    if both.any()
                    else 0.0,
                }
            )
        result["repair"] = rows
        seq = root / "seq"
        seq.mkdir()
        for name, frame in frames:
            cv2.imwrite(str(seq / name), frame)
        recover(seq, root / "seq_out")
        p = d2sr.Pipeline(depth_scale=4000)
        p.prime([f for _, f in frames[:PRIME_FRAMES]])  # as d2sr recover primes a recording's scene
        same, flagged, secs = 0, 0, []
        for k, (name, frame) in enumerate(frames):
            t = time.perf_counter()
            r = p.process(frame, timestamp_ns=k * 33_333_333)
            secs.append(time.perf_counter() - t)
            flagged += r.interfered
            same += bool(np.array_equal(r.depth, read(root / "seq_out" / name)))
        result["pipeline"] = {
            "frames_identical_to_recover": same,
            "flagged": flagged,
            "last_window": {"period": r.window.period, "offset": r.window.offset} if r.window else None,
            "ms_median": round(1000 * statistics.median(secs[5:]), 2),
        }
    result["other_sensors"] = other_sensors(args.data)
    from d2sr.provenance import data_read

    singles = [path for path, _ in _singles(args.data).values()]
    files = (
        sorted((args.data / "l515" / "dev1").glob("*.png"))[: len(frames)]
        + sorted((args.data / "d435").glob("depth*.png"))
        + singles
    )
    what = "l515/dev1 (the first frames, outside interference), d435, azure_kinect, open3d_rgbd"
    print(write_result(result, args.json, data=data_read(what, files, args.data)))


def _changed(before: np.ndarray, after: np.ndarray) -> float:
    valid = before > 0
    return float((after != before)[valid].mean()) if valid.any() else 0.0


def _singles(data: Path) -> dict[str, tuple[Path, int]]:
    """The single frames of other sensors: name -> (file, units per metre)."""
    return {
        "azure_kinect_640x576": (data / "azure_kinect" / "depth_640x576_mm.png", 1000),
        "azure_kinect_crop": (data / "azure_kinect" / "depth_640x480_centercrop_mm.png", 1000),
        "tum": (data / "open3d_rgbd" / "TUM_depth.png", 5000),
        "open3d_unknown": (data / "open3d_rgbd" / "unknown_origin_depth.png", 1000),
    }


def other_sensors(data: Path) -> dict:
    """Flags and changed pixels of the default repair on real clean frames of other sensors."""
    out: dict = {}
    p = d2sr.Pipeline(depth_scale=1000)
    d435 = [read(f) for f in sorted((data / "d435").glob("depth*.png"))]
    shares, flagged = [], 0
    for k, frame in enumerate(d435):
        r = p.process(frame, timestamp_ns=k * 33_333_333)
        flagged += r.interfered
        shares.append(_changed(frame, r.depth))
    out["d435"] = {"frames": len(d435), "flagged": flagged, "changed_mean": round(float(np.mean(shares)), 6),
                   "changed_worst": round(max(shares), 6)}  # fmt: skip
    for name, (path, scale) in _singles(data).items():
        frame = read(path)
        r = d2sr.repair(frame, depth_scale=scale)
        out[name] = {
            "interfered": r.interfered,
            "score": round(r.score, 4),
            "changed": round(_changed(frame, r.depth), 6),
        }
    return out


if __name__ == "__main__":
    main()
