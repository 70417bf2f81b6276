"""d2sr fleet on this machine's cores: the same recordings on 1 and 2 workers (frames per second and the
speed-up), and one long recording's worker memory sampled as it goes (its growth after warm-up).

The recordings are generated L515 frames (640x480, 4000 units per metre), every other one interfered, so
the detector, the scene and the repair all run; written once to a temporary folder. Ray's start-up is timed
apart: the cluster is started first and each run joins it, so the rates are the repair's.

Run:  .venv/bin/python bench/fleet.py --json docs/results/bench_fleet.json
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

import cv2

from d2sr.atomic import write_result
from d2sr.eval.speed import frame_4000
from d2sr.fleet import Cluster, FleetProgress, recover_fleet
from d2sr.runtime.settings import RunSettings
from harness import check_output, output_args

SEED = 9_100_000


def write_recordings(root: Path, count: int, frames: int, size: tuple[int, int]) -> list[Path]:
    """``count`` recordings of ``frames`` generated frames each (every other one interfered), at ``size``."""
    pool = [frame_4000(SEED + i, bool(i % 2)) for i in range(8)]
    out = []
    for r in range(count):
        folder = root / f"rec{r}"
        folder.mkdir(parents=True)
        for i in range(frames):
            f = pool[(i + r) % len(pool)]
            if f.shape != (size[1], size[0]):
                f = cv2.resize(f, size, interpolation=cv2.INTER_NEAREST)
            cv2.imwrite(str(folder / f"{i:06d}.png"), f)
        out.append(folder)
    return out


def rss_mb(pid: int) -> float | None:
    try:
        with open(f"/proc/{pid}/statm") as fh:
            return int(fh.read().split()[1]) * resource.getpagesize() / 2**20
    except OSError:
        return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=4)
    ap.add_argument("--frames", type=int, default=120, help="frames per recording of the speed runs")
    ap.add_argument("--long", type=int, default=3000, help="frames of the memory run's recording (320x240)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per worker count (the median is reported)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    import ray

    settings = RunSettings(depth_scale=4000.0)
    result: dict = {"recordings": args.recordings, "frames_each": args.frames, "size": "640x480", "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        recs = write_recordings(root / "in", args.recordings, args.frames, (640, 480))
        t = time.perf_counter()
        ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
        result["ray_start_s"] = round(time.perf_counter() - t, 2)
        for workers in (1, 2):
            rates = []
            for k in range(args.repeats):
                s = recover_fleet(
                    recs, root / f"out{workers}_{k}", settings, cluster=Cluster(workers=workers)
                )
                assert not s.failed, s.failed
                rates.append(s.fps)
            result["runs"][str(workers)] = {"fps": [round(r, 2) for r in rates],
                                            "fps_median": round(statistics.median(rates), 2)}  # fmt: skip
        one, two = (result["runs"][w]["fps_median"] for w in ("1", "2"))
        result["speedup"] = round(two / one, 3)
        same = all(
            (root / "out1_0" / r.name / n).read_bytes() == (root / "out2_0" / r.name / n).read_bytes()
            for r in recs
            for n in sorted(p.name for p in (root / "out1_0" / r.name).glob("*.png"))
        )
        result["outputs_identical_1_vs_2_workers"] = same
        # memory: one long recording, its worker's resident size sampled from here
        long = write_recordings(root / "long", 1, args.long, (320, 240))
        samples: list[tuple[int, float]] = []

        def sample(p: FleetProgress) -> None:
            for pid in p.running.values():
                mb = rss_mb(pid)
                if mb is not None:
                    samples.append((p.frames, mb))

        recover_fleet(long, root / "outlong", settings, cluster=Cluster(workers=1), progress=sample)
        ray.shutdown()
    warm = [mb for f, mb in samples if f >= args.long // 10]
    result["memory"] = {
        "frames": args.long,
        "size": "320x240",
        "samples": len(samples),
        "rss_mb_after_warmup_first": round(warm[0], 1) if warm else None,
        "rss_mb_max": round(max(warm), 1) if warm else None,
        "growth_after_warmup": round(max(warm) / warm[0] - 1, 4) if warm else None,
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
