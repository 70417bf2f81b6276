"""A wide interference generator for training: many shape families, confinement, hit rates and a broad
error model, so that learned stages learn "interference" rather than the look of one simulator.

Each frame's interference is one to three patterns. A pattern is:

* a **shape** from one family (``FAMILIES``): a few bands of any curvature, orientation and thickness;
  scanline streaks; bars at any angle; blobs and sparse clusters; speckle; large smooth regions; dense
  periodic gratings (straight, wavy or concentric, any period and duty: a modulated source beating with
  the sensor repeats across the whole view); or the physical simulator's own patterns
  (``sim.interference``);
* optionally **confined** to a random overlap region (half-plane, ellipse or polygon), as another sensor's
  light only lands where the views overlap;
* **thinned** by a per-pattern hit rate (not every pixel under the pattern is hit), spatially correlated;
* an **error model** drawn per pattern: dropouts (zeros), too-short depths (any factor), offsets both ways,
  spurious near or far values independent of the scene, a smooth bias (one of them throughout the pattern,
  or a mixture); and spurious returns where the sensor had none.

Coverage is drawn log-uniformly from 0.1% to 50% of the valid pixels. The mask is exactly the pixels
whose value changed. Everything is a pure function of the seed (numpy and OpenCV, no torch).
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
from pydantic import Field, model_validator

from d2sr.config import Settings
from d2sr.errors import InputError
from d2sr.frames.base import to_units
from d2sr.sim.interference import Interferer

__all__ = ["FAMILIES", "WideSettings", "shape", "shell_interference", "wide_interference"]

FAMILIES = ("band", "streak", "bar", "blob", "speckle", "region", "grating", "physical")


class WideSettings(Settings):
    """What the wide generator draws from. ``families`` is what leave-one-family-out changes."""

    families: tuple[str, ...] = Field(FAMILIES, description="shape families drawn from, uniformly")
    coverage: tuple[float, float] = Field((0.001, 0.5), description="share of valid pixels hit (log-uniform)")
    patterns: tuple[int, int] = Field((1, 3), description="patterns per frame (inclusive)")
    confine: float = Field(0.5, ge=0, le=1, description="chance a pattern is confined to an overlap region")

    @model_validator(mode="after")
    def _known(self) -> WideSettings:
        bad = set(self.families) - set(FAMILIES)
        if bad or not self.families:
            raise ValueError(f"families must be among {FAMILIES}, got {sorted(bad) or 'none'}")
        return self


def _angle_coords(h: int, w: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Image coordinates rotated by a random angle about a random centre: (along, across)."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    th = rng.uniform(0, np.pi)
    cx, cy = rng.uniform(0, w), rng.uniform(0, h)
    return (x - cx) * np.cos(th) + (y - cy) * np.sin(th), -(x - cx) * np.sin(th) + (y - cy) * np.cos(th)


def _band(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """1-6 curved bands (sinusoid plus parabola, or circular arcs like a scanner's rings), any angle."""
    k = int(rng.integers(1, 7))
    thick = max(c * h / k, 1.0)
    out = np.zeros((h, w), bool)
    s, n = _angle_coords(h, w, rng)
    if rng.random() < 0.3:  # concentric arcs around a centre that may lie off the image
        r = np.hypot(s + rng.uniform(-2, 2) * w, n + rng.uniform(-2, 2) * h)
        r0 = rng.uniform(r.min(), r.max())
        gap = rng.uniform(1.5, 6) * thick
        for j in range(k):
            out |= np.abs(r - (r0 + j * gap)) < thick / 2
        return out
    for _ in range(k):
        amp, lam = rng.uniform(0, 0.2) * h, rng.uniform(0.3, 3.0) * w
        bend = rng.uniform(-3, 3) / w
        n0 = rng.uniform(-0.6, 0.6) * max(h, w)
        curve = n0 + amp * np.sin(2 * np.pi * s / lam + rng.uniform(0, 2 * np.pi)) + bend * s * s / 2
        out |= np.abs(n - curve) < thick / 2
    return out


def _streak(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """Scanline streaks: many thin line segments, mostly along the rows, over a random stretch of rows."""
    img = np.zeros((h, w), np.uint8)
    angle = rng.normal(0, 0.05) if rng.random() < 0.7 else rng.uniform(0, np.pi)
    length = rng.uniform(0.05, 1.0) * w
    width = int(rng.integers(1, 4))
    y0, y1 = sorted(rng.uniform(0, h, 2))
    y1 = max(y1, y0 + 0.1 * h)
    count = int(np.clip(c * h * w / max(length * width, 1), 1, 2000))
    ys = rng.uniform(y0, y1, count)
    xs = rng.uniform(-0.2 * w, w, count)
    dx, dy = np.cos(angle) * length, np.sin(angle) * length
    for x, y in zip(xs, ys, strict=True):
        cv2.line(img, (int(x), int(y)), (int(x + dx), int(y + dy)), 1, width)
    return img.astype(bool)


def _bar(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """1-5 straight bars at any angle, full or partial length."""
    k = int(rng.integers(1, 6))
    s, n = _angle_coords(h, w, rng)
    thick = max(c * w / k, 1.0)
    out = np.zeros((h, w), bool)
    span = max(h, w)
    for _ in range(k):
        n0 = rng.uniform(-0.6, 0.6) * span
        a, b = (-span, span) if rng.random() < 0.6 else sorted(rng.uniform(-0.7, 0.7, 2) * span)
        out |= (np.abs(n - n0) < thick / 2) & (s > a) & (s < b)
    return out


def _smooth_field(h: int, w: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise blurred at ``sigma`` pixels (computed at reduced size when ``sigma`` is large)."""
    f = max(1, int(sigma // 4))
    g: np.ndarray = rng.standard_normal((h // f + 1, w // f + 1)).astype(np.float32)
    g = cv2.GaussianBlur(g, (0, 0), max(sigma / f, 0.5))
    return cv2.resize(g, (w, h), interpolation=cv2.INTER_LINEAR)


def _blob(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """Blobs and clusters: irregular shapes around a few centres, each with ragged edges."""
    k = int(rng.integers(1, 12))
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    r = np.sqrt(c * h * w / (k * np.pi))
    rough = _smooth_field(h, w, rng.uniform(2, 12), rng)
    out = np.zeros((h, w), bool)
    for _ in range(k):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        ax, ay = r * rng.uniform(0.5, 2.0), r * rng.uniform(0.5, 2.0)
        d = ((x - cx) / ax) ** 2 + ((y - cy) / ay) ** 2
        out |= d + 0.4 * rough < 1
    return out


def _speckle(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """Isolated pixels and tiny dots scattered over part of the frame."""
    area = _blob(h, w, min(1.0, c * rng.uniform(2, 10)), rng) if rng.random() < 0.5 else np.ones((h, w), bool)
    dots = rng.random((h, w)) < min(1.0, c / max(float(area.mean()), 1e-3))
    if rng.random() < 0.4:
        dots = cv2.dilate(dots.astype(np.uint8), np.ones((2, 2), np.uint8)).astype(bool)
    return dots & area


def _region(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """Large smooth regions: a low-frequency field above its (1 - c) quantile."""
    g = _smooth_field(h, w, rng.uniform(20, 80), rng)
    return g > np.quantile(g, 1 - c)


def _grating(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """A periodic pattern over the whole image: stripes (straight or wavy) or rings around a centre that
    may lie off the image, of any period (4-200 px) and a duty cycle near the coverage."""
    s, n = _angle_coords(h, w, rng)
    kind = rng.integers(3)
    if kind == 1:  # wavy stripes
        s = s + rng.uniform(0.02, 0.2) * h * np.sin(2 * np.pi * n / (rng.uniform(0.2, 2.0) * w))
    elif kind == 2:  # rings, possibly squashed
        cx, cy = rng.uniform(-1, 1) * w, rng.uniform(-1, 1) * h
        s = np.hypot(s - cx, (n - cy) * rng.uniform(0.5, 2.0))
    period = float(np.exp(rng.uniform(np.log(4), np.log(200))))
    duty = float(np.clip(c, 1.2 / period, 0.8))
    return ((s / period + rng.uniform(0, 1)) % 1) < duty


def _physical(h: int, w: int, c: float, rng: np.random.Generator) -> np.ndarray:
    """The physical simulator's drifting patterns (band, wave, bar, cluster) at one frame."""
    it = Interferer.draw((h, w), int(rng.integers(2**31)))
    it.coverage = float(np.clip(c, 0.01, 0.5))
    return it.pattern(int(rng.integers(0, 1000)))


SHAPES: dict[str, Callable[[int, int, float, np.random.Generator], np.ndarray]] = {
    "band": _band,
    "streak": _streak,
    "bar": _bar,
    "blob": _blob,
    "speckle": _speckle,
    "region": _region,
    "grating": _grating,
    "physical": _physical,
}


def shape(family: str, hw: tuple[int, int], coverage: float, rng: np.random.Generator) -> np.ndarray:
    """One family's boolean shape covering about ``coverage`` of the image."""
    if family not in SHAPES:
        raise InputError(f"unknown interference family {family!r}: one of {', '.join(FAMILIES)}")
    return SHAPES[family](hw[0], hw[1], coverage, rng)


def _overlap_region(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Where another sensor's light lands: a half-plane, an ellipse or a polygon covering 15-85%."""
    kind = rng.integers(3)
    if kind == 0:
        s, _ = _angle_coords(h, w, rng)
        return s > np.quantile(s, rng.uniform(0.15, 0.85))
    img = np.zeros((h, w), np.uint8)
    if kind == 1:
        centre = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
        axes = (int(rng.uniform(0.2, 0.8) * w), int(rng.uniform(0.2, 0.8) * h))
        cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
    else:
        pts = np.stack([rng.uniform(-0.2, 1.2, 5) * w, rng.uniform(-0.2, 1.2, 5) * h], 1).astype(np.int32)
        cv2.fillPoly(img, [cv2.convexHull(pts)], 1)
    return img.astype(bool)


def _errors(d: np.ndarray, where: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """New depths (metres) for the pixels of ``where``; ``d`` is the clean frame in metres (0: none)."""
    h, w = d.shape
    has = d > 0
    smooth = _smooth_field(h, w, rng.uniform(4, 60), rng)
    smooth = (smooth - smooth.min()) / max(float(np.ptp(smooth)), 1e-6)  # 0..1
    # Error kinds for returning pixels: zero, too short, offset, spurious, bias. Half the patterns have one
    # mechanism throughout (a coherent wrong surface, as one other sensor's light makes), half a mixture.
    p = rng.dirichlet(np.full(5, 0.6)) if rng.random() < 0.5 else np.eye(5)[rng.integers(5)]
    kind = rng.choice(5, size=(h, w), p=p)
    out = d.copy()
    lo = rng.uniform(0.05, 0.9)
    short = lo + (rng.uniform(lo, 0.95) - lo) * smooth
    off = rng.choice([-1, 1]) * rng.uniform(0.05, 1.5)
    spur_near, spur_far = rng.uniform(0.15, 1.5), rng.uniform(3.0, 12.0)
    spur = np.where(rng.random() < 0.6, spur_near, spur_far) * (0.8 + 0.4 * smooth)
    bias = rng.choice([-1, 1]) * rng.uniform(0.05, 0.8) * (0.3 + smooth)
    r = has & where
    out[r & (kind == 0)] = 0
    out[r & (kind == 1)] = (d * short)[r & (kind == 1)]
    offset = np.maximum(d + off * (0.5 + smooth), 0.1)
    out[r & (kind == 2)] = offset[r & (kind == 2)]
    out[r & (kind == 3)] = spur[r & (kind == 3)]
    out[r & (kind == 4)] = np.maximum(d + bias, 0.1)[r & (kind == 4)]
    # Pixels without a return get a spurious one at some rate.
    gets = where & ~has & (rng.random((h, w)) < rng.uniform(0, 0.6))
    out[gets] = spur[gets]
    return out


def shell_interference(d: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(new depths in metres, where they apply) for a pattern confined to one shell of the scene's depth: a
    gated sensor meets another's light only at some ranges, so the hit region follows the room's surfaces
    rather than a shape in the image. Thinned and valued as ``wide_interference``'s patterns are (the same
    error model). ``d``: the clean frame in metres (0: no return)."""
    h, w = d.shape
    valid = d > 0
    if not valid.any():
        return d.copy(), np.zeros(d.shape, bool)
    qa = rng.uniform(0.0, 0.8)
    lo, hi = np.quantile(d[valid], [qa, min(qa + rng.uniform(0.1, 0.5), 1.0)])
    where = valid & (d >= lo) & (d <= hi)
    hit = rng.uniform(0.25, 1.0)
    if hit < 0.98:
        thin = _smooth_field(h, w, rng.uniform(0.5, 3.0), rng)
        where &= thin < np.quantile(thin, hit)
    return _errors(d, where, rng), where


def wide_interference(
    depth: np.ndarray, depth_scale: float, seed: int, config: WideSettings | None = None
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(interfered uint16 frame, mask of changed pixels, the families drawn). Draws until at least one
    pixel changes."""
    if depth.dtype != np.uint16 or depth.ndim != 2:
        raise InputError(f"interference works on uint16 depth images, got {depth.dtype} {depth.shape}")
    cfg = config or WideSettings()
    rng = np.random.default_rng([seed, 0x3D1E])
    h, w = depth.shape
    d = depth.astype(np.float32) / np.float32(depth_scale)
    valid = max(float((d > 0).mean()), 0.05)
    for _ in range(8):
        out, drawn = d.copy(), []
        for _ in range(int(rng.integers(cfg.patterns[0], cfg.patterns[1] + 1))):
            lo, hi = np.log(cfg.coverage[0]), np.log(cfg.coverage[1])
            c = float(np.exp(rng.uniform(lo, hi)))
            confined = rng.random() < cfg.confine
            region = _overlap_region(h, w, rng) if confined else None
            # Aim the shape at the share of valid pixels, and inside the region when confined.
            share = region.mean() if region is not None else 1.0
            c_img = min(0.9, c * valid / max(share, 0.1))
            family = str(rng.choice(cfg.families))
            drawn.append(family)
            where = shape(family, (h, w), c_img, rng)
            if region is not None and (where & region).any():
                where &= region
            hit = rng.uniform(0.25, 1.0)
            if hit < 0.98:
                thin = _smooth_field(h, w, rng.uniform(0.5, 3.0), rng)
                where &= thin < np.quantile(thin, hit)
            out = np.where(where, _errors(out, where, rng), out)
        frame = to_units(out, depth_scale)
        mask = frame != depth
        if mask.any():
            return frame, mask, sorted(set(drawn))
    raise InputError("interference changed no pixel in 8 draws (an empty frame?)")
