"""Inference backends behind one small protocol. ``OnnxBackend`` imports no torch
(``pip install d2sr[edge]``); ``d2sr.models.inference.TorchBackend`` loads safetensors weights. Both work
in metres; ``to_depth_units`` puts the result back into the input's units, with pixels outside the
predicted mask bit-identical to the input."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from typing import Protocol

import numpy as np

from d2sr.errors import InputError

__all__ = [
    "THRESHOLD",
    "WEIGHTS",
    "Backend",
    "OnnxBackend",
    "check_size",
    "model_input",
    "open_backend",
    "to_depth_units",
]

WEIGHTS = Path(__file__).resolve().parents[1] / "models" / "weights"
DETECTOR = "detector"
THRESHOLD = 0.5  # detector score at or above which a frame counts as interfered


class Backend(Protocol):
    name: str

    def scores(self, metres: np.ndarray) -> np.ndarray:
        """(N, H, W) float32 metres -> (N,) probability that each frame is interfered."""
        ...

    frames: int  # 2: a temporal recovery model, which also takes the last clean frame

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N, H, W) float32 metres -> (predicted depth in metres, predicted mask bool), both (N, H, W).
        ``previous``: each frame's last clean frame (N, H, W), for temporal models (others ignore it)."""
        ...


def model_input(metres: np.ndarray, previous: np.ndarray | None, frames: int) -> np.ndarray:
    """(N, H, W) metres -> the recovery model's (N, frames, H, W) input; no last clean frame reads as 0."""
    x = metres[:, None].astype(np.float32, copy=False)
    if frames == 1:
        return x
    if previous is None:
        previous = np.zeros_like(metres)
    elif previous.shape != metres.shape:
        raise InputError(f"the last clean frame is {previous.shape}, the frame {metres.shape}")
    return np.concatenate([x, previous[:, None].astype(np.float32, copy=False)], axis=1)


def to_depth_units(frames: np.ndarray, pred: np.ndarray, mask: np.ndarray, scale: float) -> np.ndarray:
    """Predicted depth inside the mask (rounded to the input's units), the input itself outside it."""
    units = np.clip(np.rint(np.maximum(pred, 0) * np.float32(scale)), 0, 65535).astype(np.uint16)
    return np.where(mask, units, frames)


def check_size(h: int, w: int, stride: int, fixed_height: int | None, what: str) -> None:
    """The one input-size rule (torch models and exported files alike)."""
    if fixed_height is not None and h != fixed_height:
        raise InputError(f"{what} needs frames {fixed_height} pixels high, got {h}x{w}")
    if h % stride or w % stride:
        raise InputError(f"{what} needs height and width divisible by {stride}, got {h}x{w}")


class OnnxBackend:
    """onnxruntime sessions on exported models (``d2sr export``)."""

    name = "onnxruntime"

    def __init__(
        self,
        detector: Path,
        recovery: Path | None,
        threads: int | None = None,
        mask_logit: float | None = None,
    ) -> None:
        try:
            import onnxruntime as ort
        except ImportError:  # pragma: no cover - depends on the install
            raise InputError("onnxruntime is not installed: pip install 'd2sr[edge]'") from None
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = threads or min(os.cpu_count() or 1, 4)
        opts.inter_op_num_threads = 1
        opts.log_severity_level = 3
        # Two sessions (detector, recovery) alternate on the same cores: idle threads that spin-wait for
        # work would steal the other session's time.
        opts.add_session_config_entry("session.intra_op.allow_spinning", "0")

        def session(path: Path) -> ort.InferenceSession:
            if not Path(path).is_file():
                raise InputError(f"{path}: no such model file (d2sr export writes it)")
            try:
                return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
            except Exception as exc:  # onnxruntime raises its own untyped errors on corrupt files
                raise InputError(f"{path}: corrupt ONNX model ({str(exc).splitlines()[0][:120]})") from None

        self.det = session(detector)
        self.rec = session(recovery) if recovery is not None else None
        self._meta = {
            k: self._props(s) for k, s in (("detector", self.det), ("recovery", self.rec)) if s is not None
        }
        if mask_logit is not None and "recovery" in self._meta:  # the caller's own trade-off
            self._meta["recovery"]["mask_logit"] = mask_logit

    @staticmethod
    def _props(s: object) -> dict[str, float | None]:
        meta = s.get_modelmeta().custom_metadata_map  # type: ignore[attr-defined]
        return {
            "stride": int(meta.get("stride", 1)),
            "height": int(meta["height"]) if meta.get("height") else None,
            "frames": int(meta.get("frames", 1)),
            "mask_logit": float(meta.get("mask_logit", 0.0)),
        }

    @property
    def frames(self) -> int:
        return int(self._meta["recovery"]["frames"] or 1) if "recovery" in self._meta else 1

    def scores(self, metres: np.ndarray) -> np.ndarray:
        h, w = metres.shape[1:]
        p = self._meta["detector"]
        check_size(h, w, int(p["stride"] or 1), p["height"], "the detector")  # type: ignore[arg-type]
        return self.det.run(None, {"depth": metres[:, None].astype(np.float32, copy=False)})[0]

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        if self.rec is None:
            raise InputError("no recovery model loaded")
        h, w = metres.shape[1:]
        p = self._meta["recovery"]
        check_size(h, w, int(p["stride"] or 1), p["height"], "the recovery model")  # type: ignore[arg-type]
        logit, pred = self.rec.run(None, {"depth": model_input(metres, previous, self.frames)})
        return pred[:, 0], logit[:, 0] > p["mask_logit"]


def open_backend(
    model: str | None = "unet8",
    backend: str = "auto",
    weights: Path = WEIGHTS,
    detector: str = DETECTOR,
    threads: int | None = None,
    int8: bool = False,
    mask_logit: float | None = None,
) -> Backend:
    """The shipped (or given folder's) detector and recovery model. ``auto``: onnxruntime when it is
    installed and the ONNX files exist, torch otherwise. ``mask_logit`` overrides the recovery model's
    own mask threshold."""
    if backend not in ("auto", "onnx", "torch"):
        raise InputError(f"unknown backend {backend!r}; choose auto, onnx or torch")
    if mask_logit is not None and not np.isfinite(mask_logit):
        raise InputError(f"--mask-logit must be a finite number, got {mask_logit}")
    ext = ".int8.onnx" if int8 else ".onnx"  # int8: d2sr export --int8
    onnx_files = [weights / f"{detector}{ext}"] + ([weights / f"{model}{ext}"] if model else [])
    if int8 and backend == "torch":
        raise InputError("int8 models run on onnxruntime (--backend onnx)")
    if int8:
        backend = "onnx"
    if backend == "auto":
        try:
            import onnxruntime  # noqa: F401

            backend = "onnx" if all(f.is_file() for f in onnx_files) else "torch"
        except ImportError:
            backend = "torch"
    if backend == "onnx":
        return OnnxBackend(onnx_files[0], onnx_files[1] if model else None, threads, mask_logit)
    if importlib.util.find_spec("torch") is None:
        raise InputError(f"no ONNX models in {weights} and torch is not installed")
    from d2sr.models.inference import TorchBackend

    rec = weights / f"{model}.safetensors" if model else None
    return TorchBackend(weights / f"{detector}.safetensors", rec, mask_logit)
