"""Every model of ``d2sr.contract.CATALOG`` by name, built in torch, with the input sizes it accepts."""

from __future__ import annotations

from collections.abc import Callable

from torch import nn

from d2sr.contract.catalog import CATALOG, DEFAULT_RECOVERY, FAST_RECOVERY, MASK_DETECTOR, check_size
from d2sr.errors import InputError
from d2sr.models.detector import FastDetector, MaskDetector, PaperDetector
from d2sr.models.onepass import OnePassUNet
from d2sr.models.unet import UNet

__all__ = ["MODELS", "build", "check_input_size", "describe", "own_passes"]

MODELS: dict[str, Callable[[], nn.Module]] = {
    "detector": FastDetector,
    "detector-temporal": lambda: FastDetector(frames=2),
    "paper-detector": PaperDetector,
    # Ours: space-to-depth stem and a depth head that corrects a fill (see unet.py). The paper's layout is
    # kept as the paper-* reference variants.
    "unet8": lambda: UNet(8, s2d=4, fill=True),
    "unet16": lambda: UNet(16, s2d=4, fill=True),
    "unet32": lambda: UNet(32, s2d=4, fill=True),
    "unet8-temporal": lambda: UNet(8, s2d=4, fill=True, frames=2),
    FAST_RECOVERY: OnePassUNet,
    # Ablation, and the start of unet8's training: the same trunk with an absolute-depth head.
    "unet8-direct": lambda: UNet(8, s2d=4),
    "paper-unet8": lambda: UNet(8, s2d=1),
    "paper-unet16": lambda: UNet(16, s2d=1),
    "paper-unet32": lambda: UNet(32, s2d=1),
    # d2sr adapt's detector: its fine-tuned unet8's mask, thresholded (the cut is in the weights).
    MASK_DETECTOR: lambda: MaskDetector(build(DEFAULT_RECOVERY)),
}


if set(MODELS) != set(CATALOG):  # one catalogue: a name added in one place and not the other is a bug
    raise RuntimeError(f"models.registry and contract.CATALOG disagree: {sorted(set(MODELS) ^ set(CATALOG))}")


def build(name: str) -> nn.Module:
    if name not in MODELS:
        raise InputError(f"unknown model {name!r}; choose from {', '.join(MODELS)}")
    return MODELS[name]()


def check_input_size(model: nn.Module, height: int, width: int) -> None:
    """Raise a one-line InputError when the model cannot take frames of this size."""
    stride = int(getattr(model, "stride", 1))
    check_size(height, width, stride, getattr(model, "height", None), type(model).__name__)


def own_passes(model: nn.Module) -> int:
    """How many times ``recover`` runs this recovery model on a frame unless told (``Entry.passes``)."""
    return int(getattr(model, "passes", CATALOG[DEFAULT_RECOVERY].passes))


def describe(model: nn.Module) -> str:
    n = sum(p.numel() for p in model.parameters())
    return f"{type(model).__name__}, {n / 1000:.1f}k parameters"
