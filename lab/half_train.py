"""Trial (issue 78): the shipped unet8 fine-tuned to run at half resolution (``lab/half_pass.py`` measured it
untrained for that scale: a third of a pass's time, 4-18 points of RMSE lost). The UNet sees every second
pixel of every second row of each training crop and its outputs are repeated back to the crop's size; the
loss is the product's (``d2sr.train.loop.loss_fn``) at full resolution, on the generator's frames
(as unet8 trained: 256x320 crops, 30% clean, mask weight 3, dice 1), from unet8's weights.

Writes ``OUT/unet8.safetensors``: unet8's own layout, so ``d2sr export`` makes its ONNX file and
``lab.half_pass --half-models`` runs it at half resolution beside the shipped unet8.

Run:  python -m lab.half_train --steps 1500 --out runs/unet8-half
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

from d2sr.contract.catalog import WEIGHTS
from d2sr.models.store import load_model, mask_logit, save_model
from d2sr.train.config import TrainSettings
from d2sr.train.data import Pool
from d2sr.train.loop import deterministic, loss_fn


class Half(nn.Module):
    """``net`` on every second pixel of every second row; its outputs repeated back to full size."""

    def __init__(self, net: nn.Module) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h, w = x.shape[-2:]
        logit, pred = self.net(x[..., ::2, ::2])

        def up(a: torch.Tensor) -> torch.Tensor:
            return a.repeat_interleave(2, dim=-2).repeat_interleave(2, dim=-1)[..., :h, :w]

        return up(logit), up(pred)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--lr", type=float, default=2e-4)
    ap.add_argument("--synthetic", type=int, default=2000, help="generated frames (seeds 0..N-1)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    cfg = TrainSettings(
        task="recovery",
        model="unet8",
        synthetic=args.synthetic,
        seed=0,
        batch=12,
        crop=(256, 320),
        clean_share=0.3,
    )
    deterministic(cfg.seed)
    torch.set_num_threads(2)
    pool = Pool.from_config(cfg)
    net, _ = load_model(WEIGHTS / "unet8.safetensors")
    model = Half(net).train()
    opt = torch.optim.AdamW(model.parameters(), lr=args.lr, weight_decay=1e-4)
    rng = np.random.default_rng(cfg.seed)
    crop = (cfg.crop[0], cfg.crop[1])
    t0, losses = time.perf_counter(), []
    for step in range(args.steps):
        b = pool.batch(rng, cfg.batch, crop, cfg.clean_share)
        loss = loss_fn(model, "recovery", b, torch.device("cpu"), cfg.mask_weight, cfg.dice)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss))
        if (step + 1) % 100 == 0:
            print(f"step {step + 1}: loss {np.mean(losses[-100:]):.3f} ({time.perf_counter() - t0:.0f} s)")
    args.out.mkdir(parents=True, exist_ok=True)
    keep = mask_logit(WEIGHTS / "unet8.safetensors")  # unet8's operating point, not chosen again
    save_model(net.eval(), "unet8", args.out / "unet8.safetensors", mask_logit=keep)
    print(
        f"{args.steps} steps in {(time.perf_counter() - t0) / 60:.1f} min -> {args.out / 'unet8.safetensors'}"
    )


if __name__ == "__main__":
    main()
