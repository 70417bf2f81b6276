"""``d2sr train``, ``d2sr threshold``, ``d2sr export`` and ``d2sr adapt``."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from d2sr.atomic import check_out
from d2sr.cli.common import Cache, Overwrite, Scale, Topic, out_dir, split_list
from d2sr.contract.catalog import RECOVERY_NAMES, WEIGHTS, check_probability
from d2sr.errors import ConfigError, InputError
from d2sr.train.config import VALIDATION_FRAMES
from d2sr.ui import console

__all__ = ["adapt", "export", "threshold", "train"]


def train(
    task: Annotated[str, typer.Argument(help="detector or recovery.", metavar="TASK")],
    out: Annotated[Path, typer.Option(help="Run folder: checkpoint.pt, <model>.safetensors and its card.")],
    config: Annotated[Path | None, typer.Option(help="TOML file of TrainSettings settings.")] = None,
    model: Annotated[str | None, typer.Option(help="Model name (overrides the config).")] = None,
    steps: Annotated[int | None, typer.Option(help="Training steps (overrides the config).")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed (overrides the config).")] = None,
    synthetic: Annotated[int | None, typer.Option(help="Generated frames (overrides the config).")] = None,
    minutes: Annotated[float | None, typer.Option(help="Stop after this many minutes (0: none).")] = None,
    leave_out: Annotated[
        str | None,
        typer.Option(help="Interference families left out of training (comma-separated; generalization)."),
    ] = None,
    overwrite: Overwrite = False,
) -> None:
    """Train the detector or a recovery UNet (resumes from OUT/checkpoint.pt; torchrun: several processes).

    Example: d2sr train recovery --config configs/unet8.toml --out runs/unet8
    """
    from d2sr.config import read_toml
    from d2sr.train.config import TrainSettings
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
    if leave_out is not None:
        values["leave_out"] = tuple(split_list(leave_out, "leave-out"))
    cfg = TrainSettings.make(**values)
    inputs = [p for f in cfg.folders for p in (f.input, f.target)]
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs, resume=True)
    command = "d2sr " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    summary = run(cfg, out, command)
    console.print(
        f"{cfg.model}: {summary['steps']} steps in {summary['minutes']} min, loss {summary['final_loss']}"
    )


def threshold(
    weights: Annotated[Path, typer.Argument(help="A recovery model's .safetensors (card beside it).")],
    out: Annotated[Path, typer.Option(help="New folder: the weights with the new threshold, card, ONNX.")],
    cache: Cache = Path("out/data"),
    validation: Annotated[
        int, typer.Option(min=2, help="Generated validation frames that choose it (training's number).")
    ] = VALIDATION_FRAMES,
    overwrite: Overwrite = False,
) -> None:
    """Choose a recovery model's mask threshold again, by the rule training uses now (lowest RMSE on
    generated validation frames with at most 1% of clean pixels changed by the repair recover writes), and
    write the same weights with it (the input is never written; copy the folder's files where you want them).

    Example: d2sr threshold src/d2sr/models/weights/unet8.safetensors --out runs/unet8-threshold
    """
    import datetime as dt

    from d2sr.models.onnx.export import export as to_onnx
    from d2sr.models.store import load_model, mask_logit, read_card, save_model, write_card
    from d2sr.train.loop import choose_mask_logit

    if not weights.is_file():
        raise InputError(f"{weights}: no such weights file")
    model, name = load_model(weights)
    if name not in RECOVERY_NAMES:
        raise InputError(f"{weights} is a {name}, not a recovery model")
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[weights.parent])  # refused before the work
    card = read_card(weights)
    # A model trained with gate_previous is chosen for on the frames it was trained for.
    gate = bool(card.get("training", {}).get("config", {}).get("gate_previous", False))
    chosen = choose_mask_logit(model, cache, count=validation, gate_previous=gate)
    was = mask_logit(weights)
    command = "d2sr " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    training = card.get("training", {}) | {"mask_threshold": chosen}
    with out_dir(out, overwrite, [weights.parent]) as tmp:
        target = tmp / weights.name
        save_model(model, name, target, mask_logit=chosen["mask_logit"])
        # The card's metrics were measured at the old threshold: dropped until `make eval-models results`.
        stale = ("metrics", "evaluation", "training", "rethreshold")
        kept = {k: v for k, v in card.items() if k not in stale}
        again = {"from": str(weights), "was": was, "command": command, "date": dt.date.today().isoformat()}
        write_card(target, **kept, training=training, rethreshold=again)
        to_onnx(target, target.with_suffix(".onnx"))
    console.print(f"{name}: mask logit {was:g} -> {chosen['mask_logit']:g} ({chosen['rule']}) -> {out}")


def export(
    out: Annotated[
        Path,
        typer.Option(help="Folder for the .onnx files (the shipped folder only when named: --overwrite)."),
    ],
    weights: Annotated[
        list[Path] | None,
        typer.Argument(help="Weights files (default: every shipped model).", metavar="WEIGHTS..."),
    ] = None,
    int8: Annotated[
        bool,
        typer.Option(
            "--int8",
            metavar="",
            help="Also write <model>.int8.onnx (static int8, onnxruntime; experimental: see "
            "docs/results/int8_real.json).",
        ),
    ] = False,
    overwrite: Overwrite = False,
) -> None:
    """Export models to ONNX (dynamic batch, height, width) after a parity check against torch.

    Example: d2sr export runs/unet8/unet8.safetensors --out out/onnx
    """
    from d2sr.models.onnx.export import export as run
    from d2sr.models.onnx.quantize import int8_path, quantize
    from d2sr.models.store import load_model
    from d2sr.models.streaming import streaming

    files = weights or sorted(WEIGHTS.glob("*.safetensors"))
    if not files:
        raise ConfigError("no weights to export")
    targets = [out / (w.stem + ".onnx") for w in files]
    for w, t in zip(files, targets, strict=True):
        written = [t, *([int8_path(t)] if int8 else [])]
        stream = streaming(load_model(w)[0])  # a streaming model's second file lies beside it
        if stream is not None:
            written += [stream.second_path(f) for f in written]
        for f in written:
            check_out(f, is_dir=False, overwrite=overwrite, inputs=files)
    for w, target in zip(files, targets, strict=True):
        r = run(w, target)
        console.print(f"{w.name} -> {target} (max |onnx - torch| = {r['max_abs_diff']:.1e})")
        if int8:
            console.print(f"  int8 -> {quantize(target)}")


def adapt(
    clean: Annotated[
        list[Path], typer.Option(help="Clean recording of your sensor and room (repeat for several).")
    ],
    out: Annotated[Path, typer.Option(help="Model folder to write (use it with --models).")],
    depth_scale: Scale = None,
    minutes: Annotated[
        float,
        typer.Option(
            help="Time budget in minutes on 2 cores, planned up front as copies and steps (the same command "
            "gives the same model; a slower or busier machine takes longer, never trains less)."
        ),
    ] = 8.0,
    false_alarm: Annotated[
        float, typer.Option(help="Target share of clean held-out frames flagged (sets the threshold).")
    ] = 0.01,
    labelled: Annotated[
        list[Path] | None,
        typer.Option(help="Folders written by d2sr label (real interference with its masks; repeatable)."),
    ] = None,
    topic: Topic = None,
    models: Annotated[
        Path, typer.Option(help="Folder of the models to start from (default: shipped).")
    ] = WEIGHTS,
    overwrite: Overwrite = False,
) -> None:
    """Fit the default recovery model to your sensor and room from a clean recording (self-supervised: the
    interference generator corrupts your frames); its mask becomes the detector. Resumes a run in OUT.

    Example: d2sr adapt --clean my_room/ --depth-scale 1000 --out models/my_room
    """
    from d2sr.frames.checks import checked_counts, open_input
    from d2sr.train.adapt import AdaptSettings, adapt_recordings

    if not minutes > 0:
        raise ConfigError(f"--minutes must be > 0, got {minutes}")
    check_probability(false_alarm, "--false-alarm")
    inputs = [*clean, *(labelled or []), models]
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs, resume=True)
    recordings, scale = [], None
    for path in clean:
        reader, s = open_input(path, topic, depth_scale if scale is None else scale, "clean", 1000.0)
        scale = s
        recordings.append([f.depth for f in checked_counts(reader, s, "clean frame")])
    assert scale is not None
    command = "d2sr " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    settings = AdaptSettings(minutes=minutes, false_alarm=false_alarm, labelled=labelled or [], models=models)
    adapt_recordings(recordings, scale, out, settings, command, console.print)
