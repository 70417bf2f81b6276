"""``d2sr bench``: speed and memory benchmarks (their scripts under bench/ write the committed results)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from d2sr.atomic import check_out
from d2sr.cli.common import Overwrite, split_list
from d2sr.errors import ConfigError
from d2sr.ui import console, progress_bar

__all__ = ["bench"]

WHAT = ("timing", "simulate", "models", "pipeline", "typical", "worst")
FRAMES = 60  # frames of --frames the typical and worst cases run on


def bench(
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results to this JSON file.")] = None,
    what: Annotated[
        str, typer.Option(help=f"Benchmarks to run: {', '.join(WHAT)} (comma-separated).")
    ] = "models",
    sensors: Annotated[int, typer.Option(help="Sensors in the timing-world benchmark.")] = 1000,
    seconds: Annotated[float, typer.Option(help="Simulated seconds of the timing-world benchmark.")] = 600.0,
    repeats: Annotated[int, typer.Option(help="Repeats (median reported).")] = 3,
    frames: Annotated[
        Path | None,
        typer.Option(
            help=f"A recording (its first {FRAMES} frames): a sensor's clean frames for typical, interfered "
            "ones for worst."
        ),
    ] = None,
    depth_scale: Annotated[
        float | None, typer.Option(help="Units per metre of --frames [what the recording says].")
    ] = None,
    no_scene: Annotated[
        bool,
        typer.Option(
            "--no-scene", help="typical: the detector alone, without the sensor's scene (scene=False)."
        ),
    ] = False,
    overwrite: Overwrite = False,
) -> None:
    """Benchmarks: detector and recovery speed (torch, onnxruntime, from outside the process); the whole
    runtime pipeline at 640x480 and 320x240; the timing world at warehouse scale; writing simulated
    640x480 recordings. On a recording (--frames): typical, the CPU time a clean frame costs through
    d2sr.Pipeline; worst, d2sr recover repairing every frame, from outside, beside the PNG read+write floor.

    Example: d2sr bench --what models,pipeline --json out/bench.json
    """
    from d2sr.atomic import write_result
    from d2sr.eval.speed import (
        bench_models,
        bench_pipeline,
        bench_simulate,
        bench_timing,
        bench_typical,
        bench_worst,
    )

    names = split_list(what, "what", WHAT)
    if sensors < 1 or seconds <= 0 or repeats < 1:
        raise ConfigError("need sensors >= 1, seconds > 0 and repeats >= 1")
    on_frames = [n for n in names if n in ("typical", "worst")]
    if on_frames and frames is None:
        raise ConfigError(f"--what {on_frames[0]} runs on a recording: pass --frames")
    if no_scene and "typical" not in names:
        raise ConfigError("--no-scene is for --what typical")
    if json_out is not None:
        check_out(json_out, is_dir=False, overwrite=overwrite, name="json")
    depth: list = []
    scale = 0.0
    if on_frames and frames is not None:
        from d2sr.frames.checks import open_input

        reader, scale = open_input(frames, None, depth_scale, "benchmark")
        depth = [f.depth for f, _ in zip(reader, range(FRAMES), strict=False)]
        if len(depth) <= 10:
            raise ConfigError(f"{frames}: the benchmarks on a recording need more than 10 frames")
    results = {}
    with progress_bar() as bar:
        if "timing" in names:
            task = bar.add_task(f"{sensors} sensors x {seconds:g} s, {repeats} runs", total=1.0)
            results["timing"] = bench_timing(
                sensors, seconds, repeats, progress=lambda f: bar.update(task, completed=f)
            )
        if "simulate" in names:
            task = bar.add_task(f"simulate 1000 frames, {repeats} runs", total=None)
            results["simulate"] = bench_simulate(1000, repeats)
            bar.update(task, total=1, completed=1)
        if "models" in names:
            task = bar.add_task("models", total=None)
            results["models"] = bench_models(
                repeats=max(repeats, 10) * 3, progress=lambda s: bar.update(task, description=s)
            )
            bar.update(task, total=1, completed=1)
        if "pipeline" in names:
            task = bar.add_task("pipeline", total=None)
            results["pipeline"] = bench_pipeline(
                repeats=repeats, progress=lambda s: bar.update(task, description=s)
            )
            bar.update(task, total=1, completed=1)
        if "typical" in names:
            task = bar.add_task("typical case: clean frames through d2sr.Pipeline", total=None)
            options = {"scene": False} if no_scene else {}
            results["typical"] = bench_typical(depth, scale, repeats, **options)
            bar.update(task, total=1, completed=1)
        if "worst" in names:
            task = bar.add_task("worst case and the PNG floor, from outside", total=None)
            results["worst"] = bench_worst(depth, scale, repeats)
            bar.update(task, total=1, completed=1)
    result = results[names[0]] if len(names) == 1 else {"benchmarks": results}
    console.print_json(write_result(result, json_out))
