"""Profile (issue 44): where a clean frame's milliseconds go through ``d2sr.Pipeline`` (the typical case of
``lab/speed.py``), on clean real L515 frames in order.

* Python side: ``cProfile`` of ``Pipeline.process`` with the detector and the loop (``repair="none"``):
  the time inside onnxruntime's ``run`` against everything else, per frame.
* onnxruntime side: every session the pipeline ran, replayed on one thread with profiling on, on the
  inputs the pipeline gave it: each node's median kernel time, summed by node.

It finds the sessions on the backend itself, so it profiles an earlier commit's runtime too: ``--ref REV``
profiles that commit (a temporary git worktree, in a subprocess) in the same run, before and after.
``--scene``: ``Pipeline(scene=True)``, a still sensor's frames also judged against its scene (the Pipeline's
default since 2026-11-27); without it ``scene=False``, the detector alone.

Run:  python -m lab.profile_typical --ref ccfb1d1 --data ../shared/data \
          --json docs/results/profile_typical.json
      python -m lab.profile_typical --scene --ref f309c3e --view dev1 --data ../shared/data \
          --json docs/results/profile_scene.json
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import onnxruntime as ort
from bench.harness import check_output, output_args
from bench.outside.sets import OUTSIDE_CAMERAS, outside_set, used_models

from d2sr.atomic import write_result
from d2sr.runtime.pipeline import Pipeline


def _sessions(obj: Any, seen: set[int] | None = None) -> list[Any]:
    """The onnxruntime sessions reachable from ``obj``'s attributes (a backend, or one it wraps)."""
    seen = set() if seen is None else seen
    if id(obj) in seen or not hasattr(obj, "__dict__"):
        return []
    seen.add(id(obj))
    out = []
    for v in vars(obj).values():
        if isinstance(v, ort.InferenceSession):
            out.append(v)
        elif type(v).__module__.startswith("d2sr."):
            out += _sessions(v, seen)
    return out


def _record(pipe: Pipeline, frames: list) -> dict[str, list[dict]]:
    """Each session's inputs, by model file, as the pipeline ran it on ``frames``."""
    feeds: dict[str, list[dict]] = defaultdict(list)
    for s in _sessions(pipe.loop.backend):
        run, path = s.run, s._model_path

        def recorded(names: Any, inputs: dict, *rest: Any, run: Any = run, path: str = path) -> Any:
            feeds[path].append({k: v.copy() for k, v in inputs.items()})
            return run(names, inputs, *rest)

        s.run = recorded
    for f in frames:
        pipe.process(f)
    return feeds


def _nodes(path: str, feeds: list[dict], repeats: int) -> dict:
    """Median kernel time of each node of ``path`` on one thread over ``feeds``, in ms."""
    with tempfile.TemporaryDirectory() as tmp:
        opts = ort.SessionOptions()
        opts.intra_op_num_threads, opts.enable_profiling = 1, True
        opts.profile_file_prefix = str(Path(tmp) / "p")
        s = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])
        for _ in range(repeats):
            for x in feeds:
                s.run(None, x)
        events = json.loads(Path(s.end_profiling()).read_text())
    times: dict[str, list[float]] = defaultdict(list)
    for e in events:
        if e.get("cat") == "Node" and e["name"].endswith("_kernel_time"):
            times[e["name"].removesuffix("_kernel_time")].append(e["dur"] / 1000)
    per = {k: statistics.median(v) for k, v in times.items()}
    ranked = dict(sorted(((k, round(v, 3)) for k, v in per.items()), key=lambda kv: -kv[1]))
    return {
        "runs_per_frame": len(feeds),
        "kernel_ms_per_run": round(sum(per.values()), 3),
        "nodes_ms": ranked,
    }


def profile(frames: list, repeats: int, scene: bool = False) -> dict:
    """The Python and onnxruntime profiles of ``Pipeline(repair="none", scene=scene)`` on ``frames``."""
    pipe = Pipeline(4000.0, repair="none", scene=scene)
    for f in frames[:5]:
        pipe.process(f)
    prof, cpu = cProfile.Profile(), time.process_time()
    prof.enable()
    for _ in range(repeats):
        for f in frames:
            pipe.process(f)
    prof.disable()
    n = repeats * len(frames)
    cpu_ms = 1000 * (time.process_time() - cpu) / n
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    inside = sum(
        tt for (_, _, fn), (_, _, tt, _, _) in stats.items() if "onnxruntime_pybind11_state.run" in fn
    )
    total = sum(tt for (_, _, tt, _, _) in stats.values())
    feeds = _record(Pipeline(4000.0, repair="none", scene=scene), frames)
    sessions = {Path(p).name: _nodes(p, f, repeats) for p, f in feeds.items()}
    for v in sessions.values():
        v["runs_per_frame"] = round(v["runs_per_frame"] / len(frames), 3)
    return {
        "cpu_ms_per_frame": round(cpu_ms, 2),
        "python_profile_ms_per_frame": {
            "onnxruntime run": round(1000 * inside / n, 3),
            "everything else": round(1000 * (total - inside) / n, 3),
            "of which the most": {
                f"{Path(file).name}:{line}({fn})": round(1000 * tt / n, 3)
                for (file, line, fn), (_, _, tt, _, _) in sorted(stats.items(), key=lambda kv: -kv[1][2])[1:8]
            },
        },
        "onnxruntime_one_thread": sessions,
    }


def _at(rev: str, argv: list[str]) -> dict:
    """This script's profile of commit ``rev``'s runtime, in a subprocess on a temporary worktree."""
    here = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        tree, git = Path(tmp) / "ref", ["git", "-C", str(here), "worktree"]
        subprocess.run([*git, "add", "--detach", str(tree), rev], check=True, capture_output=True)
        try:
            env = dict(os.environ, PYTHONPATH=f"{tree / 'src'}{os.pathsep}{here / 'bench'}")
            cmd = [sys.executable, __file__, *argv, "--inner"]
            r = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
        finally:
            subprocess.run([*git, "remove", "--force", str(tree)], check=False, capture_output=True)
    if r.returncode:
        raise SystemExit(f"profiling {rev} failed: {r.stderr.strip().splitlines()[-1:]}")
    out: dict = json.loads(r.stdout)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--view", default="dev0", choices=("dev0", "dev1"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ref", help="also profile this commit (git rev), first, in the same run")
    ap.add_argument("--scene", action="store_true", help="Pipeline(scene=True): judged against the scene too")
    ap.add_argument("--inner", action="store_true", help=argparse.SUPPRESS)
    output_args(ap)
    args = ap.parse_args()
    frames = [f for f, cam in zip(outside_set(args.data), OUTSIDE_CAMERAS, strict=True) if cam == args.view]
    if args.inner:  # the --ref run: the profile alone, on stdout
        print(json.dumps(profile(frames, args.repeats, args.scene)))
        return
    check_output(ap, args)
    result: dict = {
        "benchmark": "issue 44: where a clean frame's time goes, "
        f"d2sr.Pipeline(repair='none'{', scene=True' if args.scene else ''}), in process",
        "frames": f"{len(frames)} clean L515 {args.view} frames in order, {args.repeats} passes",
    }
    if args.ref:
        argv = ["--data", str(args.data), "--view", args.view, "--repeats", str(args.repeats)]
        argv += ["--scene"] if args.scene else []
        result["before"] = {"commit": args.ref} | _at(args.ref, argv)
    result["this commit"] = profile(frames, args.repeats, args.scene)
    data = f"{args.data}/l515 (real L515 frames, {args.view})"
    print(write_result(result, args.json, models=used_models(None), data=data))


if __name__ == "__main__":
    main()
