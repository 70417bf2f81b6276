"""Start a wider UNet as a narrower one (Net2WiderNet, Chen et al. 2016): every trunk channel of the narrow
model appears ``factor`` times in the wide one, and the weights that read a copied channel are divided by
``factor``, so the wide model computes the same function. A little noise on the wide weights then lets the
copies part ways in training (copies with identical weights get identical gradients forever).

Why: unet16 trained from its own start has stayed behind unet8 on every set (CHANGELOG), against the
paper's trend. Started as unet8 it begins where unet8 is and can only use its extra width to do better.
"""

from __future__ import annotations

from typing import cast

import torch
from torch import nn

from d2sr.models.unet import UNet

__all__ = ["can_widen", "widen"]


def can_widen(narrow: nn.Module, wide: nn.Module) -> bool:
    """``wide`` is ``narrow``'s layout with a whole multiple of its width."""
    return (
        isinstance(narrow, UNet)
        and isinstance(wide, UNet)
        and wide.width > narrow.width
        and wide.width % narrow.width == 0
        and (narrow.s2d, narrow.fill, narrow.frames, narrow.levels)
        == (wide.s2d, wide.fill, wide.frames, wide.levels)
        and narrow.head[0].out_channels == wide.head[0].out_channels
    )


def _layout(net: UNet) -> tuple:
    return net.s2d, net.fill, net.frames, net.levels, _c(net.head, 0).out_channels


def _c(block: nn.Module, i: int) -> nn.Conv2d:
    return cast(nn.Conv2d, cast(nn.Sequential, block)[i])


def _conv(small: nn.Conv2d, big: nn.Conv2d, ins: list[tuple[int, bool]], out_wide: bool, f: int) -> None:
    """Fill ``big`` from ``small``. ``ins``: the input's parts in order, (channels in the narrow model,
    copied f times); ``out_wide``: whether the output channels are copied."""
    idx, scale = [], []
    at = 0
    for n, copied in ins:
        reps = f if copied else 1
        idx += [at + j % n for j in range(n * reps)]
        scale += [1.0 / reps] * (n * reps)
        at += n
    out = small.out_channels
    rows = [o % out for o in range(big.out_channels)] if out_wide else list(range(out))
    w = small.weight[rows][:, idx] * torch.tensor(scale).view(1, -1, 1, 1)
    big.weight.copy_(w)
    if small.bias is not None and big.bias is not None:
        big.bias.copy_(small.bias[rows])


def widen(narrow: UNet, wide: UNet, noise: float = 1e-3, seed: int = 0) -> None:
    """Set ``wide``'s weights so that it computes ``narrow``'s function (``can_widen`` must hold), then add
    Gaussian noise of ``noise`` x each weight tensor's standard deviation to the trunk's weights."""
    if not can_widen(narrow, wide):
        raise ValueError("widen needs two UNets of one layout, the second a multiple of the first's width")
    f = wide.width // narrow.width
    widths = [narrow.width * 2**k for k in range(narrow.levels)]
    cin = _c(narrow.down[0], 0).in_channels
    gen = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for k in range(narrow.levels):
            first = [(cin, False)] if k == 0 else [(widths[k - 1], True)]
            _conv(_c(narrow.down[k], 0), _c(wide.down[k], 0), first, True, f)
            _conv(_c(narrow.down[k], 2), _c(wide.down[k], 2), [(widths[k], True)], True, f)
        for k in range(narrow.levels - 1):
            ins = [(widths[k + 1], True), (widths[k], True)]  # the upsampled level below, then the skip
            _conv(_c(narrow.up[k], 0), _c(wide.up[k], 0), ins, True, f)
            _conv(_c(narrow.up[k], 2), _c(wide.up[k], 2), [(widths[k], True)], True, f)
        _conv(_c(narrow.head, 0), _c(wide.head, 0), [(widths[0], True), (cin, False)], False, f)
        _c(wide.head, 2).load_state_dict(_c(narrow.head, 2).state_dict())
        if noise > 0:
            for block in [*wide.down, *wide.up]:
                for conv in (_c(block, 0), _c(block, 2)):
                    std = float(conv.weight.std())
                    conv.weight.add_(torch.randn(conv.weight.shape, generator=gen) * noise * std)
