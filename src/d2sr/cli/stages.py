"""``d2sr detect`` and ``d2sr recover``: the learned stages on a recording (any reader's input)."""

from __future__ import annotations

import csv
import io
import os
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import nullcontext
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from d2sr.atomic import atomic_dir, atomic_write, check_out
from d2sr.cli.common import (
    BackendOpt,
    Input,
    MaskLogit,
    MaxRange,
    ModelDir,
    Overwrite,
    Passes,
    RerunOpt,
    Scale,
    Threshold,
    Topic,
    checked_counts,
    checked_frames,
    open_input,
    prefetch,
)
from d2sr.contract import (
    DETECTOR,
    MODEL_HELP,
    RECOVER_MODEL,
    REPAIR_MODELS,
    REPAIR_PASSES,
    WEIGHTS,
    check_probability,
)
from d2sr.desync import TOTAL_FRAMES
from d2sr.errors import InputError
from d2sr.frames.base import PLAUSIBLE_M, Frame
from d2sr.frames.layout import REPAIRED, FrameFolder
from d2sr.runtime.memory import reuse_freed_memory
from d2sr.ui import progress_bar

__all__ = ["detect", "recover"]


def detect(
    input: Input,
    out: Annotated[Path, typer.Option(help="CSV file: frame,score,interfered.")],
    depth_scale: Scale = None,
    threshold: Threshold = None,
    topic: Topic = None,
    backend: BackendOpt = "auto",
    weights: ModelDir = WEIGHTS,
    max_range: MaxRange = PLAUSIBLE_M[1],
    overwrite: Overwrite = False,
) -> None:
    """Stage 1: score every frame (probability that it is interfered).

    Example: d2sr detect recording/ --depth-scale 4000 --out flags.csv
    """
    from d2sr.contract import padded
    from d2sr.inference import open_backend

    if threshold is not None:
        check_probability(threshold, "--threshold")
    check_out(out, is_dir=False, overwrite=overwrite, inputs=[input])
    reuse_freed_memory()
    net = open_backend(None, backend, weights)
    cut = threshold if threshold is not None else net.threshold
    reader, scale = open_input(input, topic, depth_scale, "input", 1000.0, max_range)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["frame", "score", "interfered"])
    flagged = 0
    with progress_bar() as bar:
        task = bar.add_task(f"detecting ({net.name})", total=len(reader))
        last: tuple[tuple[int, ...], np.ndarray] | None = None  # the previous frame, for a temporal detector
        for f, metres in prefetch(checked_frames(reader, scale)):
            x = padded(metres[None])
            s = float(net.scores(x, last[1] if last is not None and last[0] == metres.shape else None)[0])
            last = (metres.shape, x)
            flagged += s >= cut
            w.writerow([f.name, f"{s:.6f}", int(s >= cut)])
            bar.advance(task)
    atomic_write(out, buf.getvalue())
    typer.echo(f"{flagged} of {len(reader)} frames interfered -> {out}")


def recover(
    input: Input,
    out: Annotated[Path, typer.Option(help="Output folder: <name>.png repaired, masks/<name>.png.")],
    depth_scale: Scale = None,
    every: Annotated[
        bool, typer.Option("--all", metavar="", help="Repair every frame, not only those the detector flags.")
    ] = False,
    model: Annotated[str, typer.Option(help=MODEL_HELP)] = RECOVER_MODEL,
    threshold: Threshold = None,
    mask_logit: MaskLogit = None,
    passes: Passes = REPAIR_PASSES,
    topic: Topic = None,
    backend: BackendOpt = "auto",
    weights: ModelDir = WEIGHTS,
    max_range: MaxRange = PLAUSIBLE_M[1],
    rerun: RerunOpt = None,
    overwrite: Overwrite = False,
) -> None:
    """Stage 3: repair interfered frames (predicted depth inside the predicted mask, the input outside).
    Frames in time order: a temporal model (unet8-temporal) also sees the last frame the detector passed;
    --model auto (the default) takes it for the frames that line up with that frame (a sensor that held
    still) and unet8 for the others. With --all and a temporal model the detector runs only where it can
    change that frame.

    Example: d2sr recover recording/ --depth-scale 4000 --out repaired/
    """
    from d2sr.desync import make_controller
    from d2sr.inference import open_backend
    from d2sr.runtime.loop import Capture, Result, SensorLoop
    from d2sr.runtime.viewer import LIVE, RerunLog

    if model not in REPAIR_MODELS:
        raise InputError(f"--model: unknown {model!r}; choose from {', '.join(REPAIR_MODELS)}")
    if threshold is not None:
        check_probability(threshold, "--threshold")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[input])
    if rerun is not None and rerun != LIVE:
        check_out(Path(rerun), is_dir=False, overwrite=overwrite, inputs=[input, out], option="--rerun")
    # --all asks no detector (its verdict would go unused) unless a view shows it or a temporal model
    # needs to know which frames were clean.
    detect = not every or rerun is not None
    # Frames are decided in order (the detector weighs the frame before; a temporal model gets the last clean
    # one) and then repaired several at a time, each on fewer of onnxruntime's threads: the guard and
    # write-back run on one core, and the model scales poorly over two (worst case on 2 cores: 1.4-1.5x the
    # frames a second, the same output).
    cores = os.cpu_count() or 1
    workers = min(cores, 4)
    threads = cores // workers if workers > 1 else None  # None: the backend's own choice
    reuse_freed_memory()
    net = open_backend(
        model, backend, weights, DETECTOR if detect else None, threads, mask_logit=mask_logit, passes=passes
    )
    if not detect and net.frames > 1:
        detect = True
        net = open_backend(model, backend, weights, DETECTOR, threads, mask_logit=mask_logit, passes=passes)
    if net.name != "onnxruntime":  # torch has threads of its own
        workers = 1
    reader, scale = open_input(input, topic, depth_scale, "input", 1000.0, max_range)
    # The runtime's loop, open loop with a controller that never moves: one way to detect and repair.
    loop = SensorLoop(
        net,
        make_controller("static", TOTAL_FRAMES, TOTAL_FRAMES),
        threshold=threshold,
        repair="all" if every else "flagged",
        detect=detect,
        # Repairing every frame, a temporal model's detector only picks the last clean frame (unless a view
        # shows its scores): it runs where that can change.
        judge_every=not every or net.frames == 1 or rerun is not None,
    )
    rows: list[dict[str, Any]] = []
    repaired = 0
    log = RerunLog(rerun, 1, f"d2sr recover {input}") if rerun else nullcontext()
    with (
        log as view,
        atomic_dir(out) as tmp,
        ThreadPoolExecutor(1) as writer,
        ThreadPoolExecutor(workers) as pool,
        progress_bar() as bar,
    ):
        folder = FrameFolder(tmp, REPAIRED)
        task = bar.add_task(f"recovering ({net.name}, {model})", total=len(reader))
        pending: deque[Future[None]] = deque()
        frames = prefetch(checked_counts(reader, scale, "frame"))
        running: deque[tuple[Frame, Future[Result]]] = deque()

        def done(f: Frame, res: Result) -> None:
            nonlocal repaired
            if view is not None:
                view.write(0, res)
            fix = every or res.flagged
            repaired += fix
            pending.append(writer.submit(folder.write, f.name, depth=res.depth, masks=res.mask))
            while len(pending) > 4:  # bounded: a slow disk must not pile frames up in memory
                pending.popleft().result()
            rows.append({"name": f.name, "timestamp_ns": f.timestamp_ns, "repaired": bool(fix)})
            bar.advance(task)

        # The next frame is decided (the detector runs) while the workers repair earlier ones; at most
        # 2 x workers frames wait, written in input order.
        for f in frames:
            running.append((f, pool.submit(loop.finish, loop.decide(Capture(f, scale)))))
            if len(running) >= 2 * workers:
                g, job = running.popleft()
                done(g, job.result())
        while running:
            g, job = running.popleft()
            done(g, job.result())
        for p in pending:
            p.result()
        folder.finish(scale, reader.intrinsics, rows)
    typer.echo(f"repaired {repaired} of {len(rows)} frames -> {out}")
