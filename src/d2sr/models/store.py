"""Weights as safetensors (metadata: the model's registry name) with a model card next to them."""

from __future__ import annotations

import json
from pathlib import Path

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file
from torch import nn

from d2sr.atomic import atomic_file, atomic_write
from d2sr.contract.catalog import THRESHOLD
from d2sr.errors import InputError
from d2sr.models.onepass import OnePassUNet
from d2sr.models.registry import MODELS, build
from d2sr.models.unet import UNet
from d2sr.models.widen import can_widen, widen

__all__ = [
    "HALF_ABOVE",
    "load_model",
    "mask_logit",
    "read_card",
    "render_card",
    "save_model",
    "stored_in_half",
    "threshold",
    "torch_device",
    "warm_start",
    "write_card",
]


# Models with more parameters than this keep their weights in float16 on disk and compute in float32, so
# that every shipped file stays under 5 MB (unet32: 7.5 -> 3.8 MB). On unet32 over outside set A frames the
# rounding flips 3e-5 of the mask pixels at its threshold and moves its depth by at most 6 mm.
HALF_ABOVE = 1_000_000


def stored_in_half(model: nn.Module) -> bool:
    """Whether ``model``'s weights files (safetensors, ONNX) hold float16 (``HALF_ABOVE``)."""
    return sum(p.numel() for p in model.parameters()) > HALF_ABOVE


def save_model(
    model: nn.Module,
    name: str,
    path: Path,
    mask_logit: float | None = None,
    threshold: float | None = None,
) -> None:
    """``mask_logit``: a recovery model's calibrated mask threshold (logit; 0 when absent); ``threshold``:
    a detector's own probability threshold (``contract.THRESHOLD`` when absent; ``d2sr adapt`` sets it).
    A large model's floats are stored in float16 (``stored_in_half``); loading widens them again."""
    state = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    if stored_in_half(model):
        state = {k: v.half() if v.is_floating_point() else v for k, v in state.items()}
    meta = {"model": name, "format": "d2sr-1"}
    if mask_logit is not None:
        meta["mask_logit"] = repr(float(mask_logit))
    if threshold is not None:
        meta["threshold"] = repr(float(threshold))
    with atomic_file(path) as tmp:
        mode = tmp.stat().st_mode & 0o777  # the usual permissions; safetensors recreates the file 0600
        save_file(state, str(tmp), metadata=meta)
        tmp.chmod(mode)


def mask_logit(path: Path) -> float:
    """The mask threshold (logit) stored with a recovery model's weights; 0 (probability 0.5) if none."""
    return _number(path, "mask_logit", 0.0)


def threshold(path: Path) -> float:
    """The probability threshold stored with a detector's weights; ``contract.THRESHOLD`` if none."""
    return _number(path, "threshold", THRESHOLD)


def _number(path: Path, key: str, default: float) -> float:
    try:
        return float(_meta(Path(path)).get(key, default))
    except (SafetensorError, OSError, ValueError) as exc:
        raise InputError(f"{path}: corrupt weights ({str(exc).splitlines()[0]})") from None


def _meta(path: Path) -> dict[str, str]:
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        return f.metadata() or {}


def load_model(path: Path) -> tuple[nn.Module, str]:
    """(model in eval mode, registry name); a one-line InputError for missing or corrupt files."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such weights file")
    try:
        name = _meta(path).get("model")
        state = load_file(str(path))
    except (SafetensorError, OSError, ValueError, RuntimeError) as exc:
        raise InputError(f"{path}: corrupt weights ({str(exc).splitlines()[0]})") from None
    if not name:
        raise InputError(f"{path}: weights lack the 'model' metadata d2sr writes")
    model = build(name)
    try:
        model.load_state_dict(state)
    except RuntimeError as exc:
        raise InputError(f"{path}: weights do not fit {name} ({str(exc).splitlines()[0]})") from None
    return model.eval(), name


def warm_start(model: nn.Module, path: Path) -> dict[str, int]:
    """Start ``model`` from another model's weights (fine-tuning, or a variant that adds inputs or outputs).
    Tensors of the same name and shape are copied; where a shape grew, the old values fill the leading slice
    and the new part starts at zero (a new input channel is ignored at first, a new output reads 0).
    A narrower UNet of the same layout is widened instead (``models.widen``), and unet8-fast starts from
    unet8 (``OnePassUNet.start_from``): the model starts as the same function. Returns counts of copied,
    grown, widened and untouched tensors."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such weights file to start from")
    try:
        old = load_file(str(path))
        name = _meta(path).get("model")
    except (SafetensorError, OSError, ValueError, RuntimeError) as exc:
        raise InputError(f"{path}: corrupt weights ({str(exc).splitlines()[0]})") from None
    counts = {"copied": 0, "grown": 0, "widened": 0, "untouched": 0}
    narrow = build(name) if name in MODELS else None
    # A UNet the model is built from (unet8-fast from unet8, a wider UNet from a narrower one) starts the
    # model as the same function rather than by names and shapes.
    if isinstance(narrow, UNet) and (isinstance(model, OnePassUNet) or can_widen(narrow, model)):
        try:
            narrow.load_state_dict(old)
        except RuntimeError as exc:
            raise InputError(f"{path}: weights do not fit {name} ({str(exc).splitlines()[0]})") from None
        if isinstance(model, OnePassUNet):
            model.start_from(narrow)
            counts["copied"] = len(model.state_dict())
        elif isinstance(model, UNet):  # can_widen holds only between UNets
            widen(narrow, model)
            counts["widened"] = len(model.state_dict())
        return counts
    state = model.state_dict()
    with torch.no_grad():
        for name, t in state.items():
            src = old.get(name)
            if (
                src is None
                or src.dim() != t.dim()
                or any(a > b for a, b in zip(src.shape, t.shape, strict=True))
            ):
                counts["untouched"] += 1
                continue
            if src.shape == t.shape:
                t.copy_(src)
                counts["copied"] += 1
            else:
                t.zero_()
                t[tuple(slice(0, n) for n in src.shape)] = src
                counts["grown"] += 1
    if not counts["copied"] + counts["grown"]:
        raise InputError(f"{path}: no tensor fits this model")
    return counts


def read_card(path: Path) -> dict:
    f = Path(path).with_suffix(".card.json")
    return json.loads(f.read_text()) if f.is_file() else {}


def write_card(path: Path, **update: object) -> dict:
    """Merge ``update`` into the card (``<weights>.card.json``); render it as Markdown (``<weights>.md``)."""
    path = Path(path)
    card = read_card(path) | update
    atomic_write(path.with_suffix(".card.json"), json.dumps(card, indent=2, default=str) + "\n")
    atomic_write(path.with_suffix(".md"), render_card(card, path.stem))
    return card


def render_card(card: dict, stem: str) -> str:
    """The card as the Markdown written beside it."""
    lines = [f"# Model card: {card.get('model', stem)}", ""]
    for key, title in (
        ("summary", "What it is"),
        ("data", "Data"),
        ("command", "Command"),
        ("training", "Training"),
        ("rethreshold", "Mask threshold chosen again (d2sr threshold)"),
        ("metrics", "Metrics (frames never trained on; the calibration overlap is under Limits)"),
        ("evaluation", "Evaluation command"),
        ("outside", "From outside: real L515 frames, interference the generator does not make"),
        ("real", "Real continuous-wave ToF interference: a Kinect v2 beside two others (development)"),
        ("limits", "Limits"),
        ("sources", "Files these figures are written from (make results)"),
        ("date", "Date"),
    ):
        if key not in card:
            continue
        value = card[key]
        lines.append(f"## {title}")
        if isinstance(value, dict):
            lines += [f"- {k}: {v}" for k, v in value.items()]
        elif isinstance(value, list):
            lines += [f"- {v}" for v in value]
        elif key in ("command", "evaluation"):
            lines.append(f"```\n{value}\n```")
        else:
            lines.append(str(value))
        lines.append("")
    return "\n".join(lines)


def torch_device() -> torch.device:
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")
