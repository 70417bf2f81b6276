"""``d2sr train``: one loop for the detector and the recovery UNets; single process or torchrun (DDP)."""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import torch
import torch.distributed as tdist
import torch.nn.functional as F
from torch import nn

from d2sr.atomic import atomic_file, atomic_write
from d2sr.models.registry import build, describe
from d2sr.models.weights import save_model, torch_device, write_card
from d2sr.train.config import TrainConfig
from d2sr.train.data import Batch, Pool
from d2sr.ui import console, progress_bar

__all__ = ["loss_fn", "train"]

CHECKPOINT = "checkpoint.pt"


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
    model: nn.Module, task: str, b: Batch, device: torch.device, mask_weight: float = 3.0, dice: float = 1.0
) -> torch.Tensor:
    x = torch.from_numpy(b.x).to(device)
    if task == "detector":
        return F.binary_cross_entropy_with_logits(model(x), torch.from_numpy(b.label).to(device))
    y, m = torch.from_numpy(b.y).to(device), torch.from_numpy(b.m).to(device)
    logit, pred = model(x)
    soft = torch.sigmoid(logit)
    out = pred * soft + x * (1 - soft)  # the paper's composition, soft while training
    depth = F.smooth_l1_loss(out, y, beta=0.05)
    # The depth head also learns on every truly interfered pixel, whatever the mask head says.
    inside = (F.smooth_l1_loss(pred, y, beta=0.05, reduction="none") * m).sum() / m.sum().clamp(min=1)
    mask = mask_weight * F.binary_cross_entropy_with_logits(logit, m)
    if dice:
        # Soft F1 over the batch: BCE alone leaves zeros inside a pattern near 0.5 (a natural no-return
        # and a dropout look alike pixel by pixel); the F1 term pays for deciding them from the context.
        mask = mask + dice * (1 - 2 * (soft * m).sum() / (soft.sum() + m.sum()).clamp(min=1))
    return mask + 10 * depth + inside


def _save_checkpoint(
    path: Path,
    model: nn.Module,
    opt: torch.optim.Optimizer,
    sched: object,
    step: int,
    rng: np.random.Generator,
    cfg: TrainConfig,
) -> None:
    state = {
        "model": model.state_dict(),
        "opt": opt.state_dict(),
        "sched": sched.state_dict(),  # type: ignore[attr-defined]
        "step": step,
        "rng": rng.bit_generator.state,
        "torch_rng": torch.get_rng_state(),
        "config": cfg.model_dump(mode="json"),
    }
    with atomic_file(path) as tmp:
        torch.save(state, tmp)


def train(cfg: TrainConfig, out: Path, command: str = "", progress: bool = True) -> dict:
    """Train, checkpoint to ``out/checkpoint.pt`` (resumed when present and of the same config), and write
    ``out/<model>.safetensors`` with its model card. Returns the training summary."""
    with _distributed() as (rank, world):
        device = torch_device()
        if device.type == "cpu":
            torch.set_num_threads(max(1, (os.cpu_count() or 1) // world))
        torch.manual_seed(cfg.seed)
        out.mkdir(parents=True, exist_ok=True)
        # Rank 0 generates the data set (if it is not cached yet); the others wait, then open it.
        if world > 1 and rank:
            tdist.barrier()
        pool = Pool.from_config(cfg, progress and rank == 0)
        if world > 1 and rank == 0:
            tdist.barrier()
        model = build(cfg.model).to(device)
        core = model
        if world > 1:
            model = nn.parallel.DistributedDataParallel(model)
        opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, cfg.lr, total_steps=cfg.steps, pct_start=0.05)
        rng = np.random.default_rng([cfg.seed, rank])
        start, losses = 0, []
        ckpt = out / CHECKPOINT
        if ckpt.is_file():
            state = torch.load(ckpt, weights_only=False)
            if state["config"] == cfg.model_dump(mode="json"):
                core.load_state_dict(state["model"])
                opt.load_state_dict(state["opt"])
                sched.load_state_dict(state["sched"])
                rng.bit_generator.state = state["rng"]
                torch.set_rng_state(state["torch_rng"])
                start = state["step"]
                if rank == 0:
                    console.print(f"resuming from step {start}")
            elif rank == 0:
                console.print(f"{ckpt} is from another config: starting afresh")
        crop = tuple(cfg.crop) if cfg.task == "recovery" else None
        share = cfg.clean_share if cfg.task == "recovery" else 0.5
        t0, stopped, done = time.perf_counter(), False, start
        bar = progress_bar() if progress and rank == 0 else contextlib.nullcontext()
        with bar as pb:
            task = pb.add_task(f"training {cfg.model}", total=cfg.steps, completed=start) if pb else None
            model.train()
            for step in range(start, cfg.steps):
                b = pool.batch(rng, cfg.batch, crop, share)
                loss = loss_fn(model, cfg.task, b, device, cfg.mask_weight, cfg.dice)
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
                    _save_checkpoint(ckpt, core, opt, sched, done, rng, cfg)
                if over:
                    stopped = True
                    break
        minutes = (time.perf_counter() - t0) / 60
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
            save_model(core, cfg.model, weights)
            atomic_write(out / "loss.json", json.dumps(losses))
            write_card(
                weights,
                model=cfg.model,
                summary=_SUMMARY[cfg.task],
                data=_data_line(cfg),
                command=command or f"d2sr train {cfg.task} --config <config.toml>",
                training=summary | {"config": cfg.model_dump(mode="json")},
                date=dt.date.today().isoformat(),
            )
        return summary


_SUMMARY = {
    "detector": "Frame-level interference detector (stage 1): probability that a depth frame is interfered.",
    "recovery": "Two-head recovery UNet (stage 3): interference mask and depth; output = predicted depth "
    "inside the mask, the input outside it.",
}


def _data_line(cfg: TrainConfig) -> str:
    parts = []
    if cfg.synthetic:
        parts.append(
            f"{cfg.synthetic} generated 640x480 frames (d2sr.train.synth, "
            f"seeds {cfg.seed}..{cfg.seed + cfg.synthetic - 1}; "
            "simulated rooms, sensor noise drawn around the calibrated L515 fit, people; "
            "interference on every other frame). "
            "No real recordings."
        )
    parts += [f"folder {f.input} -> {f.target}" for f in cfg.folders]
    return " ".join(parts)
