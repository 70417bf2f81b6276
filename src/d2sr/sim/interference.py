"""Direct and scattering interference on a depth frame, only where views overlap, with the true mask.

What users report on the L515 and time-of-flight cameras, and what this draws:

* ``band``: curved bands that drift across the image from frame to frame;
* ``wave``: periodic wave patterns (stripes bent by a slow sinusoid);
* ``bar``: vertical bars (moving slowly sideways);
* ``cluster``: scattered clusters of corrupted pixels;
* ``direct``: a burst around the interferer when it is in view, facing this sensor.

Inside a pattern, pixels with a return drop out or get a wrong depth (mostly too short, some spurious far
returns); pixels without a return sometimes get a spurious short one. Each interferer adds its own
pattern, so more interferers corrupt more of the frame. The mask marks exactly the pixels that changed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from pydantic import Field, model_validator

from d2sr.config import Settings
from d2sr.errors import InputError
from d2sr.frames.base import to_units

__all__ = ["KINDS", "InterferenceSettings", "Interferer", "corrupt", "interfere"]

KINDS = ("band", "wave", "bar", "cluster")


class InterferenceSettings(Settings):
    """How interference looks. Defaults match the descriptions in the module docstring."""

    kinds: tuple[str, ...] = Field(KINDS, description="pattern kinds drawn from, uniformly")
    coverage: tuple[float, float] = Field(
        (0.06, 0.22), description="share of the image one interferer's pattern covers"
    )
    drift_px: tuple[float, float] = Field((6.0, 30.0), description="pattern drift per frame (pixels)")
    dropout: float = Field(0.55, ge=0, le=1, description="corrupted returning pixel -> no return")
    short: float = Field(0.35, ge=0, le=1, description="corrupted returning pixel -> too-short depth")
    far: float = Field(0.06, ge=0, le=1, description="corrupted returning pixel -> spurious far return")
    spurious: float = Field(0.3, ge=0, le=1, description="pixel without a return -> spurious short return")
    short_range: tuple[float, float] = Field(
        (0.25, 0.85), description="too-short depth as a fraction of true"
    )
    far_add: tuple[float, float] = Field((0.5, 3.0), description="metres a far return adds")

    @model_validator(mode="after")
    def _consistent(self) -> InterferenceSettings:
        bad = set(self.kinds) - set(KINDS)
        if bad or not self.kinds:
            raise ValueError(f"kinds must be among {KINDS}")
        if self.dropout + self.short + self.far > 1:
            raise ValueError("dropout + short + far must be <= 1")
        return self


@dataclass
class Interferer:
    """One interfering sensor as seen by one victim: a pattern whose parameters persist over a sequence, so
    it drifts rather than jumps from frame to frame."""

    shape: tuple[int, int]
    kind: str
    seed: int
    coverage: float
    drift: float
    direct_at: tuple[float, float] | None = None
    #: Where this interferer's light lands in the victim's image (None: anywhere).
    region: np.ndarray | None = field(default=None, compare=False, repr=False)

    @classmethod
    def draw(
        cls,
        shape: tuple[int, int],
        seed: int,
        config: InterferenceSettings | None = None,
        direct_at: tuple[float, float] | None = None,
        region: np.ndarray | None = None,
    ) -> Interferer:
        cfg = config or InterferenceSettings()
        rng = np.random.default_rng([seed, 0x1F])
        kind = "direct" if direct_at is not None else str(rng.choice(cfg.kinds))
        return cls(
            shape,
            kind,
            seed,
            float(rng.uniform(*cfg.coverage)),
            float(rng.uniform(*cfg.drift_px)),
            direct_at,
            region,
        )

    def pattern(self, t: int) -> np.ndarray:
        """Boolean pattern at frame ``t``."""
        h, w = self.shape
        rng = np.random.default_rng([self.seed, 0x2F])
        y, x = np.mgrid[0:h, 0:w].astype(np.float32)
        shift = self.drift * t
        if self.kind == "band":
            k = int(rng.integers(1, 4))
            out = np.zeros(self.shape, bool)
            width = self.coverage * h / k
            theta = rng.uniform(-0.6, 0.6)
            xr = x * np.cos(theta) + y * np.sin(theta)
            yr = -x * np.sin(theta) + y * np.cos(theta)
            for _ in range(k):
                amp, lam, phi = rng.uniform(10, 60), rng.uniform(0.6, 2.0) * w, rng.uniform(0, 2 * np.pi)
                bend = rng.uniform(-1.5, 1.5) / w
                y0 = (rng.uniform(0, h) + shift) % (h + 2 * width) - width
                curve = y0 + amp * np.sin(2 * np.pi * xr / lam + phi) + bend * (xr - w / 2) ** 2
                out |= np.abs(yr - curve) < width / 2
            return out
        if self.kind == "wave":
            theta, lam = rng.uniform(0, np.pi), rng.uniform(40, 120)
            amp, lam2 = rng.uniform(5, 25), rng.uniform(150, 400)
            s = x * np.cos(theta) + y * np.sin(theta)
            n = -x * np.sin(theta) + y * np.cos(theta)
            phase = 2 * np.pi * (s + amp * np.sin(2 * np.pi * n / lam2) - shift) / lam
            return np.cos(phase) > np.cos(np.pi * self.coverage)
        if self.kind == "bar":
            k = int(rng.integers(1, 5))
            out = np.zeros(self.shape, bool)
            width = self.coverage * w / k
            for _ in range(k):
                x0 = (rng.uniform(0, w) + 0.3 * shift * rng.choice([-1, 1])) % (w + width) - width
                v0, v1 = sorted(rng.uniform(0, h, 2)) if rng.random() < 0.4 else (0, h)
                out |= (x >= x0) & (x < x0 + width) & (y >= v0) & (y < v1)
            return out
        if self.kind == "cluster":
            frame_rng = np.random.default_rng([self.seed, 0x3F, t])
            g = cv2.GaussianBlur(frame_rng.standard_normal(self.shape, dtype=np.float32), (0, 0), 6)
            return g > np.quantile(g, 1 - self.coverage)
        # direct: a burst around the interferer's image position, with a horizontal streak
        assert self.direct_at is not None
        u, v = self.direct_at
        r = np.sqrt(self.coverage * h * w / np.pi) * (0.8 + 0.4 * np.sin(0.7 * t))
        blob = (x - u) ** 2 + (y - v) ** 2 < r * r
        streak = (np.abs(y - v) < r / 5) & (np.abs(x - u) < 3 * r)
        return blob | streak


def corrupt(
    depth: np.ndarray,
    depth_scale: float,
    where: np.ndarray,
    rng: np.random.Generator,
    config: InterferenceSettings | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Corrupt the pixels of ``where`` in a uint16 frame; returns (frame, mask of pixels that changed)."""
    cfg = config or InterferenceSettings()
    h, w = depth.shape
    d = depth.astype(np.float32) / np.float32(depth_scale)
    u = rng.random((h, w), dtype=np.float32)
    has = d > 0
    # Wrong depths come as coherent wrong surfaces, not salt: a smooth factor field over the frame.
    smooth = cv2.GaussianBlur(rng.random((h // 8 + 1, w // 8 + 1), dtype=np.float32), (0, 0), 1.5)
    smooth = cv2.resize((smooth - smooth.min()) / max(float(np.ptp(smooth)), 1e-6), (w, h))
    lo, hi = cfg.short_range
    factor = lo + (hi - lo) * smooth
    out = d.copy()
    drop = where & has & (u < cfg.dropout)
    short = where & has & (u >= cfg.dropout) & (u < cfg.dropout + cfg.short)
    far = where & has & (u >= cfg.dropout + cfg.short) & (u < cfg.dropout + cfg.short + cfg.far)
    spur = where & ~has & (u < cfg.spurious)
    out[drop] = 0
    out[short] = d[short] * factor[short]
    out[far] = d[far] + cfg.far_add[0] + (cfg.far_add[1] - cfg.far_add[0]) * smooth[far]
    out[spur] = 0.3 + 2.0 * smooth[spur]
    frame = to_units(out, depth_scale)
    return frame, frame != depth


def interfere(
    depth: np.ndarray,
    depth_scale: float,
    interferers: list[Interferer],
    t: int,
    seed: int,
    region: np.ndarray | None = None,
    config: InterferenceSettings | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Frame ``t`` of a sequence under the given interferers, each limited to its own region, and all to
    ``region`` (where the views overlap; everywhere when None).
    Returns (corrupted uint16 frame, true mask)."""
    if depth.dtype != np.uint16 or depth.ndim != 2:
        raise InputError(f"interference works on uint16 depth images, got {depth.dtype} {depth.shape}")
    where = np.zeros(depth.shape, bool)
    for it in interferers:
        if it.shape != depth.shape:
            raise InputError(f"interferer pattern is {it.shape}, frame is {depth.shape}")
        p = it.pattern(t)
        where |= p if it.region is None else p & it.region
    if region is not None:
        where &= region
    if not where.any():
        return depth.copy(), np.zeros(depth.shape, bool)
    return corrupt(depth, depth_scale, where, np.random.default_rng([seed, 0x4F, t]), config)
