"""``d2sr adapt``: fit the default recovery model, and with it a detector, to one site's sensor and room.

Self-supervised: the user's clean frames, corrupted by the wide interference generator (so the true masks
are known), plus any real interfered frames labelled by ``d2sr label``. Starting from the shipped weights,
the recovery model is fine-tuned for a budget of steps, with generated frames of every sensor kind mixed in
(rehearsal: a model fitted to a few dozen frames of one room forgets what else is clean). The detector
written beside it is that model's mask (``MaskDetector``: the share of a frame it would repair), not a
second network: fine-tuned the same way, the frame CNN could not separate a D435's later clean frames from
corrupted ones (precision / recall 0.91 / 0.87 from outside), while the mask could (1.00 / 0.92).
The last ``HOLDOUT`` of each recording (by time, not at random: neighbouring frames are near-copies) is held
out; on it the mask threshold is chosen for at most ``MAX_CLEAN_CHANGED`` clean pixels changed, then the
detector's threshold for a target false-alarm rate. The result is a model folder (safetensors, ONNX, card)
that ``--models`` takes; the shipped weights are never written. A checkpoint lets an interrupted run resume.

The budget in minutes buys a fixed plan, worked out before anything runs from the number of frames and
what each part costs on a 2-core machine (``COSTS``, measured): how many corrupted copies of each frame,
how many generated frames mixed in, how many training steps. The same command on the same frames gives the
same model whatever the machine's load; a slower or busier machine takes longer, and says so, but never
trains less. An adapted model that does worse than the one it started from on the held-out frames is not
handed out: the folder gets the starting models back, and the card says why.
"""

from __future__ import annotations

import datetime as dt
import json
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from pydantic import Field

from d2sr.atomic import atomic_file, atomic_write, listed, record_manifest
from d2sr.config import Settings
from d2sr.contract.catalog import (
    DEFAULT_RECOVERY,
    DETECTOR,
    MASK_DETECTOR,
    PAD,
    THRESHOLD,
    WEIGHTS,
    detector_input,
)
from d2sr.errors import InputError
from d2sr.frames.overlap import processes
from d2sr.frames.png import decode_png
from d2sr.models.detector import MaskDetector
from d2sr.models.store import load_model, mask_logit, save_model, torch_device, write_card
from d2sr.models.store import threshold as read_threshold
from d2sr.sim.dataset import Synth, synth_sequence_frame
from d2sr.sim.families import wide_interference
from d2sr.train.data import Pool, Source
from d2sr.train.loop import deterministic, load_checkpoint, loss_fn, pick_as_recovered, recovered_sums

__all__ = [
    "COSTS",
    "MIN_FRAMES",
    "AdaptData",
    "Costs",
    "Plan",
    "adapt",
    "adapt_recordings",
    "check_resumable",
    "choose_threshold",
    "prepare",
    "split",
    "worse",
]

MIN_FRAMES = 50  # fewer clean frames than this cannot both train and hold out
HOLDOUT = 0.2
# Corrupted copies of each training frame (fresh draws of the generator); 4 -> 8: held-out RMSE 50 -> 39 cm.
VARIANTS = 8
HELD_VARIANTS = 2
SEED = 4_000_000  # interference seeds of adapt (apart from training, test and evaluation seeds)
REHEARSAL = 240  # generated frames mixed in (at most twice the user's training frames)
REHEARSAL_SEED = 500_000  # their seeds: training-side (below TEST_SEED), apart from the shipped models' sets
VISIBLE = 0.01  # the threshold keeps recall on held-out frames with at least this share of pixels hit
# Constant: one-cycle over the same steps adapted less (held-out recall 0.80 -> 0.78, 5% false alarms).
# Over 4,488 steps, held-out RMSE / mask F1 / detector recall: 3e-4 46.3 cm / 0.40 / 0.75, 6e-4 43.0 / 0.43 /
# 0.75, 1e-3 39.8 / 0.44 / 0.68; 6e-4 is the one no held-out figure is worse for.
LR = 6e-4
CROP = (256, 320)
TRAIN_SHARE = 0.5  # of the budget at least for training, when the frames allow (the rest prepares, judges)
PREPARING, JUDGING = "preparing the frames", "judging on the held-out frames"  # progress labels
MIN_STEPS = 20  # a budget too small for its frames still trains this much (and says it runs over)
Arr = np.ndarray
CHECKPOINT = "adapt-checkpoint.pt"


@dataclass
class AdaptData:
    scale: float
    train: list[np.ndarray]  # clean uint16 frames
    held: list[np.ndarray]
    # Each frame's predecessor in its recording (the frame itself for a recording's first): what a
    # temporal detector also sees.
    train_prev: list[np.ndarray] = field(default_factory=list)
    held_prev: list[np.ndarray] = field(default_factory=list)
    bad: list[np.ndarray] = field(default_factory=list)  # corrupted training frames
    bad_clean: list[np.ndarray] = field(default_factory=list)
    held_bad: list[np.ndarray] = field(default_factory=list)
    held_bad_clean: list[np.ndarray] = field(default_factory=list)
    labelled: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)  # frame, gt, mask
    rehearsal: list[Synth] = field(default_factory=list)  # generated frames (their own scales)
    variants: int = VARIANTS  # corrupted copies of each training frame

    def pool(self, frames: int = 1) -> Pool:
        """The training frames; ``frames=2`` for a temporal detector (each with its previous frame)."""

        def prev(v: list[np.ndarray]) -> list[np.ndarray] | None:
            return v if frames > 1 else None  # references, not copies: the corrupted copies share them

        n, g = len(self.train), self.rehearsal
        sources = [
            Source(self.train, self.train, None, self.scale, np.zeros(n, bool), prev(self.train_prev)),
            Source(self.bad, self.bad_clean, None, self.scale, np.ones(len(self.bad), bool),
                   prev(self.train_prev * self.variants)),
        ]  # fmt: skip
        if g:
            last = [x.clean if x.previous is None else x.previous for x in g]
            labels = np.array([bool(x.families) for x in g])
            scales = np.array([x.scale for x in g])
            sources.append(
                Source([x.frame for x in g], [x.clean for x in g], None, scales, labels, prev(last))
            )
        if self.labelled:
            f, c, m = (list(v) for v in zip(*self.labelled, strict=True))
            before = [f[k - 1] if k and f[k - 1].shape == x.shape else x for k, x in enumerate(f)]
            sources.append(Source(f, c, m, self.scale, np.array([x.any() for x in m]), prev(before)))
        return Pool(sources, frames, raw_previous=True)


@dataclass(frozen=True)
class Costs:
    """Seconds each part of adapt takes on a 2-core machine at 640x480, what turns a budget into a plan
    (``lab/adapt_costs.py`` on the shared D435 frames, 2-core Xeon, 2026-11-28: 7.0-9.2 steps a
    second, 0.066-0.071 s a corrupted copy, 0.19-0.21 s a generated frame; loading, judging 20-40 held-out
    copies and two exports 21-30 s, not growing with the copies at that size, so a small share a copy)."""

    step: float = 1 / 9.0  # one training step (batch 8, crops up to ``CROP``)
    corrupt: float = 0.07  # one corrupted copy of a frame (two worker processes)
    generate: float = 0.2  # one generated frame mixed in
    judge: float = 0.1  # one held-out corrupted copy judged (scores, masks, threshold curves)
    fixed: float = 25.0  # loading, judging's fixed part, two exports and the cards


COSTS = Costs()


@dataclass(frozen=True)
class Plan:
    """What a budget buys for a number of frames: corrupted copies per training and held-out frame,
    generated frames mixed in, training steps, and the seconds all of it should take (``COSTS``)."""

    variants: int
    held_variants: int
    rehearsal: int
    steps: int
    seconds: float

    @classmethod
    def of(cls, minutes: float, train: int, held: int, costs: Costs | None = None) -> Plan:
        """The most corrupted copies (up to ``VARIANTS``) that leave training ``TRAIN_SHARE`` of the budget
        (copies taught it more than steps: 4 -> 8 copies, held-out RMSE 50 -> 39 cm), then the steps the
        rest of the budget buys; at least one copy and ``MIN_STEPS`` steps, whatever the budget."""
        budget, costs = minutes * 60, costs or COSTS

        def rehearsal(v: int) -> int:
            return min(REHEARSAL, 2 * train * v // VARIANTS)

        def overhead(v: int) -> float:
            judged = held * HELD_VARIANTS
            return (costs.fixed + costs.corrupt * (train * v + judged) + costs.generate * rehearsal(v)
                    + costs.judge * judged)  # fmt: skip

        v = next((v for v in range(VARIANTS, 0, -1) if overhead(v) <= (1 - TRAIN_SHARE) * budget), 1)
        steps = max(MIN_STEPS, round((budget - overhead(v)) / costs.step))
        return cls(v, HELD_VARIANTS, rehearsal(v), steps, round(overhead(v) + steps * costs.step, 1))

    def key(self) -> dict[str, int]:
        """What decides the model (a run resumes only under the same)."""
        return {"variants": self.variants, "rehearsal": self.rehearsal, "steps": self.steps}


def _corrupt(job: tuple[np.ndarray, float, int]) -> np.ndarray:
    frame, scale, seed = job
    return wide_interference(frame, scale, seed)[0]


def _generated(seed: int) -> Synth:
    return synth_sequence_frame(seed, bool(seed % 2), previous=True)


def labelled_frames(folders: list[Path]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(interfered frame, ground-truth depth, mask) of every frame in folders ``d2sr label`` wrote: each
    holds its interfered frames (``interfered/``) beside their truth, so nothing outside it is read."""
    from d2sr.frames import open_frames
    from d2sr.frames.layout import LABELS, FrameFolder

    pairs: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for folder in folders:
        if not (folder / "label.json").is_file():
            raise InputError(f"{folder}: not a d2sr label output (no label.json)")
        if not (folder / LABELS["interfered"]).is_dir():
            raise InputError(f"{folder}: made by an older d2sr label (no interfered/); run d2sr label again")
        frames = list(open_frames(folder / LABELS["interfered"]))
        stored = FrameFolder(folder, LABELS, create=False)
        for f in frames:
            if not stored.has(f.name):
                raise InputError(f"{folder}: frame {f.name} has no mask or truth beside it")
            gt = decode_png(stored.path("depth", f.name).read_bytes(), f"{folder}/depth/{f.name}")
            mask = decode_png(stored.path("masks", f.name).read_bytes(), f"{folder}/masks/{f.name}", np.uint8)
            if not f.depth.shape == gt.shape == mask.shape:
                raise InputError(f"{folder}: frame {f.name}'s truth or mask is of another size")
            pairs.append((f.depth, gt, mask > 0))
    return pairs


def check_resumable(out: Path, plan: Plan) -> None:
    """Refuse, before any work, an ``out`` whose adapt run was planned otherwise (another budget or frames):
    resumed, the result would be neither run."""
    ckpt = out / f"recovery-{CHECKPOINT}"
    if ckpt.is_file() and load_checkpoint(ckpt).get("plan") != plan.key():
        raise InputError(
            f"{out} holds an adapt run of another budget (minutes), frames or version; name a new folder",
            "out",
        )


def split(recordings: list[list[np.ndarray]]) -> tuple[int, int]:
    """(training frames, held-out frames) ``prepare`` will take from ``recordings``."""
    train = held = 0
    for r in recordings:
        cut = len(r) - max(1, round(HOLDOUT * len(r)))
        for k, f in enumerate(r):
            if f.any():
                train, held = (train + 1, held) if k < cut else (train, held + 1)
    return train, held


def prepare(
    recordings: list[list[np.ndarray]],
    scale: float,
    labelled: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
    workers: int = 2,
    plan: Plan | None = None,
    tick: Callable[[str, int, int], None] | None = None,
) -> AdaptData:
    """Split each recording by time (the last ``HOLDOUT`` held out), check the frames, and draw the
    corrupted copies ``plan`` asks for (``VARIANTS`` per frame by default; in ``workers`` processes),
    ``tick(what, done, total)`` telling how far it is."""
    frames = [f for r in recordings for f in r]
    if len(frames) < MIN_FRAMES:
        raise InputError(f"adapt needs at least {MIN_FRAMES} clean frames, got {len(frames)}")
    shapes = {f.shape for f in frames}
    if len(shapes) > 1:
        raise InputError(f"the clean frames mix sizes ({', '.join(f'{w}x{h}' for h, w in sorted(shapes))})")
    empty = sum(not f.any() for f in frames)
    if empty == len(frames):
        raise InputError("the clean frames hold no valid depth")
    data = AdaptData(scale, [], [], labelled=list(labelled or []))
    for r in recordings:
        cut = len(r) - max(1, round(HOLDOUT * len(r)))
        for k, f in enumerate(r):
            if f.any():  # with the frame delivered before it (a recording's first is its own)
                (data.train if k < cut else data.held).append(f)
                (data.train_prev if k < cut else data.held_prev).append(r[k - 1] if k else f)
    train, held = data.train, data.held
    variants = VARIANTS if plan is None else plan.variants
    data.variants = variants
    jobs = [(f, scale, SEED + i) for i, f in enumerate(train * variants)]
    held_jobs = [(f, scale, SEED + 500_000 + i) for i, f in enumerate(held * HELD_VARIANTS)]
    rehearsal = min(REHEARSAL, 2 * len(train)) if plan is None else plan.rehearsal
    seeds = range(REHEARSAL_SEED, REHEARSAL_SEED + rehearsal)
    total, done = len(jobs) + len(held_jobs) + len(seeds), 0

    def each(results: Iterator[Any]) -> list[Any]:
        nonlocal done
        got = []
        for r in results:
            got.append(r)
            done += 1
            if tick and done % 8 == 0:
                tick(PREPARING, done, total)
        return got

    with processes(max(workers, 1)) as ex:
        data.bad = each(ex.map(_corrupt, jobs, chunksize=8))
        data.held_bad = each(ex.map(_corrupt, held_jobs, chunksize=8))
        data.rehearsal = each(ex.map(_generated, seeds, chunksize=8))
    if tick:
        tick(PREPARING, total, total)
    data.bad_clean = [j[0] for j in jobs]
    data.held_bad_clean = [j[0] for j in held_jobs]
    return data


def _crop(shape: tuple[int, ...], most: tuple[int, int]) -> tuple[int, int]:
    """Training crops: at most ``most``, within the user's frame, in whole strides (the generated frames
    mixed in are 640x480, and one batch takes one size)."""
    return min(shape[0], most[0]) // PAD * PAD, min(shape[1], most[1]) // PAD * PAD


def _visible(data: AdaptData) -> np.ndarray:
    """Per held-out corrupted frame: at least ``VISIBLE`` of its valid pixels hit."""
    pairs = zip(data.held_bad, data.held_bad_clean, strict=True)
    return np.array([(b != c).sum() >= VISIBLE * max((c > 0).sum(), 1) for b, c in pairs], bool)


def choose_threshold(
    clean: Arr, bad: Arr, visible: Arr, false_alarm: float, recall: float = 0.9, floor: float = 0.1
) -> float:
    """The detector threshold from held-out scores. ``lo``: the clean frames' score at the false-alarm
    target; ``hi``: the score that keeps ``recall`` of the visibly corrupted frames. When they separate, the
    middle in logit space: the widest margin both ways, since the user's later frames drift from the
    held-out ones (a threshold just above the held-out clean scores flagged a fifth of a D435's later
    frames). Otherwise the false-alarm target wins. Never below ``floor``."""
    if not len(clean):
        return THRESHOLD
    lo = float(np.quantile(clean, 1 - false_alarm)) + 0.02
    hits = bad[visible] if visible.any() else bad
    hi = float(np.quantile(hits, 1 - recall)) if len(hits) else lo
    if hi > lo:
        a, b = np.clip([lo, hi], 1e-4, 1 - 1e-4)
        mid = (np.log(a / (1 - a)) + np.log(b / (1 - b))) / 2
        return float(np.clip(1 / (1 + np.exp(-mid)), floor, 0.99))
    return float(np.clip(lo, floor, 0.99))


def _metres(frames: list[np.ndarray], scale: float) -> list[np.ndarray]:
    return [f.astype(np.float32)[None, None] / np.float32(scale) for f in frames]


def _scores(
    model: torch.nn.Module,
    frames: list[np.ndarray],
    prev: list[np.ndarray],
    scale: float,
    device: torch.device,
) -> Arr:
    """Detector scores of ``frames``; a temporal detector also sees each one's previous frame ``prev``."""
    model.eval()
    out = []
    n = int(getattr(model, "frames", 1))
    with torch.inference_mode():
        for x, p in zip(_metres(frames, scale), _metres(prev, scale), strict=True):
            x = detector_input(x[:, 0], p[:, 0], n)
            out.append(float(torch.sigmoid(model(torch.from_numpy(x).to(device)))[0]))
    return np.array(out)


def _detector_figures(clean: np.ndarray, bad: np.ndarray, threshold: float) -> dict:
    return {
        "threshold": round(threshold, 4),
        "false_alarms": round(float((clean >= threshold).mean()), 4),
        "recall": round(float((bad >= threshold).mean()), 4),
    }


def _held_items(data: AdaptData) -> list[tuple[list[np.ndarray], np.ndarray, float]]:
    return [([f], c, data.scale) for f, c in zip(data.held_bad, data.held_bad_clean, strict=True)]


@dataclass
class _Phase:
    name: str
    model: torch.nn.Module
    task: str
    steps: int
    plan: dict[str, int]
    batch: int
    crop: tuple[int, int] | None
    clean_share: float


def _fit(
    phase: _Phase,
    pool: Pool,
    out: Path,
    device: torch.device,
    tick: Callable[[str, int, int], None] | None,
) -> dict:
    """Fine-tune for ``phase.steps`` (over every resumed part), checkpointing as it goes. Time decides only
    when a checkpoint is written, never what is trained."""
    ckpt = out / f"{phase.name}-{CHECKPOINT}"
    deterministic(SEED)
    model = phase.model.to(device)
    opt = torch.optim.AdamW(model.parameters(), lr=LR, weight_decay=1e-4)
    rng = np.random.default_rng([SEED, len(phase.name)])
    spent, steps, losses = 0.0, 0, []
    if ckpt.is_file():
        state = load_checkpoint(ckpt)
        if state.get("plan") != phase.plan:  # resumed, it would be neither run
            raise InputError(
                f"{out} holds an adapt run of another budget (minutes), frames or version; name a new folder",
                "out",
            )
        try:
            model.load_state_dict(state["model"])
            opt.load_state_dict(state["opt"])
            rng.bit_generator.state = state["rng"]
            spent, steps, losses = float(state["seconds"]), int(state["steps"]), list(state["losses"])
        except (KeyError, RuntimeError, ValueError, TypeError) as exc:
            raise InputError(
                f"{ckpt}: a damaged checkpoint ({type(exc).__name__}); name a new output folder", "out"
            ) from None
    model.train()
    t0, last = time.perf_counter(), time.perf_counter()

    def elapsed() -> float:
        return spent + time.perf_counter() - t0

    while steps < phase.steps:
        b = pool.batch(rng, phase.batch, phase.crop, phase.clean_share)
        loss = loss_fn(model, phase.task, b, device)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        steps += 1
        losses.append(float(loss.item()))
        if tick:
            tick(f"training the {phase.name} model", steps, phase.steps)
        if time.perf_counter() - last > 30:  # a checkpoint every half minute
            _save(ckpt, model, opt, rng, elapsed(), steps, losses, phase.plan)
            last = time.perf_counter()
    total = elapsed()
    _save(ckpt, model, opt, rng, total, steps, losses, phase.plan)
    last_loss = float(np.mean(losses[-50:])) if losses else float("nan")
    return {"steps": steps, "seconds": round(total, 1), "final_loss": round(last_loss, 5)}


def _save(path: Path, model: torch.nn.Module, opt: torch.optim.Optimizer, rng: np.random.Generator,
          seconds: float, steps: int, losses: list[float], plan: dict[str, int]) -> None:  # fmt: skip
    state = {"model": model.state_dict(), "opt": opt.state_dict(), "rng": rng.bit_generator.state,
             "seconds": seconds, "steps": steps, "losses": losses, "plan": plan}  # fmt: skip
    with atomic_file(path) as tmp:
        torch.save(state, tmp)


WORSE_BY = 0.005  # a held-out figure this much lower (mask F1, detector recall) is worse, not noise


def worse(held_out: dict[str, Any]) -> str | None:
    """Why the adapted models are worse than the ones they started from on the held-out frames (lower mask
    F1, or lower detector recall without fewer false alarms), or None."""
    d, r = held_out["detector"], held_out["recovery"]
    if r["adapted"]["mask_f1"] < r["shipped"]["mask_f1"] - WORSE_BY:
        return f"mask F1 {r['shipped']['mask_f1']:.2f} -> {r['adapted']['mask_f1']:.2f}"
    recall = (d["shipped"]["recall"], d["adapted"]["recall"])
    alarms = (d["shipped"]["false_alarms"], d["adapted"]["false_alarms"])
    if recall[1] < recall[0] - WORSE_BY and alarms[1] >= alarms[0]:
        return f"detector recall {recall[0]:.1%} -> {recall[1]:.1%} at {alarms[1]:.1%} false alarms"
    return None


def adapt(
    data: AdaptData,
    out: Path,
    plan: Plan,
    false_alarm: float,
    command: str,
    weights: Path = WEIGHTS,
    tick: Callable[[str, int, int], None] | None = None,
) -> dict:
    """Fine-tune as ``plan`` says, choose thresholds on the held-out frames, write ``out`` (weights, ONNX,
    card). When the adapted models do worse on the held-out frames than the ones in ``weights``
    (``worse``), ``out`` gets those instead and the card says why."""
    from d2sr.models.onnx.export import export

    t_start = time.perf_counter()
    device = torch_device()
    out.mkdir(parents=True, exist_ok=True)
    # detector-*: what 0.7.0 left in a folder (it fine-tuned the frame CNN), still a file d2sr made
    record_manifest(out, [f"detector-{CHECKPOINT}", f"recovery-{CHECKPOINT}"])
    shipped_det, _ = load_model(weights / f"{DETECTOR}.safetensors")
    rec, _ = load_model(weights / f"{DEFAULT_RECOVERY}.safetensors")
    shipped_logit = mask_logit(weights / f"{DEFAULT_RECOVERY}.safetensors")
    held_bad_prev = data.held_prev * HELD_VARIANTS  # the corrupted copies' frames before (clean)

    def scored(det: torch.nn.Module) -> tuple[Arr, Arr]:
        det = det.to(device)
        return (_scores(det, data.held, data.held_prev, data.scale, device),
                _scores(det, data.held_bad, held_bad_prev, data.scale, device))  # fmt: skip

    before = _detector_figures(*scored(shipped_det), read_threshold(weights / f"{DETECTOR}.safetensors"))
    rec = rec.to(device)
    mask_before = recovered_sums(rec, _held_items(data), shipped_logit).result()
    crop = _crop(data.train[0].shape, CROP)
    phase = _Phase("recovery", rec, "recovery", plan.steps, plan.key(), 8, crop, 0.3)
    fits = {phase.name: _fit(phase, data.pool(int(getattr(rec, "frames", 1))), out, device, tick)}
    if tick:
        tick(JUDGING, 0, 3)
    logit, rule, _, mask_after = pick_as_recovered(rec, _held_items(data))
    if tick:
        tick(JUDGING, 1, 3)
    det = MaskDetector(rec, logit)  # the detector: this model's mask, at the repair threshold just chosen
    clean_s, bad_s = scored(det)
    # Not below 0.5 (the model would repair REF_SHARE of the returns): 20-odd held-out clean frames do not
    # show how far a room's later views drift; the middle rule alone let 4 of the D435's later clean frames
    # through from outside (repairing 0.3-0.4% of their returns), while visibly hit frames score >= 0.5.
    threshold = choose_threshold(clean_s, bad_s, _visible(data), false_alarm, floor=0.5)
    after = _detector_figures(clean_s, bad_s, threshold)
    save_model(det, MASK_DETECTOR, out / f"{DETECTOR}.safetensors", threshold=threshold)
    save_model(rec, DEFAULT_RECOVERY, out / f"{DEFAULT_RECOVERY}.safetensors", mask_logit=logit)
    for name in (DETECTOR, DEFAULT_RECOVERY):
        export(out / f"{name}.safetensors", out / f"{name}.onnx")
    if tick:
        tick(JUDGING, 3, 3)

    def mask_row(r: dict) -> dict:
        return {k: round(float(r[k]), 4) for k in ("rmse_cm", "mask_f1", "clean_changed")}

    held_out = {
        "detector": {"shipped": before, "adapted": after, "target_false_alarms": false_alarm},
        "recovery": {
            "shipped": mask_row(mask_before) | {"mask_logit": shipped_logit},
            "adapted": mask_row(mask_after) | {"mask_logit": logit, "rule": rule},
        },
    }
    card = {
        "data": {
            "clean_frames": len(data.train) + len(data.held),
            "trained_on": len(data.train),
            "held_out": len(data.held),
            "labelled_frames": len(data.labelled),
            "depth_scale": data.scale,
            "corrupted_copies": {"train": data.variants, "held_out": HELD_VARIANTS},
        },
        "command": command,
        "started_from": str(weights),
        "plan": {
            "copies": plan.variants,
            "generated": plan.rehearsal,
            "steps": plan.steps,
            "minutes_on_2_cores": round(plan.seconds / 60, 2),
        },
        "training": fits,
        "held_out": held_out,
        "minutes": round((time.perf_counter() - t_start) / 60, 2),
        "date": dt.date.today().isoformat(),
    }
    summary = {
        DETECTOR: f"{MASK_DETECTOR}, made by d2sr adapt: the share of a frame's returns that "
        f"{DEFAULT_RECOVERY} in this folder would repair (mask logit > {logit:g}); flags at threshold "
        f"{threshold:.3f} (false-alarm target {false_alarm:.0%} on held-out clean frames, never below 0.5)",
        DEFAULT_RECOVERY: f"{DEFAULT_RECOVERY} fine-tuned by d2sr adapt from {weights} on this sensor's "
        f"clean frames and generated interference; mask logit {logit:g} ({rule})",
    }
    limits = (
        f"held-out figures: the generator's interference on the last {HOLDOUT:.0%} of each clean recording; "
        "real interference, and the room's later views, can differ"
    )
    for name, kind in ((DETECTOR, "detector"), (DEFAULT_RECOVERY, "recovery")):
        write_card(out / f"{name}.safetensors", model=name, summary=summary[name], data=card["data"],
                   command=command, training=fits, metrics=held_out[kind], date=card["date"],
                   limits=limits, adapt=card)  # fmt: skip
    ext = (".safetensors", ".onnx", ".card.json", ".md")
    files = [f"{n}{e}" for n in (DETECTOR, DEFAULT_RECOVERY) for e in ext]
    why = worse(held_out)
    card["kept"] = None if why is None else {"models": str(weights), "why": why}
    if why is not None:  # the folder holds what it started from, so --models OUT is never a step back
        started = sorted(
            f.name for n in (DETECTOR, DEFAULT_RECOVERY) for f in weights.glob(f"{n}.*") if f.is_file()
        )
        for f in started:
            with atomic_file(out / f) as tmp:
                shutil.copyfile(weights / f, tmp)
        files = sorted(set(files) | set(started))
    mine = listed(out)
    for old in [p for n in (DETECTOR, DEFAULT_RECOVERY) for p in out.glob(f"{n}.*")]:
        if old.name not in files and old.name in mine:  # what an earlier run here wrote and this one did not
            old.unlink()
    atomic_write(out / "adapt.json", json.dumps(card, indent=1) + "\n")
    record_manifest(out, [*files, "adapt.json"])
    return card


class AdaptSettings(Settings):
    """How ``d2sr adapt`` adapts: about ``minutes`` of work on 2 cores, the detector's false alarms held to
    ``false_alarm`` of clean frames, ``labelled`` folders of frames with their interference marked (``d2sr
    label``), starting from the models in ``models`` [the shipped ones]."""

    minutes: float = Field(10.0, gt=0, allow_inf_nan=False)
    false_alarm: float = Field(0.01, gt=0, lt=1)
    labelled: list[Path] = Field(default_factory=list)
    models: Path = WEIGHTS


def adapt_recordings(
    recordings: list[list[np.ndarray]],
    scale: float,
    out: Path,
    settings: AdaptSettings | None = None,
    command: str = "",
    say: Callable[[str], object] = print,
) -> dict:
    """``d2sr adapt`` from clean recordings (uint16 frames, ``scale`` units per metre): plan the budget, say
    the plan, prepare, fit and judge with a progress bar, say the held-out figures (and a kept start)."""
    from d2sr.ui import progress_bar, warn

    a = settings if settings is not None else AdaptSettings()
    minutes, false_alarm, labelled, weights = a.minutes, a.false_alarm, a.labelled, a.models
    t0 = time.perf_counter()
    pairs = labelled_frames(labelled)
    plan = Plan.of(minutes, *split(recordings))
    check_resumable(out, plan)
    over = (
        ""
        if plan.seconds <= minutes * 60 * 1.05
        else f" (over the {minutes:g} minutes asked: so many frames)"
    )
    say(f"plan: {plan.variants} corrupted copies of each frame, {plan.rehearsal} generated frames, "
        f"{plan.steps} training steps; about {plan.seconds / 60:.1f} min on 2 cores{over}")  # fmt: skip
    with progress_bar() as bar:
        tasks: dict[str, Any] = {}

        def tick(name: str, done: int, total: int) -> None:
            if name not in tasks:
                tasks[name] = bar.add_task(name, total=total)
            bar.update(tasks[name], completed=done, total=total)

        data = prepare(recordings, scale, pairs, plan=plan, tick=tick)
        card = adapt(data, out, plan, false_alarm, command, weights, tick)
    kept = card["kept"]
    if kept:
        warn(f"adapting did not help on your held-out frames ({kept['why']}): {out} holds the models it "
             f"started from, {kept['models']}")  # fmt: skip
    d, r = card["held_out"]["detector"], card["held_out"]["recovery"]
    say(f"held out ({card['data']['held_out']} clean frames, x{HELD_VARIANTS} corrupted): false alarms "
        f"{d['shipped']['false_alarms']:.1%} -> {d['adapted']['false_alarms']:.1%}, recall "
        f"{d['shipped']['recall']:.1%} -> {d['adapted']['recall']:.1%}, "
        f"mask F1 {r['shipped']['mask_f1']:.2f} -> {r['adapted']['mask_f1']:.2f}")  # fmt: skip
    took = f"{out} in {(time.perf_counter() - t0) / 60:.1f} min (planned {plan.seconds / 60:.1f} on 2 cores)"
    say(f"{took}: the models it started from" if kept else f"{took}; use it with --models {out}")
    return card
