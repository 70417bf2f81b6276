"""The model catalogue: what the learned stages, their weights and every inference backend agree on.
Torch-free, so that ``models/`` (torch), ``runtime/`` (onnxruntime on the edge) and the CLI share one
source for each fact.

- Names: ``CATALOG`` (detectors and recovery models, which ship), the defaults, the files a model is made of.
- Depth units: models take float32 metres, shape (N, frames, H, W), 0 = no return; they normalise inside.
- Sizes: height and width divisible by the model's stride (``check_size``); ``padded`` adds a no-return
  border up to ``PAD`` so any sensor size works, and results are cropped back.
- Thresholds: the detector's is a probability (``THRESHOLD``); a recovery model's mask threshold is a
  logit (``mask_logit``, stored with its weights). Signatures say which.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.version import WEIGHTS

__all__ = [
    "ALONE",
    "AUTO_RECOVERY",
    "AUTO_TEMPORAL_LOGIT",
    "CATALOG",
    "DEFAULT_MODEL",
    "DEFAULT_RECOVERY",
    "DETECTOR",
    "DETECTOR_NAMES",
    "FAST_RECOVERY",
    "MASK_DETECTOR",
    "MODEL_HELP",
    "PAD",
    "PAIR_INPUTS",
    "RECOVERY_NAMES",
    "REPAIR_MODELS",
    "SHIPPED_RECOVERY",
    "STREAM_CODES",
    "STREAM_INPUTS",
    "TEMPORAL_RECOVERY",
    "THRESHOLD",
    "WEIGHTS",
    "Entry",
    "check_probability",
    "check_size",
    "code_path",
    "detector_input",
    "gate",
    "model_files",
    "model_input",
    "padded",
    "pair_path",
    "scale_at",
]

DETECTOR = "detector"
FAST_RECOVERY = "unet8-fast"  # d2sr.models.onepass: unet8 at half resolution, one pass
MASK_DETECTOR = "mask-detector"  # d2sr adapt's detector: a recovery model's mask (not trained on its own)


@dataclass(frozen=True)
class Entry:
    """A model name in the catalogue: its ``kind`` (detector or recovery), whether its weights ship
    with d2sr, what it is, and (recovery) how many times ``recover`` runs it on a frame unless told
    (``d2sr.contract.recover_passes``)."""

    kind: str
    shipped: bool
    about: str
    passes: int = 2


# The one catalogue of model names. models.registry builds exactly these (a test holds them equal); the
# tuples below are views of it. Ours first; unet8-direct is the ablation unet8 starts from; paper-* are
# the paper's layouts.
CATALOG: dict[str, Entry] = {
    "detector": Entry("detector", True, "ours; the shipped file is the two-frame (temporal) architecture"),
    "detector-temporal": Entry("detector", False, "ours, also weighs the sensor's previous frame"),
    "paper-detector": Entry("detector", True, "the paper's detector"),
    MASK_DETECTOR: Entry("detector", False, "d2sr adapt's: its unet8's mask, thresholded"),
    "unet8": Entry("recovery", True, "ours, 8 channels (the single-frame default)"),
    "unet16": Entry("recovery", True, "ours, 16 channels"),
    "unet32": Entry("recovery", True, "ours, 32 channels"),
    "unet8-temporal": Entry("recovery", True, "ours, also sees the last clean frame"),
    FAST_RECOVERY: Entry("recovery", True, "ours, one pass at the camera's rate; repairs less", passes=1),
    "unet8-direct": Entry("recovery", False, "ablation: an absolute-depth head"),
    "paper-unet8": Entry("recovery", False, "the paper's layout"),
    "paper-unet16": Entry("recovery", False, "the paper's layout"),
    "paper-unet32": Entry("recovery", False, "the paper's layout"),
}
DETECTOR_NAMES = tuple(n for n, e in CATALOG.items() if e.kind == "detector" and n != MASK_DETECTOR)
RECOVERY_NAMES = tuple(n for n, e in CATALOG.items() if e.kind == "recovery")
DEFAULT_RECOVERY = "unet8"
SHIPPED_RECOVERY = tuple(n for n in RECOVERY_NAMES if CATALOG[n].shipped)
THRESHOLD = 0.5  # detector probability at or above which a frame counts as interfered
PAD = 32  # the largest stride of the shipped models
# ``--model auto``: the temporal model only where the sensor's last clean frame lines up with the frame
# (``repair.agreement``); where the robot moved, the temporal model alone lost 9.1 points of RMSE to unet8.
AUTO_RECOVERY = "auto"
TEMPORAL_RECOVERY = "unet8-temporal"
# auto's own operating point for the temporal model (unet8 keeps its own), chosen on one development set
# and held on two others (lab/notes/decisions.md).
AUTO_TEMPORAL_LOGIT = -1.5
REPAIR_MODELS = (AUTO_RECOVERY, *RECOVERY_NAMES)  # what recover and run take: a model, or auto's pair
# What every caller repairs with unless told: d2sr.repair, d2sr.Pipeline, recover, run and the demo (one
# name, one repair). DEFAULT_RECOVERY stays the single-frame model auto falls back on.
DEFAULT_MODEL = AUTO_RECOVERY
MODEL_HELP = (
    f"Recovery model: {AUTO_RECOVERY} or one of the shipped {', '.join(SHIPPED_RECOVERY)} ({AUTO_RECOVERY}: "
    f"{TEMPORAL_RECOVERY} where the last clean frame lines up with the frame, {DEFAULT_RECOVERY} elsewhere); "
    f"{', '.join(n for n in RECOVERY_NAMES if n not in SHIPPED_RECOVERY)} from a --models folder that holds "
    "them (make weights trains them)."
)
# The inputs of two-frame models in their streaming form (``d2sr.models.streaming``), by kind, and the
# outputs of a temporal UNet's encoder: a file with other inputs came from an earlier d2sr.
STREAM_INPUTS = {"detector": ("depth",), "recovery": ("depth", "previous", "code", "head_code")}
STREAM_CODES = ("code", "head_code")
# A temporal detector's second file (``pair_path``) takes these; its first, the frame alone
# (``STREAM_INPUTS``), has ``ALONE`` in its metadata (an earlier d2sr's file with that input did not).
PAIR_INPUTS = ("depth", "previous")
ALONE = {"scores": "alone"}


def code_path(onnx: Path) -> Path:
    """Where an exported temporal UNet's encoder of the last clean frame lies, beside the model
    (``d2sr.models.streaming``): unet8-temporal.onnx -> unet8-temporal.code.onnx."""
    return onnx.with_name(onnx.name.removesuffix(".onnx") + ".code.onnx")


def pair_path(onnx: Path) -> Path:
    """Where an exported temporal detector's second file lies, the one that scores a frame with its previous
    frame (``d2sr.models.streaming``): detector.onnx -> detector.pair.onnx."""
    return onnx.with_name(onnx.name.removesuffix(".onnx") + ".pair.onnx")


def model_files(folder: Path, name: str) -> list[Path]:
    """Model ``name``'s files in ``folder`` that exist: its weights, its ONNX export and a streaming model's
    second file (``code_path``, ``pair_path``). What to copy to move a model."""
    onnx = folder / f"{name}.onnx"
    files = [folder / f"{name}.safetensors", onnx, code_path(onnx), pair_path(onnx)]
    return [f for f in files if f.is_file()]


def gate(alone: np.ndarray, cut: float | None, pair: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """A temporal detector's scores (N,): each frame's score alone (``alone``), lowered to its score with its
    previous frame (``pair(rows)``, for the rows of a bool (N,) selection) where that is lower. With a
    probability ``cut``, only the frames that reach it alone are scored with their previous frame: the
    others are below the cut either way and keep their score alone, at or above the exact one. The same
    verdict at any threshold from ``cut`` up, for half the detector's work on a clean frame."""
    rows = np.ones(len(alone), bool) if cut is None else alone >= cut
    out = np.array(alone, np.float32)
    if rows.any():
        out[rows] = np.minimum(out[rows], pair(rows))
    return out


def check_probability(value: float, option: str) -> float:
    """A probability threshold strictly between 0 and 1 (a ConfigError naming the option otherwise)."""
    if not 0 < value < 1:
        raise ConfigError(f"{option} must be in (0, 1), got {value}")
    return value


def check_size(h: int, w: int, stride: int, fixed_height: int | None, what: str) -> None:
    """The one input-size rule (torch models and exported files alike)."""
    if fixed_height is not None and h != fixed_height:
        raise InputError(f"{what} needs frames {fixed_height} pixels high, got {h}x{w}")
    if h % stride or w % stride:
        raise InputError(f"{what} needs height and width divisible by {stride}, got {h}x{w}")


def padded(metres: np.ndarray) -> np.ndarray:
    """(N, H, W) metres with a border of "no return" (zeros) at the bottom and right up to ``PAD``, so any
    sensor size works (320x240 as well as 640x480); crop results back to (H, W)."""
    h, w = metres.shape[-2:]
    if not (h % PAD or w % PAD):
        return metres
    return np.pad(metres, ((0, 0), (0, -h % PAD), (0, -w % PAD)))


def model_input(metres: np.ndarray, previous: np.ndarray | None, frames: int) -> np.ndarray:
    """(N, H, W) metres -> the recovery model's (N, frames, H, W) input; no last clean frame reads as 0."""
    x = metres[:, None].astype(np.float32, copy=False)
    if frames == 1:
        return x
    if previous is None:
        previous = np.zeros_like(metres)
    elif previous.shape != metres.shape:
        raise InputError(f"the earlier frame is {previous.shape}, the frame {metres.shape}")
    return np.concatenate([x, previous[:, None].astype(np.float32, copy=False)], axis=1)


def detector_input(metres: np.ndarray, previous: np.ndarray | None, frames: int) -> np.ndarray:
    """(N, H, W) metres -> the detector's (N, frames, H, W) input. A temporal detector also takes the
    sensor's previous frame; with none (a single image, a stream's first frame) the frame stands in for it,
    the single-frame case it was trained on."""
    return model_input(metres, metres if previous is None else previous, frames)


def scale_at(scale: float | np.ndarray, i: int) -> float:
    """Frame ``i``'s depth units per metre, for sets that hold one scale or one per frame."""
    return float(scale) if isinstance(scale, (int, float)) else float(np.asarray(scale)[i])
