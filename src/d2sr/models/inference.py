"""The torch inference backend (same protocol as ``d2sr.runtime.OnnxBackend``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

from d2sr.contract.catalog import THRESHOLD, detector_input, gate, model_input
from d2sr.contract.repair import REPAIR_PASSES, check_passes, recover_passes
from d2sr.errors import InputError
from d2sr.models.detector import FastDetector
from d2sr.models.registry import check_input_size
from d2sr.models.store import load_model, torch_device
from d2sr.models.store import mask_logit as read_mask_logit
from d2sr.models.store import threshold as read_threshold

__all__ = ["TorchBackend"]


class TorchBackend:
    """The same from safetensors weights, in torch (training machines, CUDA when present)."""

    name = "torch"

    def __init__(
        self,
        detector: Path | None,
        recovery: Path | torch.nn.Module | None,
        mask_logit: float | None = None,
        passes: int = REPAIR_PASSES,
    ) -> None:
        """``recovery`` may be a model in memory (``d2sr adapt`` checks its repair as ``recover`` runs it);
        then ``mask_logit`` is needed."""
        self.passes = check_passes(passes)
        self.device = torch_device()
        self.det = load_model(detector)[0].to(self.device) if detector is not None else None
        if isinstance(recovery, torch.nn.Module):
            if mask_logit is None:
                raise ValueError("a recovery model in memory needs its mask_logit")
            self.rec: torch.nn.Module | None = recovery.to(self.device)
        else:
            self.rec = load_model(recovery)[0].to(self.device) if recovery is not None else None
        self.frames = int(getattr(self.rec, "frames", 1))
        if mask_logit is None:  # the model's own, chosen on validation frames
            mask_logit = read_mask_logit(recovery) if isinstance(recovery, (str, Path)) else 0.0
        self.mask_logit = mask_logit
        self.threshold = read_threshold(detector) if detector is not None else THRESHOLD

    def scores(
        self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
    ) -> np.ndarray:
        if self.det is None:
            raise InputError("no detector loaded")
        check_input_size(self.det, *metres.shape[1:])
        det = self.det

        def score(x: np.ndarray, net: Callable[[torch.Tensor], torch.Tensor] = det) -> np.ndarray:
            with torch.inference_mode():
                out: np.ndarray = torch.sigmoid(net(torch.from_numpy(x).to(self.device))).cpu().numpy()
            return out

        if not isinstance(det, FastDetector) or det.frames == 1:
            return score(detector_input(metres, previous, int(getattr(det, "frames", 1))))
        # FastDetector.forward's two scores, one at a time: alone (the frame as its own previous one), then
        # with the previous frame where contract.gate asks for it.
        alone = score(detector_input(metres, None, 2), det.logit)
        if previous is None:
            return alone
        return gate(
            alone, cut, lambda rows: score(detector_input(metres[rows], previous[rows], 2), det.logit)
        )

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(mask logits, predicted depth), before any threshold."""
        if self.rec is None:
            raise InputError("no recovery model loaded")
        check_input_size(self.rec, *metres.shape[1:])
        x = torch.from_numpy(model_input(metres, previous, self.frames)).to(self.device)
        with torch.inference_mode():
            logit, pred = self.rec(x)
        return logit[:, 0].cpu().numpy(), pred[:, 0].cpu().numpy()

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        return recover_passes(self.raw, metres, previous, self.mask_logit, self.passes)
