"""The model contract: what the learned stages, their weights and every inference backend agree on.
Torch-free, so that ``models/`` (torch), ``runtime/`` (onnxruntime on the edge) and the CLI share one
source for each fact.

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

import cv2
import numpy as np

from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import crop_around
from d2sr.scene.evidence import SceneRepair

__all__ = [
    "AGREE_M",
    "AGREE_REL",
    "ALONE",
    "AUTO_RECOVERY",
    "AUTO_TEMPORAL_LOGIT",
    "CATALOG",
    "DEFAULT_MODEL",
    "DEFAULT_RECOVERY",
    "DETECTOR",
    "DETECTOR_NAMES",
    "LINES_UP",
    "MASK_DETECTOR",
    "MODEL_HELP",
    "PAD",
    "PAIR_INPUTS",
    "RECOVERY_NAMES",
    "REFRESH_FRAMES",
    "REPAIR_MODELS",
    "REPAIR_PASSES",
    "SHIPPED_RECOVERY",
    "TEMPORAL_RECOVERY",
    "THRESHOLD",
    "WEIGHTS",
    "Entry",
    "Raw",
    "SceneRepair",
    "agreement",
    "check_passes",
    "check_probability",
    "check_size",
    "code_path",
    "crop_around",
    "detector_input",
    "gate",
    "guard",
    "model_files",
    "model_input",
    "padded",
    "pair_path",
    "recover_passes",
    "refill",
    "repair_frame",
    "scale_at",
]

WEIGHTS = Path(__file__).resolve().parent / "models" / "weights"  # the shipped weights, ONNX and cards
DETECTOR = "detector"
MASK_DETECTOR = "mask-detector"  # d2sr adapt's detector: a recovery model's mask (not trained on its own)


@dataclass(frozen=True)
class Entry:
    """A model name in the catalogue: its ``kind`` (detector or recovery), whether its weights ship
    with d2sr, and what it is."""

    kind: str
    shipped: bool
    about: str


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
# Do no harm (``guard``): a repair stays within the range of its trusted neighbours (``GUARD_PX`` around),
# widened by the sensor's noise (``KEEP_M`` + ``KEEP_REL`` x depth).
KEEP_M = 0.03
KEEP_REL = 0.02
GUARD_PX = 12
# ... and moves a return only when its value is farther from the repair than the model's own error: inside
# that band a right value cannot be told from a wrong one (the adapted D435 model's error at hit pixels of
# its held-out frames: lower quartile 10% of depth, median 25%). There, 25% fewer clean pixels changed at
# the same mask threshold, recall 0.306 -> 0.300; a partly hit stripe's returns in between are left alone.
LEAVE_REL = 0.10
# ... and leaves a lone return as it is: one with at most ``LONE_MAX`` other returns among the pixels within
# ``LONE_PX`` (9x9; outside the image: none). No surface around it says where it belongs. On the clean L515
# frames of outside sets A-H the repair moved about 10 such returns a frame by metres (nearly all farther),
# most of the harm on sets G and H; leaving them cost set A 3.8 points of RMSE (research/decisions.md).
LONE_PX = 4
LONE_MAX = 16
# Recovery runs the model again on its own repair: once the pixels it was sure of are filled in, the rest of
# a wide wrong surface stands out against them (a second pass lifted mask F1 0.63 -> 0.70 on sawtooth
# stripes written outside the project, and left clean frames as they were).
REPAIR_PASSES = 2
# ``--model auto``: the temporal model only where the sensor's last clean frame lines up with the frame (a
# sensor that held still): at least ``LINES_UP`` of the pixels returning in both agree within ``AGREE_M`` +
# ``AGREE_REL`` x depth. Where the robot moved, the temporal model alone lost 9.1 points of RMSE to unet8
# (bench/temporal_gate.py).
AUTO_RECOVERY = "auto"
TEMPORAL_RECOVERY = "unet8-temporal"
LINES_UP = 0.5
AGREE_M = 0.05
AGREE_REL = 0.02
# auto's own operating point for the temporal model (unet8 keeps its own): read off outside set A, held on
# sets B and C, and confirmed with the default's switch on sealed set F (docs/research/decisions.md).
AUTO_TEMPORAL_LOGIT = -1.5
# Repairing every frame with a temporal model, the detector only picks the last clean frame: it runs on a
# frame with none yet, one that does not line up with it, or when this many frames have passed since it
# last ran (unet8-temporal was trained with last clean frames 1-12 frames old).
REFRESH_FRAMES = 10


REPAIR_MODELS = (AUTO_RECOVERY, *RECOVERY_NAMES)  # what recover and run take: a model, or auto's pair
# What every caller repairs with unless told: d2sr.repair, d2sr.Pipeline, recover, run and the demo (auto
# since 2026-11-26 for recover, docs/research/decisions.md; the others followed so that one name means one
# repair). DEFAULT_RECOVERY stays the single-frame model auto falls back on.
DEFAULT_MODEL = AUTO_RECOVERY
MODEL_HELP = (
    f"Recovery model: {', '.join(REPAIR_MODELS)} (shipped: {', '.join(SHIPPED_RECOVERY)}; auto: "
    f"{TEMPORAL_RECOVERY} where the last clean frame lines up with the frame, {DEFAULT_RECOVERY} elsewhere)."
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


def guard(metres: np.ndarray, pred: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Do no harm: (pred, mask) limited to changes that matter and agree with the frame's trusted pixels.

    - A prediction is clamped to the range of the trusted returns (not masked) within ``GUARD_PX`` pixels,
      widened by ``KEEP_M`` + ``KEEP_REL`` x depth, so a repair never invents a surface nearer or farther
      than all of its neighbours. Where no trusted return is that close (a large hit region), it stands.
    - A returning pixel whose (clamped) prediction is within ``KEEP_M`` + ``LEAVE_REL`` x depth of its own
      value is left alone: the repair would move it by no more than the model's own error.
    - A lone return (at most ``LONE_MAX`` other returns within ``LONE_PX``) is left alone.

    Only masked pixels can be repaired, so only they are clamped (``pred`` is returned as is elsewhere).
    Works on one frame (H, W) or a batch (N, H, W), in metres."""
    if metres.ndim == 3:
        pairs = [guard(x, p, m) for x, p, m in zip(metres, pred, mask, strict=True)]
        return np.stack([p for p, _ in pairs]), np.stack([m for _, m in pairs])
    p = np.array(pred, np.float32)  # a contiguous copy, written below
    keep = np.zeros(mask.shape, bool)
    # The neighbours' range is needed only within GUARD_PX of a masked pixel (erode and dilate ignore
    # what lies beyond a crop's edge), and the rest only at the masked pixels: the cost follows the mask.
    crop = crop_around(mask, GUARD_PX)
    if crop is None:
        return p, keep
    rs, cs = crop
    x = np.ascontiguousarray(metres[rs, cs], np.float32)
    m = mask[rs, cs]
    returns = x > 0
    trusted = (returns & ~m).view(np.uint8)
    k = np.ones((2 * GUARD_PX + 1, 2 * GUARD_PX + 1), np.uint8)
    at = np.flatnonzero(m)
    # The trusted returns, inf (for the minimum) or 0 (for the maximum) elsewhere; cv2.copyTo: 6x np.where.
    lo = cv2.erode(cv2.copyTo(x, trusted, np.full_like(x, np.inf)), k).ravel()[at]
    hi = cv2.dilate(cv2.copyTo(x, trusted, np.zeros_like(x)), k).ravel()[at]
    xi = x.ravel()[at]
    pc = p[rs, cs]  # a view into p
    pi = pc[m]
    tol = np.float32(KEEP_M) + np.float32(KEEP_REL) * xi
    pi = np.where(hi > 0, np.minimum(np.maximum(pi, lo - tol), hi + tol), pi)
    pc[m] = pi
    leave = np.float32(KEEP_M) + np.float32(LEAVE_REL) * xi
    # Returns counted as uint8 into uint16 (2.5x a float32 box filter); the crop's margin, GUARD_PX, holds
    # every masked pixel's LONE_PX neighbourhood, so only the image's own edges count as no return.
    side = 2 * LONE_PX + 1
    around = cv2.boxFilter(
        returns.view(np.uint8), cv2.CV_16U, (side, side), normalize=False, borderType=cv2.BORDER_CONSTANT
    )
    lone = around.ravel()[at] <= LONE_MAX + 1  # the count includes the pixel itself
    keep[rs, cs][m] = ~((xi > 0) & ((np.abs(pi - xi) <= leave) | lone))
    return p, keep


Raw = Callable[[np.ndarray, np.ndarray | None], tuple[np.ndarray, np.ndarray]]


def agreement(metres: np.ndarray, previous: np.ndarray | None) -> float:
    """Share of the pixels returning in both frames (metres, same shape) that agree within ``AGREE_M`` +
    ``AGREE_REL`` x depth; 0 with no earlier frame or no pixel returning in both."""
    if previous is None:
        return 0.0
    if previous.shape != metres.shape:
        raise InputError(f"the earlier frame is {previous.shape}, the frame {metres.shape}")
    ok = (metres > 0) & (previous > 0)
    n = np.count_nonzero(ok)
    if not n:
        return 0.0
    agree = np.abs(metres - previous) <= AGREE_M + AGREE_REL * metres  # whole arrays: no gathers
    return np.count_nonzero(agree & ok) / n


def check_passes(passes: int) -> int:
    if not 1 <= passes <= 8:
        raise ConfigError(f"--passes must be in 1..8, got {passes}")
    return passes


def refill(metres: np.ndarray, pred: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What a pass after the first sees (``recover_passes``): the frame with the guarded repair filled in
    (float32 metres), and the pixels it filled."""
    p, keep = guard(metres, pred, mask)
    return np.where(keep, p, metres).astype(np.float32), keep


def recover_passes(
    raw: Raw, metres: np.ndarray, previous: np.ndarray | None, mask_logit: float, passes: int
) -> tuple[np.ndarray, np.ndarray]:
    """(predicted depth, mask), both (N, H, W), after ``passes`` runs of a recovery model (``raw``: metres,
    previous -> mask logits, depth). Each pass after the first sees the frame with the last pass's guarded
    repair filled in and keeps every pixel repaired so far; it stops early once a pass repairs nothing or
    finds no pixel the last one had not."""
    logit, pred = raw(metres, previous)
    mask = logit > mask_logit
    for _ in range(passes - 1):
        filled, keep = refill(metres, pred, mask)
        if not keep.any():
            break
        logit, pred = raw(filled, previous)
        grown = keep | (logit > mask_logit)
        found = (grown & ~mask).any()  # nothing new: a further pass would see much the same frame
        mask = grown
        if not found:
            break
    return pred, mask


def repair_frame(
    frames: np.ndarray,
    pred: np.ndarray,
    mask: np.ndarray,
    scale: float,
    scene: SceneRepair | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(repaired frame in the input's units, mask of the pixels repaired): the guarded prediction inside
    the mask (``guard``), rounded to the input's units (uint16) or as computed (float32 metres, ``scale``
    1); the input itself everywhere else, bit for bit. With ``scene``: its ``keep`` pixels are out of the
    mask (and so trusted by the guard), and its ``fill`` depths are written past the guard's model-error
    margin; only those that change the pixel count as repaired."""
    if scene is not None:
        mask = mask & ~scene.keep
    p, m = guard(frames.astype(np.float32) / np.float32(scale), pred, mask)
    written = m
    if scene is not None:
        p, written = np.where(scene.fill, scene.depth, p), m | scene.fill
    out = frames.copy()
    fixed = np.maximum(p[written], 0) * np.float32(scale)
    out[written] = fixed if frames.dtype.kind == "f" else np.clip(np.rint(fixed), 0, 65535).astype(np.uint16)
    return out, m if scene is None else m | (scene.fill & (out != frames))
