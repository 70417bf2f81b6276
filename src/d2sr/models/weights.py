"""Weights as safetensors (metadata: the model's registry name) with a model card next to them."""

from __future__ import annotations

import json
from pathlib import Path

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file
from torch import nn

from d2sr.atomic import atomic_file, atomic_write
from d2sr.errors import InputError
from d2sr.models.registry import build
from d2sr.runtime.backends import WEIGHTS

__all__ = ["SHIPPED", "load_model", "read_card", "save_model", "torch_device", "write_card"]

SHIPPED = WEIGHTS  # the one shipped-weights folder (defined where the torch-free runtime can see it)


def save_model(model: nn.Module, name: str, path: Path) -> None:
    state = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    with atomic_file(path) as tmp:
        save_file(state, str(tmp), metadata={"model": name, "format": "d2sr-1"})


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


def read_card(path: Path) -> dict:
    f = Path(path).with_suffix(".card.json")
    return json.loads(f.read_text()) if f.is_file() else {}


def write_card(path: Path, **update: object) -> dict:
    """Merge ``update`` into the card (``<weights>.card.json``); render it as Markdown (``<weights>.md``)."""
    path = Path(path)
    card = read_card(path) | update
    atomic_write(path.with_suffix(".card.json"), json.dumps(card, indent=2, default=str) + "\n")
    lines = [f"# Model card: {card.get('model', path.stem)}", ""]
    for key, title in (
        ("summary", "What it is"),
        ("data", "Data"),
        ("command", "Command"),
        ("training", "Training"),
        ("metrics", "Metrics (held-out data, never trained on)"),
        ("evaluation", "Evaluation command"),
        ("limits", "Limits"),
        ("date", "Date"),
    ):
        if key not in card:
            continue
        value = card[key]
        lines.append(f"## {title}")
        if isinstance(value, dict):
            lines += [f"- {k}: {v}" for k, v in value.items()]
        elif key in ("command", "evaluation"):
            lines.append(f"```\n{value}\n```")
        else:
            lines.append(str(value))
        lines.append("")
    atomic_write(path.with_suffix(".md"), "\n".join(lines))
    return card


def torch_device() -> torch.device:
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")
