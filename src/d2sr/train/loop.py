"""``d2sr train``: one loop for the detector and the recovery UNets; single process or torchrun (DDP)."""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import json
import os
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch
import torch.distributed as tdist
import torch.nn.functional as F
from torch import nn

from d2sr.atomic import atomic_file, atomic_write, record_manifest
from d2sr.contract.metrics import RepairSums, threshold_curve
from d2sr.contract.repair import guard, refill, repair_frame
from d2sr.errors import ConfigError, InputError
from d2sr.models.inference import TorchBackend
from d2sr.models.registry import build, describe, own_passes
from d2sr.models.store import mask_logit, read_card, save_model, torch_device, warm_start, write_card
from d2sr.sim.dataset import VERSION
from d2sr.sim.rooms import SensorModel
from d2sr.train.config import VALIDATION_FRAMES, TrainSettings
from d2sr.train.data import Batch, Pool
from d2sr.ui import console, progress_bar

__all__ = [
    "MASK_LOGITS",
    "MAX_CLEAN_CHANGED",
    "as_second_pass",
    "choose_mask_logit",
    "deterministic",
    "loss_fn",
    "mask_sums",
    "pick_as_recovered",
    "pick_mask_logit",
    "recovered_sums",
    "train",
]

CHECKPOINT = "checkpoint.pt"
MASK_LOGITS = tuple(float(t) for t in np.arange(3.0, -6.01, -0.25))  # candidate mask thresholds (logits)
MAX_CLEAN_CHANGED = 0.01  # half the 2% bar: room for real frames to differ from generated ones
MISS_CAP_M = 2.0  # mask_error_weight: errors beyond this weigh as this (a dropout far away is not worth more)


@contextlib.contextmanager
def _distributed() -> Iterator[tuple[int, int]]:
    """(rank, world size). Under torchrun this joins the process group (gloo on CPU, nccl on CUDA)."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world == 1:
        yield 0, 1
        return
    tdist.init_process_group("nccl" if torch.cuda.is_available() else "gloo")
    try:
        yield tdist.get_rank(), world
    finally:
        tdist.destroy_process_group()


def loss_fn(
    model: nn.Module,
    task: str,
    b: Batch,
    device: torch.device,
    mask_weight: float = 3.0,
    dice: float = 1.0,
    error_weight: float = 0.0,
    teacher_weight: float = 0.0,
) -> torch.Tensor:
    x = torch.from_numpy(b.x).to(device)
    if task == "detector":
        return F.binary_cross_entropy_with_logits(model(x), torch.from_numpy(b.label).to(device))
    y, m = torch.from_numpy(b.y).to(device), torch.from_numpy(b.m).to(device)
    logit, pred = model(x)
    soft = torch.sigmoid(logit)
    out = pred * soft + x[:, :1] * (1 - soft)  # the paper's composition, soft while training
    # Depth is scored only where the ground truth has a return (as RMSE is). Scoring the no-return pixels
    # too taught the depth head to pull ambiguous zeros towards 0 and the mask head to leave them alone:
    # a real surface read as "no return" costs metres, a no-return read as a surface is not a depth error.
    valid = (y > 0).to(y.dtype)
    depth = (F.smooth_l1_loss(out, y, beta=0.05, reduction="none") * valid).mean()
    # The depth head also learns on every truly interfered pixel, whatever the mask head says.
    mv = m * valid
    inside = (F.smooth_l1_loss(pred, y, beta=0.05, reduction="none") * mv).sum() / mv.sum().clamp(min=1)
    miss = _miss_cost(x, y, m, error_weight)
    mask = mask_weight * F.binary_cross_entropy_with_logits(logit, m, weight=miss)
    if b.taught is not None and teacher_weight:
        # The teacher's repair as a second target: what two passes of a larger model find, one pass learns.
        tm, ty = (torch.from_numpy(t).to(device) for t in b.taught)
        mask = mask + teacher_weight * mask_weight * F.binary_cross_entropy_with_logits(logit, tm)
        tv = tm * (ty > 0).to(ty.dtype)
        taught = (F.smooth_l1_loss(pred, ty, beta=0.05, reduction="none") * tv).sum() / tv.sum().clamp(min=1)
        inside = inside + teacher_weight * taught
    if dice:
        # Soft F1 over the batch: BCE alone leaves zeros inside a pattern near 0.5 (a natural no-return
        # and a dropout look alike pixel by pixel); the F1 term pays for deciding them from the context.
        mask = mask + dice * (1 - 2 * (soft * m).sum() / (soft.sum() + m.sum()).clamp(min=1))
    return mask + 10 * depth + inside


def _miss_cost(x: torch.Tensor, y: torch.Tensor, m: torch.Tensor, k: float) -> torch.Tensor | None:
    """Per-pixel weights of the mask's BCE (``TrainSettings.mask_error_weight``): an interfered pixel weighs
    1 + ``k`` x its depth error (metres, where the truth returns; capped), rescaled so that the interfered
    pixels of the batch weigh 1 on average; clean pixels weigh 1. A missed pixel costs RMSE by its error,
    so the mask learns first to catch what costs the most; the mean keeps the clean/interfered balance of
    an unweighted run. None for k = 0 (every pixel alike)."""
    if not k:
        return None
    err = ((x[:, :1] - y).abs() * (y > 0).to(y.dtype)).clamp(max=MISS_CAP_M)
    w = (1 + k * err) * m
    w = w * (m.sum() / w.sum().clamp(min=1e-6))
    return w + (1 - m)


def as_second_pass(
    model: nn.Module, b: Batch, share: float, logit: float, rng: np.random.Generator, device: torch.device
) -> Batch:
    """``b`` with about ``share`` of its interfered frames as ``recover``'s second pass sees them: the frame
    with the model's own guarded first repair (mask threshold ``logit``) filled in
    (``d2sr.contract.recover_passes``). Targets stay the same: the clean frame and the true mask."""
    pick = np.flatnonzero((b.label > 0) & (rng.random(len(b.label)) < share))
    if pick.size == 0:
        return b
    was = model.training
    model.eval()
    with torch.inference_mode():
        lg, pred = (t[:, 0].cpu().numpy() for t in model(torch.from_numpy(b.x[pick]).to(device)))
    model.train(was)
    x = b.x.copy()
    for k, j in enumerate(pick):
        x[j, 0] = refill(x[j, 0], pred[k], lg[k] > logit)[0]
    return dataclasses.replace(b, x=x)


def taught(teacher: TorchBackend, b: Batch) -> Batch:
    """``b`` with its teacher's repair (``Batch.taught``): the mask and depth ``recover`` would write with the
    teacher (its passes and guard; its depth where it repairs, the frame's elsewhere). Clean frames take
    the truth, which a good teacher leaves them at (half the teacher's cost)."""
    masks, depths = b.m.copy(), b.y.copy()
    hit = np.flatnonzero(b.label > 0)
    if hit.size:
        pred, mask = teacher.recover(b.x[hit, 0])
        for k, j in enumerate(hit):
            x = b.x[j, 0]
            p, kept = guard(x, pred[k], mask[k])
            masks[j, 0] = kept
            depths[j, 0] = np.where(kept, np.maximum(p, 0), x)
    return dataclasses.replace(b, taught=(masks, depths))


def load_checkpoint(path: Path) -> dict[str, Any]:
    """A training checkpoint d2sr wrote: tensors and plain values only (``weights_only``), so a file planted
    in an output folder cannot run code; anything else is refused with one line."""
    if path.is_symlink() or not path.is_file():
        raise InputError(f"{path}: a checkpoint must be a plain file, not a link or a folder")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch's unpickler raises many kinds on a foreign or damaged file
        why = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else type(exc).__name__
        raise InputError(
            f"{path}: not a checkpoint d2sr wrote (it may hold only tensors and plain values): {why}"
        ) from None
    if not isinstance(state, dict):
        raise InputError(f"{path}: not a checkpoint d2sr wrote (not a dictionary)")
    return state


class _Done(NamedTuple):
    """How far training has come: steps, minutes over every resumed part, and the losses so far."""

    step: int
    minutes: float
    losses: list[float]


def _save_checkpoint(
    path: Path,
    model: nn.Module,
    opt: torch.optim.Optimizer,
    sched: torch.optim.lr_scheduler.LRScheduler,
    rng: np.random.Generator,
    cfg: TrainSettings,
    done: _Done,
) -> None:
    step, minutes, losses = done
    state = {
        "minutes": minutes,  # training time over every resumed part
        "losses": losses,
        "model": model.state_dict(),
        "opt": opt.state_dict(),
        "sched": sched.state_dict(),
        "step": step,
        "rng": rng.bit_generator.state,
        "torch_rng": torch.get_rng_state(),
        "config": cfg.model_dump(mode="json"),
    }
    with atomic_file(path) as tmp:
        torch.save(state, tmp)


def deterministic(seed: int) -> None:
    """At one seed and one thread count, one result: torch's deterministic kernels, its generator seeded
    (the data's order comes from numpy generators seeded apart)."""
    torch.use_deterministic_algorithms(True, warn_only=True)
    torch.manual_seed(seed)


def train(cfg: TrainSettings, out: Path, command: str = "", progress: bool = True) -> dict:
    """Train, checkpoint to ``out/checkpoint.pt`` (resumed when present and of the same config), and write
    ``out/<model>.safetensors`` with its model card. Returns the training summary."""
    with _distributed() as (rank, world):
        device = torch_device()
        if device.type == "cpu":
            torch.set_num_threads(max(1, (os.cpu_count() or 1) // world))
        deterministic(cfg.seed)
        # Rank 0 generates the data set (if it is not cached yet); the others wait, then open it.
        if world > 1 and rank:
            tdist.barrier()
        model = build(cfg.model)
        frames = int(getattr(model, "frames", 1))
        pool = Pool.from_config(cfg, progress and rank == 0, frames)
        if world > 1 and rank == 0:
            tdist.barrier()
        out.mkdir(parents=True, exist_ok=True)  # only once the data opened: bad input leaves nothing
        if rank == 0:  # the run folder is d2sr's: a later run may resume it, --overwrite replace it
            record_manifest(out, [CHECKPOINT])
        if cfg.init is not None:
            counts = warm_start(model, cfg.init)
            if rank == 0:
                console.print(f"started from {cfg.init}: {counts}")
        model = model.to(device)
        core = model
        if world > 1:
            model = nn.parallel.DistributedDataParallel(model)
        opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, cfg.lr, total_steps=cfg.steps, pct_start=0.05)
        rng = np.random.default_rng([cfg.seed, rank])
        start, before = 0, 0.0
        losses: list[float] = []
        ckpt = out / CHECKPOINT
        if ckpt.is_file():
            state = load_checkpoint(ckpt)
            saved = state.get("config")
            if isinstance(saved, dict) and _same_run(saved, cfg):
                try:
                    core.load_state_dict(state["model"])
                    opt.load_state_dict(state["opt"])
                    sched.load_state_dict(state["sched"])
                    rng.bit_generator.state = state["rng"]
                    torch.set_rng_state(state["torch_rng"])
                    start = int(state["step"])
                except (KeyError, RuntimeError, ValueError, TypeError) as exc:
                    raise InputError(
                        f"{ckpt}: a damaged checkpoint ({type(exc).__name__}); name a new output folder",
                        "out",
                    ) from None
                kept_minutes, kept_losses = state.get("minutes"), state.get("losses")
                if kept_minutes is None or kept_losses is None:  # a checkpoint from before these were kept
                    done_card = read_card(out / f"{cfg.model}.safetensors").get("training", {})
                    old = out / "loss.json"
                    kept_minutes = float(done_card.get("minutes", 0.0))
                    kept_losses = json.loads(old.read_text()) if old.is_file() else []
                before, losses = float(kept_minutes), [float(x) for x in kept_losses]
                if rank == 0:
                    console.print(f"resuming from step {start}")
            elif rank == 0:
                console.print(f"{ckpt} is from another config: starting afresh")
        crop = (cfg.crop[0], cfg.crop[1]) if cfg.task == "recovery" else None
        share = cfg.clean_share if cfg.task == "recovery" else 0.5
        second = cfg.second_pass if cfg.task == "recovery" else 0.0
        # The second pass's inputs are made at the threshold the model starts with (its own, or 0).
        pass_logit = mask_logit(cfg.init) if cfg.init is not None else 0.0
        teacher = TorchBackend(None, cfg.teacher) if cfg.teacher is not None else None
        t0, stopped, done = time.perf_counter(), False, start
        bar = progress_bar() if progress and rank == 0 else contextlib.nullcontext()
        with bar as pb:
            task = pb.add_task(f"training {cfg.model}", total=cfg.steps, completed=start) if pb else None
            model.train()
            for step in range(start, cfg.steps):
                b = pool.batch(rng, cfg.batch, crop, share)
                if second:
                    b = as_second_pass(core, b, second, pass_logit, rng, device)
                if teacher is not None:
                    b = taught(teacher, b)
                loss = loss_fn(
                    model,
                    cfg.task,
                    b,
                    device,
                    cfg.mask_weight,
                    cfg.dice,
                    cfg.mask_error_weight,
                    cfg.teacher_weight,
                )
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                sched.step()
                losses.append(loss.item())
                if pb is not None and task is not None:
                    pb.update(
                        task, advance=1, description=f"training {cfg.model} loss {np.mean(losses[-50:]):.4f}"
                    )
                done = step + 1
                over = cfg.time_limit_min and time.perf_counter() - t0 > cfg.time_limit_min * 60
                if rank == 0 and (done % cfg.checkpoint_every == 0 or done == cfg.steps or over):
                    spent = before + (time.perf_counter() - t0) / 60
                    _save_checkpoint(ckpt, core, opt, sched, rng, cfg, _Done(done, spent, losses))
                if over:
                    stopped = True
                    break
        minutes = before + (time.perf_counter() - t0) / 60
        summary = {
            "steps": done,
            "stopped_early": stopped,
            "minutes": round(minutes, 2),
            "processes": world,
            "device": device.type,
            "final_loss": round(float(np.mean(losses[-100:])), 5) if losses else None,
            "architecture": describe(core),
        }
        if rank == 0:
            weights = out / f"{cfg.model}.safetensors"
            threshold = None
            if cfg.task == "recovery":
                threshold = choose_mask_logit(
                    core, cfg.cache, progress, cfg.validation, cfg.gate_previous, cfg.sensor_model()
                )
                summary["mask_threshold"] = threshold
            save_model(core, cfg.model, weights, threshold["mask_logit"] if threshold else None)
            atomic_write(out / "loss.json", json.dumps(losses))
            write_card(
                weights,
                model=cfg.model,
                summary=_SUMMARY[cfg.task],
                data=_data_line(cfg, frames),
                command=command or f"d2sr train {cfg.task} --config <config.toml>",
                training=summary | {"config": cfg.model_dump(mode="json")},
                **({"started_from": lineage(cfg.init)} if cfg.init is not None else {}),
                date=dt.date.today().isoformat(),
            )
            record_manifest(out, [weights.name, f"{cfg.model}.card.json", f"{cfg.model}.md", "loss.json"])
        return summary


# Settings that do not change the trained weights: a run resumes across changes to them.
NOT_TRAINING = ("validation", "time_limit_min", "checkpoint_every")


def _same_run(saved: dict, cfg: TrainSettings) -> bool:
    now = cfg.model_dump(mode="json")
    return all(saved.get(k) == v for k, v in now.items() if k not in NOT_TRAINING)


def mask_sums(
    model: nn.Module, items: Iterable[tuple[list[np.ndarray], np.ndarray, float]]
) -> list[RepairSums]:
    """``threshold_curve``'s sums (one per ``MASK_LOGITS``) of a recovery model over ``items`` of (inputs:
    the frame, and its last clean frame for a temporal model; the clean frame; depth scale), all uint16:
    the same sums as ``d2sr eval recovery``."""
    device = next(model.parameters()).device
    was = model.training
    model.eval()

    def samples() -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]]:
        for ins, clean, s in items:
            x = np.stack(ins).astype(np.float32) / np.float32(s)
            with torch.inference_mode():
                logit, pred = model(torch.from_numpy(x)[None].to(device))
            y = clean.astype(np.float32) / np.float32(s)
            yield x[0], y, ins[0] != clean, logit[0, 0].cpu().numpy(), pred[0, 0].cpu().numpy(), s

    _, sums = threshold_curve(samples(), MASK_LOGITS)
    model.train(was)
    return sums


def pick_mask_logit(sums: list[RepairSums]) -> tuple[float, str]:
    """Of ``MASK_LOGITS`` (one ``RepairSums`` each), the lowest RMSE among those that change at most
    ``MAX_CLEAN_CHANGED`` of the clean pixels; (logit, the rule in words)."""
    rmse = np.array([r.result()["rmse_cm"] for r in sums])
    changed = np.array([r.result()["clean_changed"] for r in sums])
    ok = np.flatnonzero(changed <= MAX_CLEAN_CHANGED)
    k = int(ok[np.argmin(rmse[ok])]) if len(ok) else MASK_LOGITS.index(0.0)
    return MASK_LOGITS[k], f"lowest RMSE with at most {MAX_CLEAN_CHANGED:.0%} of clean pixels changed"


Items = list[tuple[list[np.ndarray], np.ndarray, float]]


def recovered_sums(model: nn.Module, items: Items, logit: float) -> RepairSums:
    """``RepairSums`` over ``items`` (as ``mask_sums``'s) of the repair ``d2sr recover`` writes with this
    model at mask threshold ``logit``: its passes, its guard, rounded to the input's units."""
    was = model.training
    model.eval()
    net, sums = TorchBackend(None, model, mask_logit=logit, passes=own_passes(model)), RepairSums()
    for ins, clean, scale in items:
        s = np.float32(scale)
        x = ins[0].astype(np.float32) / s
        prev = ins[1].astype(np.float32)[None] / s if len(ins) > 1 else None
        pred, mask = net.recover(x[None], prev)
        out, kept = repair_frame(ins[0], pred[0], mask[0], scale)
        sums.add(out.astype(np.float32) / s, kept, x, clean.astype(np.float32) / s, ins[0] != clean)
    model.train(was)
    return sums


def pick_as_recovered(model: nn.Module, items: Items) -> tuple[float, str, list[RepairSums], dict]:
    """(mask threshold, the rule in words, the one-pass curve's sums, the threshold's ``recovered_sums``
    figures): ``pick_mask_logit`` on the one-pass curve, stepped up ``MASK_LOGITS`` until the repair
    ``recover`` writes changes at most ``MAX_CLEAN_CHANGED`` of the clean pixels: its second pass repairs
    more than the one-pass curve counts."""
    sums = mask_sums(model, items)
    logit, rule = pick_mask_logit(sums)
    k = MASK_LOGITS.index(logit)
    figures = recovered_sums(model, items, logit).result()
    while figures["clean_changed"] > MAX_CLEAN_CHANGED and k > 0:
        k -= 1
        figures = recovered_sums(model, items, MASK_LOGITS[k]).result()
    return MASK_LOGITS[k], f"{rule}, as recover repairs ({own_passes(model)} passes)", sums, figures


def choose_mask_logit(
    model: nn.Module,
    cache: Path,
    progress: bool = True,
    count: int = VALIDATION_FRAMES,
    gate_previous: bool = False,
    sensor: SensorModel | None = None,
) -> dict:
    """The recovery model's mask threshold: of the candidate logits, the one with the lowest RMSE on
    generated validation frames (seeds VALIDATION_SEED+, never trained or tested on) among those that change
    at most MAX_CLEAN_CHANGED of the clean pixels by more than 1 cm (``pick_mask_logit``), raised until the
    repair ``recover`` writes keeps that (``pick_as_recovered``). The mask head errs towards missing
    dropouts (a dropout and a natural no-return look alike), and each missed one costs metres. The
    ``rmse_cm`` and ``clean_changed`` curves are of one pass. ``gate_previous``: only the frames whose last
    clean frame lines up (those ``--model auto`` gives a temporal model; ``TrainSettings.gate_previous``).
    ``sensor``: the L515 fit the validation frames are drawn around (``TrainSettings.sensor``)."""
    from d2sr.sim.dataset import VALIDATION_SEED
    from d2sr.train.data import lines_up, synth_set

    frames = int(getattr(model, "frames", 1))
    ss = synth_set(cache, count, VALIDATION_SEED, progress, frames > 1, sensor)
    prev = ss.previous if frames > 1 else None
    items = [
        ([ss.frames[i]] + ([prev[i]] if prev is not None else []), ss.clean[i], float(ss.scales[i]))
        for i in map(int, np.flatnonzero(ss.labels))
    ]
    if gate_previous and prev is not None:  # the frames --model auto gives the temporal model
        items = [it for it in items if lines_up(it[0][0], it[0][1], it[2])]
        if not items:
            raise ConfigError(f"none of the {count} validation frames' last clean frames lines up: give more")
    logit, rule, sums, figures = pick_as_recovered(model, items)
    rmse = np.array([r.result()["rmse_cm"] / 100 for r in sums])
    changed = np.array([r.result()["clean_changed"] for r in sums])
    return {
        "mask_logit": logit,
        "rule": f"{rule}, {count} generated validation frames (seeds {VALIDATION_SEED}+)"
        + (f", the {len(items)} interfered ones whose last clean frame lines up" if gate_previous else ""),
        "as_recovered": {k: round(float(figures[k]), 5) for k in ("rmse_cm", "mask_f1", "clean_changed")},
        "rmse_cm": {f"{t:g}": round(100 * float(r), 2) for t, r in zip(MASK_LOGITS, rmse, strict=True)},
        "clean_changed": {f"{t:g}": round(float(c), 5) for t, c in zip(MASK_LOGITS, changed, strict=True)},
    }


_SUMMARY = {
    "detector": "Frame-level interference detector (stage 1): probability that a depth frame is interfered.",
    "recovery": "Two-head recovery UNet (stage 3): interference mask and depth; output = predicted depth "
    "inside the mask, the input outside it.",
}


def lineage(init: Path) -> dict:
    """What a fine-tune started from: the weights and, where a card lies beside them, the command and time
    that made them and what those started from in turn (the whole chain of a model trained in stages)."""
    card = read_card(init)
    t = card.get("training", {})
    found = {"command": card.get("command"), "steps": t.get("steps"), "minutes": t.get("minutes"),
             "device": t.get("device"), "started_from": card.get("started_from")}  # fmt: skip
    return {"weights": str(init)} | {k: v for k, v in found.items() if v is not None}


def _data_line(cfg: TrainSettings, frames: int = 1) -> str:
    parts = []
    if cfg.synthetic:
        parts.append(
            f"{cfg.synthetic} generated 640x480 frames (d2sr.sim.dataset version {VERSION}, "
            f"seeds {cfg.seed}..{cfg.seed + cfg.synthetic - 1}; "
            "simulated rooms of any size, people; L515, stereo, time-of-flight and structured-light "
            "sensor models; the wide interference generator (d2sr.sim.families) on every other frame"
            + (f", frames with {', '.join(cfg.leave_out)} left out" if cfg.leave_out else "")
            + ("; each with the same camera's last clean frame 1-12 frames earlier" if frames > 1 else "")
            + "). No real recordings."
        )
    parts += [f"folder {f.input} -> {f.target}" for f in cfg.folders]
    return " ".join(parts)
