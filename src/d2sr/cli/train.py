"""``d2sr train`` and ``d2sr export``."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from d2sr.atomic import check_out
from d2sr.cli.common import Overwrite
from d2sr.contract import WEIGHTS
from d2sr.errors import ConfigError
from d2sr.ui import console

__all__ = ["export", "train"]


def train(
    task: Annotated[str, typer.Argument(help="detector or recovery.", metavar="TASK")],
    out: Annotated[Path, typer.Option(help="Run folder: checkpoint.pt, <model>.safetensors and its card.")],
    config: Annotated[Path | None, typer.Option(help="TOML file of TrainConfig settings.")] = None,
    model: Annotated[str | None, typer.Option(help="Model name (overrides the config).")] = None,
    steps: Annotated[int | None, typer.Option(help="Training steps (overrides the config).")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed (overrides the config).")] = None,
    synthetic: Annotated[int | None, typer.Option(help="Generated frames (overrides the config).")] = None,
    minutes: Annotated[float | None, typer.Option(help="Stop after this many minutes (0: none).")] = None,
    overwrite: Overwrite = False,
) -> None:
    """Train the detector or a recovery UNet (resumes from OUT/checkpoint.pt; torchrun: several processes).

    Example: d2sr train recovery --config configs/unet8.toml --out runs/unet8
    """
    from d2sr.config import read_toml
    from d2sr.train.config import TrainConfig
    from d2sr.train.loop import train as run

    if task not in ("detector", "recovery"):
        raise ConfigError(f"task must be detector or recovery, got {task!r}")
    values: dict = {} if config is None else read_toml(config)
    values["task"] = task
    values.setdefault("model", "detector" if task == "detector" else "unet8")
    for key, v in (
        ("model", model),
        ("steps", steps),
        ("seed", seed),
        ("synthetic", synthetic),
        ("time_limit_min", minutes),
    ):
        if v is not None:
            values[key] = v
    cfg = TrainConfig.make(**values)
    inputs = [p for f in cfg.folders for p in (f.input, f.target)]
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs, resume=True)
    command = "d2sr " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    summary = run(cfg, out, command)
    console.print(
        f"{cfg.model}: {summary['steps']} steps in {summary['minutes']} min, loss {summary['final_loss']}"
    )


def export(
    weights: Annotated[
        list[Path] | None,
        typer.Argument(help="Weights files (default: every shipped model).", metavar="WEIGHTS..."),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Folder for the .onnx files (default: next to each weights file you name; out/onnx "
            "for the shipped models)."
        ),
    ] = None,
    int8: Annotated[
        bool,
        typer.Option("--int8", metavar="", help="Also write <model>.int8.onnx (static int8, onnxruntime)."),
    ] = False,
    overwrite: Overwrite = False,
) -> None:
    """Export models to ONNX (dynamic batch, height, width) after a parity check against torch.

    Example: d2sr export runs/unet8/unet8.safetensors --out out/onnx
    """
    from d2sr.export import export as run
    from d2sr.quantize import quantize

    files = weights or sorted(WEIGHTS.glob("*.safetensors"))
    if not files:
        raise ConfigError("no weights to export")
    if out is None and not weights:
        out = Path("out/onnx")  # the shipped folder changes only when asked: --out src/d2sr/models/weights
    targets = [(out or w.parent) / (w.stem + ".onnx") for w in files]
    for t in targets:
        check_out(t, is_dir=False, overwrite=overwrite, inputs=files)
        if int8:
            check_out(t.with_suffix(".int8.onnx"), is_dir=False, overwrite=overwrite)
    for w, target in zip(files, targets, strict=True):
        r = run(w, target)
        console.print(f"{w.name} -> {target} (max |onnx - torch| = {r['max_abs_diff']:.1e})")
        if int8:
            console.print(f"  int8 -> {quantize(target)}")
