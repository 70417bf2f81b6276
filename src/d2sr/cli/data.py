"""CLI commands for data: ``simulate``, ``label``, ``calibrate`` and ``gallery``."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from d2sr.atomic import atomic_dir, check_out
from d2sr.cli.common import Overwrite, Topic, renamed, resolution_of
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Reader, positive_finite
from d2sr.frames.checks import checked_counts, open_input
from d2sr.provenance import stamp
from d2sr.ui import NA, console, progress_bar

__all__ = ["calibrate", "label", "simulate"]


def simulate(
    out: Annotated[Path, typer.Option(help="Output folder (written atomically).")],
    sensors: Annotated[int, typer.Option(help="Sensors in the room.")] = 3,
    seconds: Annotated[float, typer.Option(help="Simulated seconds.")] = 10.0,
    active_frames: Annotated[
        int, typer.Option(help="Frames each sensor captures per 1 s period (of 30 slots).")
    ] = 15,
    fps: Annotated[int | None, typer.Option(hidden=True, help="Deprecated: --active-frames.")] = None,
    controller: Annotated[
        str, typer.Option(help="De-synchronization controller of every sensor.")
    ] = "static",
    moving: Annotated[
        bool, typer.Option("--moving", metavar="", help="The last sensor rides a robot through the room.")
    ] = False,
    moving_robot: Annotated[
        bool | None, typer.Option("--moving-robot", hidden=True, help="Deprecated: --moving.")
    ] = None,
    people: Annotated[
        int | None, typer.Option(help="People walking in the room (default: 0-2, random).")
    ] = None,
    resolution: Annotated[str, typer.Option(help="Image size, e.g. 640x480 or 320x240.")] = "640x480",
    fmt: Annotated[
        str, typer.Option("--format", help="png, or ros2 (depth as a ROS 2 bag, millimetres).")
    ] = "png",
    seed: Annotated[int, typer.Option(help="Random seed (room, poses, noise, interference).")] = 0,
    workers: Annotated[int, typer.Option(help="Worker processes (0: one per core, at most 2).")] = 0,
    overwrite: Overwrite = False,
) -> None:
    """Write recordings of a simulated multi-sensor room: per sensor depth/, clean/ and masks/ PNG folders
    with meta.json (timestamps, interfered frames), and scene.json.

    Example: d2sr simulate --sensors 3 --seconds 10 --active-frames 15 --out out/room
    """
    from d2sr.desync import CONTROLLERS
    from d2sr.sim.record import RecordSettings, record, to_ros2
    from d2sr.sim.rooms import L515
    from d2sr.sim.world import make_rig

    if controller not in CONTROLLERS:
        raise ConfigError(f"unknown controller {controller!r}; choose from {', '.join(CONTROLLERS)}")
    if fmt not in ("png", "ros2"):
        raise ConfigError(f"--format must be png or ros2, got {fmt!r}")
    fps = renamed("--fps", "--active-frames", fps, active_frames)
    moving = renamed("--moving-robot", "--moving", moving_robot, moving)
    if sensors < 1 or sensors > 63 or seconds <= 0 or not 1 <= fps <= 30 or workers < 0:
        raise ConfigError("need 1 <= sensors <= 63, seconds > 0, 1 <= --active-frames <= 30 and workers >= 0")
    w, h = resolution_of(resolution)
    check_out(out, is_dir=True, overwrite=overwrite)
    from d2sr.sim.rooms import L515_INTRINSICS

    settings = RecordSettings(
        seconds=seconds, active_frames=fps, controller=controller, seed=seed, workers=workers or None
    )
    rig = make_rig(seed, sensors, moving, people, L515_INTRINSICS.scaled(w, h))
    model = L515.model_copy(update={"depth_scale": 1000.0}) if fmt == "ros2" else L515
    with progress_bar() as bar:
        task = bar.add_task(f"{sensors} sensors x {seconds:g} s at {fps} fps", total=None)

        def tick(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        summary = record(
            rig, out, settings, model, progress=tick,
            finish=(lambda tmp: to_ros2(tmp, sensors)) if fmt == "ros2" else None,
        )  # fmt: skip
    n, bad = summary["frames"], summary["interfered_frames"]
    console.print(f"Wrote {n} frames ({bad} interfered) of {sensors} sensors to {out}")


def _counts(reader: Reader, what: str, scale: float) -> Iterator[np.ndarray]:
    return (f.depth for f in checked_counts(reader, scale, f"{what} frame"))


def label(
    clean: Annotated[Path, typer.Option(help="Clean static sequence (PNG folder or any recording).")],
    interfered: Annotated[Path, typer.Option(help="Interfered frames of the same view.")],
    out: Annotated[Path, typer.Option(help="Output folder: masks/ and depth/ (written atomically).")],
    depth_scale: Annotated[
        float | None, typer.Option(help="Units per metre (default: what the recording says).")
    ] = None,
    statistic: Annotated[
        str,
        typer.Option(
            help="The error threshold: mu, mu+sigma or mu+2sigma of the clean sequence (the paper's). "
            "--threshold is a detector score on every other command."
        ),
    ] = "mu+sigma",
    method: Annotated[str, typer.Option(help="stats (ours, default) or paper (Section V-C.1).")] = "stats",
    topic: Topic = None,
    memory_mb: Annotated[float, typer.Option(help="Memory for the clean sequence's statistics.")] = 64.0,
    overwrite: Overwrite = False,
) -> None:
    """Ground truth from recordings: interference masks and depth for each interfered frame.

    Example: d2sr label --clean clean/ --interfered interfered/ --depth-scale 4000 --out labels/
    """
    from d2sr.frames.layout import LABELS, FrameFolder
    from d2sr.scene import Labeller, clean_stats, label_frames

    if not positive_finite(memory_mb):
        raise ConfigError(f"--memory-mb must be a positive number, got {memory_mb}")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[clean, interfered])
    creader, scale = open_input(clean, topic, depth_scale, "clean")
    ireader, _ = open_input(interfered, topic, scale, "interfered")
    cshape, ishape = creader.shape, ireader.shape
    if cshape and ishape and cshape != ishape:
        raise InputError(
            f"clean frames are {cshape[1]}x{cshape[0]} but interfered frames are {ishape[1]}x{ishape[0]}"
        )
    with progress_bar() as bar:
        task = bar.add_task("clean statistics", total=1.0)
        stats = clean_stats(
            lambda: _counts(creader, "clean", scale),
            scale,
            memory_mb,
            lambda f: bar.update(task, completed=f),
            count=len(creader),
        )
        lab = Labeller(stats, method, statistic)

        def refs() -> Iterator[np.ndarray]:
            while True:
                yield from _counts(creader, "clean", scale)

        frames = ((f.name, f.depth) for f in checked_counts(ireader, scale, "interfered frame"))
        rows = []
        task2 = bar.add_task("labelling", total=len(ireader))
        with atomic_dir(out) as tmp:
            folder = FrameFolder(tmp, LABELS)
            references = refs() if method == "paper" else None
            kept: dict[str, np.ndarray] = {}

            def keeping() -> Iterator[tuple[str, np.ndarray]]:
                for name, depth in frames:
                    kept[name] = depth
                    yield name, depth

            for name, mask, gt in label_frames(lab, keeping(), scale, references):
                folder.write(name, masks=mask, depth=gt, interfered=kept.pop(name))
                rows.append({"name": name, "mask_share": round(float((mask > 0).mean()), 5)})
                bar.advance(task2)
            folder.finish(scale, ireader.intrinsics, rows)
            info = {
                "method": method,
                "statistic": statistic,
                "depth_scale": scale,
                "clean_frames": stats.frames,
                "clean": str(clean),
                "interfered": str(interfered),
                "frames": rows,
            }
            (tmp / "label.json").write_text(json.dumps(info, indent=1) + "\n")
    share = np.mean([r["mask_share"] for r in rows]) if rows else 0.0
    console.print(
        f"Labelled {len(rows)} frames ({method}, {statistic}): mean mask share {share:.1%}; wrote {out}"
    )


def calibrate(
    real: Annotated[
        list[Path], typer.Option(help="Clean static recordings of the real sensor (repeatable).")
    ],
    out: Annotated[Path, typer.Option(help="Folder for calibration.json and calibration.png.")],
    depth_scale: Annotated[
        float | None, typer.Option(help="Units per metre (default: what the recording says).")
    ] = None,
    skip: Annotated[int, typer.Option(help="Frames to skip at the start of each recording.")] = 45,
    rooms: Annotated[int, typer.Option(help="Simulated rooms per evaluation.")] = 8,
    frames: Annotated[int, typer.Option(help="Frames per simulated room.")] = 24,
    overwrite: Overwrite = False,
) -> None:
    """Fit the sensor model to real captures; plot real vs simulated statistics (bar: within 20%).

    Example: d2sr calibrate --real captures/dev0 --real captures/dev1 --out out/calibration
    """
    from d2sr.eval.plots import calibration as plot
    from d2sr.eval.plots import save
    from d2sr.sim.calibrate import STATS, combine, sequence_stats, simulated_stats, verdict
    from d2sr.sim.calibrate import calibrate as fit

    check_out(out, is_dir=True, overwrite=overwrite, inputs=real)
    real_stats = {}
    for path in real:
        reader, scale = open_input(path, None, depth_scale, "clean")
        real_stats[path.name] = sequence_stats(
            (d for i, d in enumerate(_counts(reader, "clean", scale)) if i >= skip), scale
        )
    target = combine(list(real_stats.values()))
    with progress_bar() as bar:
        task = bar.add_task("fitting the sensor model", total=1.0)
        model = fit(target, rooms=rooms, frames=frames, progress=lambda f: bar.update(task, completed=f))
    sim = simulated_stats(model, rooms, frames, seed=100)  # rooms not used by the fit
    checks = verdict(target, sim)
    ratios = checks["noise"]["ratios"]
    result = stamp(
        {
            "real": {k: v.to_dict() for k, v in real_stats.items()},
            "target": target.to_dict(),
            "simulated": sim.to_dict(),
            "model": model.model_dump(),
            "checks": checks,
        }
    )
    with atomic_dir(out) as tmp:
        (tmp / "calibration.json").write_text(json.dumps(result, indent=1) + "\n")
        save(plot(real_stats, sim), tmp / "calibration.png")
    t = Table("statistic", "real", "simulated", "ratio", "within 20%")
    for key in STATS:
        c = checks[key]
        t.add_row(
            key, f"{c['real']:.3f}", f"{c['sim']:.3f}", f"{c['ratio']:.2f}", "yes" if c["pass"] else "NO"
        )
    t.add_row(
        "noise vs range",
        NA,
        NA,
        ", ".join(f"{r:.2f}" for r in ratios),
        "yes" if checks["noise"]["pass"] else "NO",
    )
    console.print(t)
    console.print(
        "Fitted: " + ", ".join(f"{k}={v:.4g}" for k, v in model.model_dump().items() if isinstance(v, float))
    )
