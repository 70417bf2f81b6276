"""The inference protocol the runtime runs on, and its torch-free implementation: ``OnnxBackend``
(``pip install d2sr[edge]``). ``d2sr.models.inference.TorchBackend`` is the torch one; ``d2sr.inference``
opens either. Both work in metres (``d2sr.contract``)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from d2sr.contract import (
    LINES_UP,
    REPAIR_PASSES,
    THRESHOLD,
    agreement,
    check_passes,
    check_size,
    detector_input,
    model_input,
    recover_passes,
)
from d2sr.errors import InputError

__all__ = ["Backend", "Gated", "OnnxBackend"]


class Backend(Protocol):
    name: str
    threshold: float  # the detector's own probability threshold (stored with it; contract.THRESHOLD)
    passes: int  # recovery runs of the model per frame (contract.recover_passes)

    def scores(self, metres: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
        """(N, H, W) float32 metres -> (N,) probability that each frame is interfered. ``previous``: the
        sensor's frame before each (N, H, W), which a temporal detector also weighs (others ignore it)."""
        ...

    @property
    def frames(self) -> int:
        """2: a temporal recovery model, which also takes the last clean frame; else 1."""
        ...

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One run of the recovery model: (mask logits, predicted depth in metres), both (N, H, W)."""
        ...

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N, H, W) float32 metres -> (predicted depth in metres, predicted mask bool), both (N, H, W).
        ``previous``: each frame's last clean frame (N, H, W), for temporal models (others ignore it).
        The model runs up to ``passes`` times (``d2sr.contract.recover_passes``)."""
        ...


@dataclass
class _Props:
    """What an exported model says about itself (``d2sr.export`` writes it as ONNX metadata)."""

    stride: int
    height: int | None
    frames: int
    mask_logit: float
    threshold: float


class OnnxBackend:
    """onnxruntime sessions on exported models (``d2sr export``)."""

    name = "onnxruntime"

    def __init__(
        self,
        detector: Path | None,
        recovery: Path | None,
        threads: int | None = None,
        mask_logit: float | None = None,
        passes: int = REPAIR_PASSES,
    ) -> None:
        self.passes = check_passes(passes)
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

        self.det = session(detector) if detector is not None else None
        self.rec = session(recovery) if recovery is not None else None
        self._meta = {
            k: self._props(s) for k, s in (("detector", self.det), ("recovery", self.rec)) if s is not None
        }
        if mask_logit is not None and "recovery" in self._meta:  # the caller's own trade-off
            self._meta["recovery"].mask_logit = mask_logit
        self.threshold = self._meta["detector"].threshold if "detector" in self._meta else THRESHOLD

    @staticmethod
    def _props(s: Any) -> _Props:
        meta = s.get_modelmeta().custom_metadata_map  # what d2sr export wrote into the file
        return _Props(
            stride=int(meta.get("stride", 1)),
            height=int(meta["height"]) if meta.get("height") else None,
            frames=int(meta.get("frames", 1)),
            mask_logit=float(meta.get("mask_logit", 0.0)),
            threshold=float(meta.get("threshold", THRESHOLD)),
        )

    @property
    def frames(self) -> int:
        return self._meta["recovery"].frames if "recovery" in self._meta else 1

    def scores(self, metres: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
        if self.det is None:
            raise InputError("no detector loaded")
        h, w = metres.shape[1:]
        p = self._meta["detector"]
        check_size(h, w, p.stride, p.height, "the detector")
        scores: np.ndarray = self.det.run(None, {"depth": detector_input(metres, previous, p.frames)})[0]
        return scores

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(mask logits, predicted depth), before any threshold."""
        if self.rec is None:
            raise InputError("no recovery model loaded")
        h, w = metres.shape[1:]
        p = self._meta["recovery"]
        check_size(h, w, p.stride, p.height, "the recovery model")
        logit, pred = self.rec.run(None, {"depth": model_input(metres, previous, self.frames)})
        return logit[:, 0], pred[:, 0]

    @property
    def mask_logit(self) -> float:
        return self._meta["recovery"].mask_logit if "recovery" in self._meta else 0.0

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        return recover_passes(self.raw, metres, previous, self.mask_logit, self.passes)


class Gated:
    """``--model auto``: a temporal recovery model for each frame whose last clean frame lines up with it (a
    sensor that held still: ``contract.agreement`` >= ``LINES_UP``), a single-frame one for the others.
    ``single`` also holds the detector; both are open backends of the same kind."""

    frames = 2  # the loop keeps the last clean frame for it

    def __init__(self, single: Backend, temporal: Backend) -> None:
        if single.frames != 1 or temporal.frames != 2:
            raise InputError("auto needs a single-frame and a temporal recovery model")
        self.single, self.temporal = single, temporal
        self.name, self.threshold, self.passes = single.name, single.threshold, single.passes

    def scores(self, metres: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
        return self.single.scores(metres, previous)

    def _each(
        self, run: str, metres: np.ndarray, previous: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``run`` ("raw" or "recover") of the model each frame gets, stacked."""
        outs = []
        for i in range(len(metres)):
            x, net, prev = metres[i : i + 1], self.single, None
            if previous is not None and agreement(x[0], previous[i]) >= LINES_UP:  # the sensor held still
                net, prev = self.temporal, previous[i : i + 1]
            outs.append(getattr(net, run)(x, prev))
        return np.concatenate([a for a, _ in outs]), np.concatenate([b for _, b in outs])

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        return self._each("raw", metres, previous)

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        return self._each("recover", metres, previous)
