"""``d2sr eval detector|recovery``: the learned stages on held-out data, with the classical baselines.

Two test sets, neither seen in training:

* ``generated``: frames from seeds >= TEST_SEED (training uses seeds below it);
* ``moving``: a simulated robot's sensor driving among three fixed ones (the paper's moving-robot case);
* ``l515``: the real L515 captures with the simulator's interference added to every other frame (dev0's
  first 45 frames, a person walking through, stay clean: hard negatives). The real frame itself is the
  ground truth, so the true mask is exactly the pixels the interference changed.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.contract.catalog import scale_at
from d2sr.contract.metrics import RepairSums, threshold_curve
from d2sr.contract.repair import Raw
from d2sr.desync import TOTAL_FRAMES
from d2sr.eval.baselines import BASELINES, last_clean
from d2sr.eval.labels import drifting_interference
from d2sr.frames import open_frames

__all__ = [
    "TestSet",
    "detector_metrics",
    "generated_set",
    "l515_set",
    "moving_set",
    "operating_curve",
    "recovery_metrics",
]

TEST_SEED_ROOMS = 2_000_000  # rooms of the moving-robot test set (training never draws these seeds)
PERSON_FRAMES = 45  # dev0: a person walks through the view in these


@dataclass
class TestSet:
    name: str
    frames: list[np.ndarray]  # uint16
    clean: list[np.ndarray]
    scale: float | np.ndarray  # depth units per metre: one for the set, or one per frame
    hard: np.ndarray  # bool per frame: a clean frame that is a known hard negative (people moving)
    last_clean: np.ndarray | None = None  # per frame, the index of its sequence's last clean frame (-1: none)
    starts: tuple[int, ...] | None = None  # first frame of each sequence (None: independent frames)

    @cached_property
    def labels(self) -> np.ndarray:
        return np.array([(f != c).any() for f, c in zip(self.frames, self.clean, strict=True)])

    def scale_at(self, i: int) -> float:
        return scale_at(self.scale, i)

    def metres(self, i: int, clean: bool = False) -> np.ndarray:
        return (self.clean if clean else self.frames)[i].astype(np.float32) / np.float32(self.scale_at(i))

    def previous(self, i: int) -> np.ndarray | None:
        """The last truly clean frame before frame ``i`` in its sequence (what a temporal model sees, with
        a perfect detector), in metres; None when there is none."""
        j = -1 if self.last_clean is None else int(self.last_clean[i])
        return None if j < 0 else self.metres(j)

    def sequence(self, k: int, name: str) -> TestSet:
        """The set's ``k``-th sequence alone (the real L515 set: 0 is dev0, 1 is dev1), named ``name``."""
        if self.starts is None or not 0 <= k < len(self.starts):
            raise IndexError(f"{self.name} has no sequence {k}")
        a = self.starts[k]
        b = self.starts[k + 1] if k + 1 < len(self.starts) else len(self.frames)
        last = (
            None
            if self.last_clean is None
            else np.where(self.last_clean[a:b] >= 0, self.last_clean[a:b] - a, -1)
        )
        scale = self.scale[a:b] if isinstance(self.scale, np.ndarray) else self.scale
        return TestSet(name, self.frames[a:b], self.clean[a:b], scale, self.hard[a:b], last, (0,))

    def before(self, i: int) -> np.ndarray | None:
        """The frame delivered just before frame ``i`` in its sequence (what a temporal detector sees), in
        metres; None for independent frames and a sequence's first."""
        return None if self.starts is None or i in self.starts else self.metres(i - 1)


def _last_clean(labels: np.ndarray, starts: list[int]) -> np.ndarray:
    """For each frame, the index of the last clean frame before it, not reaching back past its sequence's
    start (``starts``: the first index of each sequence)."""
    out = np.full(len(labels), -1)
    last = -1
    for i in range(len(labels)):
        if i in starts:
            last = -1
        out[i] = last
        if not labels[i]:
            last = i
    return out


def _every_other(t: int, skip: int) -> int:
    """Interferers of frame ``t``: none in the first ``skip`` frames and on every other one; 1 or 2."""
    return 0 if t < skip or (t - skip) % 2 == 0 else 1 + (t // 2) % 2


def l515_set(root: Path, seed: int = 7) -> TestSet:
    """Every other frame of each capture interfered by one or two drifting interferers."""
    frames: list[np.ndarray] = []
    clean: list[np.ndarray] = []
    hard: list[bool] = []
    starts: list[int] = []
    scale = 4000.0
    for k, (name, skip) in enumerate((("dev0", PERSON_FRAMES), ("dev1", 0))):
        starts.append(len(frames))
        reader = open_frames(root / name)
        scale = reader.depth_scale or scale
        seq = [f.depth for f in reader]
        out, _ = drifting_interference(
            seq,
            scale,
            seed + k,
            functools.partial(_every_other, skip=skip),
        )
        frames += out
        clean += seq
        hard += [t < skip for t in range(len(seq))]
    ts = TestSet("l515", frames, clean, scale, np.array(hard), starts=tuple(starts))
    ts.last_clean = _last_clean(ts.labels, starts)
    return ts


def moving_set(seed: int = 0, seconds: float = 8.0, every: int = 2) -> TestSet:
    """A robot's sensor (the paper's Table II, right) driving among three fixed ones, all always on: every
    ``every``-th frame of the robot, rendered and interfered by the simulator (a held-out room: training
    frames come from other seeds' rigs)."""
    from d2sr.sim.lockstep import SimRoom
    from d2sr.sim.timing import TimingSettings
    from d2sr.sim.world import make_rig

    rig = make_rig(TEST_SEED_ROOMS + seed, sensors=4, moving_robot=True)
    robot = rig.n - 1
    cfg = TimingSettings(active_frames=TOTAL_FRAMES, setup=0, hit_prob=1.0)  # always on
    room = SimRoom(rig, cfg, seed=TEST_SEED_ROOMS + seed, seconds=seconds, render=[robot])
    frames, clean = [], []
    for ev in room.slots(seconds):
        f = ev.frame
        if f is not None and ev.sensor == robot and f.slot % every == 0:
            frames.append(f.depth)
            clean.append(f.clean)
    ts = TestSet("moving", frames, clean, room.model.depth_scale, np.zeros(len(frames), bool), starts=(0,))
    ts.last_clean = _last_clean(ts.labels, [0])
    return ts


def generated_set(cache: Path, count: int = 600) -> TestSet:
    from d2sr.sim.dataset import TEST_SEED
    from d2sr.train.data import synth_set

    ss = synth_set(cache, count, TEST_SEED)
    return TestSet("generated", list(ss.frames), list(ss.clean), ss.scales, np.zeros(count, bool))


def _prf(pred: np.ndarray, true: np.ndarray) -> dict[str, float]:
    tp = float((pred & true).sum())
    p = tp / max(float(pred.sum()), 1)
    r = tp / max(float(true.sum()), 1)
    return {"precision": p, "recall": r, "f1": 2 * p * r / max(p + r, 1e-12)}


def detector_metrics(scores: np.ndarray, ts: TestSet, threshold: float = 0.5) -> dict:
    labels = ts.labels
    pred = scores >= threshold
    out: dict[str, Any] = _prf(pred, labels) | {"frames": len(labels), "interfered": int(labels.sum())}
    out["false_alarm_rate"] = float(pred[~labels].mean()) if (~labels).any() else 0.0
    if ts.hard.any():
        out["false_alarm_rate_people"] = float(pred[ts.hard].mean())
    order = np.argsort(-scores)
    tp = np.cumsum(labels[order])
    out["pr_curve"] = {
        "precision": np.round(tp / np.arange(1, len(order) + 1), 4).tolist(),
        "recall": np.round(tp / max(labels.sum(), 1), 4).tolist(),
    }
    return out


# (metres, last clean frame or None, depth scale) -> (repaired metres, mask)
Repair = Callable[[np.ndarray, np.ndarray | None, float], tuple[np.ndarray, np.ndarray]]


def _interfered(
    ts: TestSet, limit: int | None
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, float]]:
    """The interfered frames (``limit``: that many, evenly spread over the set): (metres, ground truth,
    true mask, last clean frame or None, depth scale)."""
    idx = np.flatnonzero(ts.labels)
    if limit is not None and limit < len(idx):
        idx = idx[np.linspace(0, len(idx) - 1, limit).round().astype(int)]
    for i in idx:
        f, c = ts.frames[i], ts.clean[i]
        j = int(i)
        yield ts.metres(j), ts.metres(j, clean=True), f != c, ts.previous(j), ts.scale_at(j)


def recovery_metrics(
    ts: TestSet,
    models: dict[str, Repair],
    baseline_mask_from: str | None,
    limit: int | None = None,
    progress: Callable[[], None] | None = None,
) -> tuple[dict[str, dict], dict[str, np.ndarray]]:
    """Table rows (RMSE, mask precision/recall/F1, share of clean pixels changed by > 1 cm) on the
    interfered frames, for identity, each model, and each baseline given the predicted mask of
    ``baseline_mask_from`` and the true mask (a ceiling). Also the per-pixel absolute errors on truly
    interfered valid pixels, for the error CDF."""
    accs: dict[str, RepairSums] = {"identity": RepairSums(errors=[])}
    for name in models:
        accs[name] = RepairSums(errors=[])
    temporal = ts.last_clean is not None
    names = [*BASELINES, *(["last clean"] if temporal else [])]
    for b in names:
        if baseline_mask_from:
            accs[f"{b} (predicted mask)"] = RepairSums(errors=[])
        accs[f"{b} (true mask)"] = RepairSums()
    for x, y, true, prev, scale in _interfered(ts, limit):
        accs["identity"].add(x, np.zeros_like(true), x, y, true)
        masks = {}
        for name, fn in models.items():
            out, mask = fn(x, prev, scale)
            masks[name] = mask
            accs[name].add(out, mask, x, y, true)
        fills = dict(BASELINES)
        if temporal:
            before = prev if prev is not None else np.zeros_like(x)
            fills["last clean"] = functools.partial(last_clean, previous=before)
        for b, fill in fills.items():
            if baseline_mask_from:
                m = masks[baseline_mask_from]
                accs[f"{b} (predicted mask)"].add(fill(x, m), m, x, y, true)
            accs[f"{b} (true mask)"].add(fill(x, true), true, x, y, true)
        if progress:
            progress()
    rows = {k: {m: round(v, 5) for m, v in a.result().items()} for k, a in accs.items()}
    ident = rows["identity"]["rmse_cm"]
    for r in rows.values():
        r["rmse_vs_identity"] = round(r["rmse_cm"] / ident - 1, 4) if ident else 0.0
    errors = {k: np.concatenate(a.errors) for k, a in accs.items() if a.errors}
    return rows, errors


def operating_curve(
    ts: TestSet, raw: Raw, logits: Sequence[float], limit: int | None = None
) -> dict[str, list[float]]:
    """One model's trade-off over mask thresholds (``raw``: metres, previous -> mask logits, depth): RMSE
    change against identity and share of clean pixels changed by > 1 cm, per threshold (what
    ``--mask-logit`` chooses along)."""
    samples = ((x, y, true, *raw(x, prev), s) for x, y, true, prev, s in _interfered(ts, limit))
    ident, accs = threshold_curve(samples, logits)
    base = max(ident.result()["rmse_cm"], 1e-12)
    rows = [a.result() for a in accs]
    return {
        "mask_logit": [float(v) for v in logits],
        "rmse_vs_identity": [round(r["rmse_cm"] / base - 1, 4) for r in rows],
        "clean_changed": [round(r["clean_changed"], 5) for r in rows],
    }
