"""Recovery metrics, one set of sums for training (choosing a model's mask threshold) and evaluation
(tables, operating curves): RMSE over pixels with a true return, mask precision / recall / F1, and the
share of clean pixels a repair changed by more than 1 cm. Numpy only."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from d2sr.contract.repair import repair_frame

__all__ = ["CHANGED_M", "RepairSums", "threshold_curve"]

CHANGED_M = 0.01  # a clean pixel moved by more than this counts as changed


@dataclass
class RepairSums:
    """Pooled sums over frames for one method (all in metres)."""

    se: float = 0.0
    n_valid: int = 0
    tp: int = 0
    fp: int = 0
    fn: int = 0
    changed: int = 0
    n_clean: int = 0
    errors: list[np.ndarray] | None = None

    def add(self, out: np.ndarray, mask: np.ndarray, x: np.ndarray, y: np.ndarray, true: np.ndarray) -> None:
        """``out`` the repair of input ``x`` with predicted ``mask``; ``y`` the clean truth, ``true`` the
        true interference mask."""
        valid = y > 0
        err = out - y
        self.se += float((err[valid] ** 2).sum())
        self.n_valid += int(valid.sum())
        self.tp += int((mask & true).sum())
        self.fp += int((mask & ~true).sum())
        self.fn += int((~mask & true).sum())
        self.changed += int((np.abs(out - x)[~true] > CHANGED_M).sum())
        self.n_clean += int((~true).sum())
        if self.errors is not None:
            self.errors.append(np.abs(err[valid & true]).astype(np.float32))

    def result(self) -> dict[str, Any]:
        p = self.tp / max(self.tp + self.fp, 1)
        r = self.tp / max(self.tp + self.fn, 1)
        return {
            "rmse_cm": 100 * float(np.sqrt(self.se / max(self.n_valid, 1))),
            "mask_precision": p,
            "mask_recall": r,
            "mask_f1": 2 * p * r / max(p + r, 1e-12),
            "clean_changed": self.changed / max(self.n_clean, 1),
        }


def threshold_curve(
    samples: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]],
    logits: Sequence[float],
) -> tuple[RepairSums, list[RepairSums]]:
    """(identity, one ``RepairSums`` per mask threshold) over ``samples`` of (input metres, clean metres,
    true mask, mask logits, predicted depth, depth scale), each repair rounded to the input's depth units
    as the runtime writes it."""
    t = np.asarray(logits, np.float32)
    ident, sums = RepairSums(), [RepairSums() for _ in t]
    for x, y, true, logit, pred, scale in samples:
        s = np.float32(scale)
        ident.add(x, np.zeros_like(true), x, y, true)
        units = np.rint(x * s).astype(np.uint16)
        for acc, m in zip(sums, logit[None] > t[:, None, None], strict=True):
            out, kept = repair_frame(units, pred, m, scale)
            acc.add(out.astype(np.float32) / s, kept, x, y, true)
    return ident, sums
