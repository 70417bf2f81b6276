"""Sets K-S, each written and sealed to judge one setting of the scene (``bench.outside.sets.STATUS``)."""

from __future__ import annotations

import cv2
import numpy as np
from bench.outside.draw import _ellipse, _start, _written


def flood_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set K (written and sealed 2026-11-27, before the scene's stillness gate ran on it; opened the same day
    to judge that gate, on a moving D435 as well as the still L515s). One of two models, chosen by the seed,
    neither in ``d2sr.sim`` nor in sets A-I:

    * flood noise: another camera's flood illuminator lights a soft ellipse (15-45% of the view) and raises
      this sensor's shot noise there: each return gets Gaussian noise of 2-6% of its depth times the light's
      weight (1 at the centre, falling to 0 at the edge), and drops out with a chance of 5-25% times it;
    * diagonal comb: a polygon-mirror scanner's lines cross a rotated strip (80-300 px wide): thin lines
      (1-2 px) every 5-16 px at a random angle, on which this sensor reads 40-90% of the depth (each line
      its own share, +-2%), and 10-30% of the line pixels drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.5% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "k")
    flood = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        if flood:
            weight = np.clip(1 - np.sqrt(_ellipse(rng, y, x, 0.15, 0.45)), 0, 1)
            noisy = d * (1 + weight * rng.uniform(0.02, 0.06) * rng.standard_normal((h, w)))
            drop = rng.random((h, w)) < weight * rng.uniform(0.05, 0.25)
            new = np.where(drop, 0.0, np.maximum(noisy, 0.0))
        else:
            across = rng.uniform(0, np.pi)
            strip = np.abs(
                (x - rng.uniform(0, w)) * np.cos(across) + (y - rng.uniform(0, h)) * np.sin(across)
            )
            inside = strip < rng.uniform(40, 150)
            ang = rng.uniform(0, np.pi)
            s = x * np.cos(ang) + y * np.sin(ang)
            spacing = rng.uniform(5, 16)
            line = np.floor(s / spacing)
            on = inside & ((s % spacing) < rng.uniform(1, 2))
            shares = rng.uniform(0.4, 0.9, int(line.max() - line.min()) + 1)
            share = shares[(line - line.min()).astype(int)] + rng.uniform(-0.02, 0.02, (h, w))
            drop = on & (rng.random((h, w)) < rng.uniform(0.1, 0.3))
            new = np.where(drop, 0.0, np.where(on, d * share, d))
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def skew_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set L (written and sealed 2026-11-27, before the scene's 16-stripe upkeep ran on it; opened the same
    day to judge it). One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-K, each
    reading as a plausible surface in the wrong place:

    * row skew: another sensor's pulses shift this one's scan timing in a band of rows (20-120 px tall): each
      row there is read from 4-30 px to one side (the shift growing or shrinking across the band), and 5-15%
      of the band's pixels drop out;
    * mirror ghost: a rectangle (10-30% of the view) where this sensor reads the scene's mirror image (left to
      right, or top to bottom) wherever that is nearer, at 60-100% of its pixels.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.5% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "l")
    skew = rng.random() < 0.5  # the first draw picks the model (``kind``)
    for _ in range(20):
        new = d.copy()
        if skew:
            tall = int(rng.integers(20, 121))
            r0 = int(rng.integers(0, h - tall))
            ends = rng.uniform(4, 30, 2) * rng.choice([-1, 1])
            for j, r in enumerate(range(r0, r0 + tall)):
                new[r] = np.roll(d[r], round(ends[0] + (ends[1] - ends[0]) * j / tall))
            band = np.zeros((h, w), bool)
            band[r0 : r0 + tall] = True
            new[band & (rng.random((h, w)) < rng.uniform(0.05, 0.15))] = 0.0
        else:
            area = rng.uniform(0.10, 0.30) * h * w
            rh = int(min(h, np.sqrt(area / rng.uniform(0.6, 1.6))))
            rw = int(min(w, area / rh))
            y0, x0 = int(rng.integers(0, h - rh + 1)), int(rng.integers(0, w - rw + 1))
            mirror = d[:, ::-1] if rng.random() < 0.5 else d[::-1, :]
            box = np.zeros((h, w), bool)
            box[y0 : y0 + rh, x0 : x0 + rw] = True
            nearer = (mirror > 0) & ((d == 0) | (mirror < d))
            take = box & nearer & (rng.random((h, w)) < rng.uniform(0.6, 1.0))
            new[take] = mirror[take]
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def walk_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set M (written and sealed 2026-11-27, before the scene's shifted windows flagged a frame of it, to
    judge them as flags: decisions.md). Two more ways another sensor's light makes a surface read a few
    centimetres off with almost no dropouts, neither in ``d2sr.sim`` nor in sets A-L:

    * range walk: another sensor's light raises the signal in a spot, and this sensor's timing walks: returns
      read nearer by 1.5-4 cm at the spot's centre, falling off as a Gaussian (sigma 30-120 px, 0.6-1.6 as
      tall as wide); where the spot is brightest (over 90% of its peak) 0-3% of the returns saturate and
      drop out;
    * phase wedge: over a rotated rectangle (20-60% of the view) the depth is off by a ramp that grows
      linearly across it from nothing at one side to 1.5-4 cm at the other, nearer or farther: a tilted
      wrong surface, with no dropouts.

    Pixels that move by more than 1 cm count, as in sets G and H; a draw that moves under 1% of the returns
    is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "m")
    walk = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        ys, xs = np.nonzero(d > 0)
        at = int(rng.integers(0, max(len(ys), 1)))
        py, px = (float(ys[at]), float(xs[at])) if len(ys) else (h / 2, w / 2)  # a returning pixel inside
        if walk:
            sx = rng.uniform(30, 120)
            sy = sx * rng.uniform(0.6, 1.6)
            g = np.exp(-0.5 * (((x - px) / sx) ** 2 + ((y - py) / sy) ** 2))
            new = d - rng.uniform(0.015, 0.04) * g
            new = np.where((g > 0.9) & (rng.random((h, w)) < rng.uniform(0.0, 0.03)), 0.0, new)
        else:
            rot = rng.uniform(0, np.pi)
            u = (x - px) * np.cos(rot) + (y - py) * np.sin(rot)
            v = -(x - px) * np.sin(rot) + (y - py) * np.cos(rot)
            area = rng.uniform(0.2, 0.6) * h * w
            long = np.sqrt(area * rng.uniform(0.6, 1.6))
            wide = area / long
            c0 = rng.uniform(-0.5, 0.5)  # where the pixel lies across the rectangle
            t = u / long + 0.5 + c0
            inside = (t >= 0) & (t <= 1) & (np.abs(v) <= wide / 2)
            ramp = t if rng.random() < 0.5 else 1 - t
            new = np.where(inside, d + rng.choice([-1.0, 1.0]) * rng.uniform(0.015, 0.04) * ramp, d)
        where = (d > 0) & ((np.abs(new - d) > 0.01) | (new == 0))
        if (where & (new > 0)).sum() >= 0.01 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def window_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set N (written and sealed 2026-11-27, before the scene's repair ran by default on it, to judge that
    default: decisions.md). One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-M:

    * window ghost: another sensor's emitter seen through its own cover window: a flat ghost at one depth
      (0.4-1.5 m, tilted by up to 0.3 m across the view) over a blob (3-6 overlapping ellipses, 8-30% of
      the view), read wherever it is nearer than the scene at 40-90% of the blob's pixels; 10-40% of the
      blob's other returns drop out;
    * column crosstalk: another scanner's lines couple into 3-12 groups of columns (2-8 px wide each), which
      read 3-15% nearer (each group its own share, +-1% per pixel), and 5-20% of their pixels drop out.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.5% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "n")
    ghost = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        if ghost:
            blob = np.zeros((h, w), bool)
            share = rng.uniform(0.08, 0.30)
            parts = int(rng.integers(3, 7))
            for _ in range(parts):
                blob |= _ellipse(rng, y, x, share / parts, 1.5 * share / parts) < 1
            ang = rng.uniform(0, 2 * np.pi)
            tilt = rng.uniform(-0.3, 0.3) * ((x * np.cos(ang) + y * np.sin(ang)) / max(h, w))
            plane = rng.uniform(0.4, 1.5) + tilt
            nearer = (d == 0) | (plane < d)
            seen = blob & nearer & (rng.random((h, w)) < rng.uniform(0.4, 0.9))
            drop = blob & ~seen & (rng.random((h, w)) < rng.uniform(0.1, 0.4))
            new = np.where(seen, plane, np.where(drop, 0.0, d))
        else:
            on = np.zeros(w, bool)
            share = np.ones(w)
            for _ in range(int(rng.integers(3, 13))):
                c0 = int(rng.integers(0, w))
                cols = slice(c0, min(w, c0 + int(rng.integers(2, 9))))
                on[cols] = True
                share[cols] = 1 - rng.uniform(0.03, 0.15)
            cols2 = np.broadcast_to(on, (h, w))
            near = d * share[None, :] * (1 + rng.uniform(-0.01, 0.01, (h, w)))
            drop = cols2 & (rng.random((h, w)) < rng.uniform(0.05, 0.2))
            new = np.where(drop, 0.0, np.where(cols2, near, d))
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def blotch_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set O (written and sealed 2026-11-27, before the scene's repair trusted returns at ``RANGE_RATE`` on
    it, to judge that: decisions.md). One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in
    sets A-N:

    * flying edges: another sensor's light mixes the two sides of the scene's range edges: pixels within
      2-8 px of an edge (of some edges: 40-90% of the view's) read a depth between its two sides (uniform),
      and 0-10% of them drop out;
    * blotch field: over an ellipse (15-40% of the view) the depth reads off by smooth blotches (white noise
      blurred over 3-10 px, scaled to 3-8 cm at its largest), either way, with no dropouts.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.5% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "o")
    flying = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        if flying:
            filled = cv2.dilate(d.astype(np.float32), np.ones((5, 5), np.uint8))
            near = cv2.erode(np.where(filled > 0, filled, np.float32(1e3)), np.ones((5, 5), np.uint8))
            edge = ((filled - near) > 0.1).astype(np.uint8)  # a step of more than 10 cm within 5 px
            keep = cv2.resize(rng.random((6, 8)).astype(np.float32), (w, h), interpolation=cv2.INTER_NEAREST)
            edge *= (keep < rng.uniform(0.4, 0.9)).astype(np.uint8)
            reach = int(rng.integers(2, 9))
            band = cv2.dilate(edge, np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
            lo = cv2.erode(
                np.where(d > 0, d, 1e3).astype(np.float32), np.ones((2 * reach + 1,) * 2, np.uint8)
            )
            hi = cv2.dilate(d.astype(np.float32), np.ones((2 * reach + 1,) * 2, np.uint8))
            mix = lo + rng.random((h, w)) * (hi - lo)
            where = band & (d > 0) & (lo < 1e3)
            new = np.where(where, mix, d)
            new = np.where(where & (rng.random((h, w)) < rng.uniform(0.0, 0.1)), 0.0, new)
        else:
            region = _ellipse(rng, y, x, 0.15, 0.40) < 1
            noise = cv2.GaussianBlur(
                rng.standard_normal((h, w)).astype(np.float32), (0, 0), rng.uniform(3, 10)
            )
            noise /= max(float(np.abs(noise).max()), 1e-9)
            new = np.where(region & (d > 0), d + rng.uniform(0.03, 0.08) * noise, d)
        changed = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (changed & (d > 0)).sum() >= 0.005 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, changed, scale)


def spark_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set P (written and sealed 2026-11-27, before far-off returns flagged a frame of it, to judge them as
    flags: decisions.md). One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-O:

    * spark segments: another scanner's beam glints along 30-300 short strokes (3-30 px long, 1 px wide, at
      random angles) over a half-plane of the view; on them this sensor reads 20-80% of the depth (a nearer
      ghost; each stroke its own share), and a fifth of their pixels drop out;
    * echo rings: thin rings (1-2 px wide, 8-25 px apart) over a disc (80-250 px in radius) centred anywhere,
      on which 50-90% of the returns read a later echo, 1.2-1.6 times their depth.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns is drawn again (thin strokes cover little)."""
    rng, h, w, d = _start(frame, scale, seed, "p")
    sparks = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        new = d.copy()
        if sparks:
            a2 = rng.uniform(0, 2 * np.pi)
            side = (x - rng.uniform(0, w)) * np.cos(a2) + (y - rng.uniform(0, h)) * np.sin(a2) > 0
            strokes = np.zeros((h, w), np.uint8)
            share = np.ones((h, w))
            for _ in range(int(rng.integers(30, 301))):
                x0, y0 = rng.uniform(0, w), rng.uniform(0, h)
                ang, length = rng.uniform(0, np.pi), rng.uniform(3, 30)
                one = np.zeros((h, w), np.uint8)
                end = (int(x0 + length * np.cos(ang)), int(y0 + length * np.sin(ang)))
                cv2.line(one, (int(x0), int(y0)), end, 1, 1)
                strokes |= one
                share[one > 0] = rng.uniform(0.2, 0.8)
            on = (strokes > 0) & side & (d > 0)
            new = np.where(on, d * share, d)
            new[on & (rng.random((h, w)) < 0.2)] = 0.0
        else:
            r = np.hypot(x - rng.uniform(0, w), y - rng.uniform(0, h))
            spacing = rng.uniform(8, 25)
            ring = (r < rng.uniform(80, 250)) & ((r % spacing) < rng.uniform(1, 2))
            on = ring & (d > 0) & (rng.random((h, w)) < rng.uniform(0.5, 0.9))
            new = np.where(on, d * rng.uniform(1.2, 1.6), d)
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def rain_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set Q (written and sealed 2026-11-27, before far-off returns counted over every return ran on it, to
    judge that: decisions.md). One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-P:

    * dash rain: another scanner's fast axis streaks a band of the view (a third to all of it, across) with
      200-1500 short dashes, 1 px wide and 2-12 px long, tilted by up to 20 degrees from vertical, on which
      this sensor reads a later echo, 1.3-2 times the depth, and a tenth of their pixels drop out;
    * grid glints: over an ellipse (15-45% of the view) single pixels and small plus signs (5 px) on a grid
      every 10-30 px, rotated, where this sensor reads the other sensor's emitter at one depth (0.3-1 m).

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.1% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "q")
    rain = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        if rain:
            span = rng.uniform(1 / 3, 1.0) * w
            x0 = rng.uniform(0, w - span)
            dashes = np.zeros((h, w), np.uint8)
            for _ in range(int(rng.integers(200, 1501))):
                px, py = rng.uniform(x0, x0 + span), rng.uniform(0, h)
                ang = np.pi / 2 + rng.uniform(-0.35, 0.35)
                length = rng.uniform(2, 12)
                end = (int(px + length * np.cos(ang)), int(py + length * np.sin(ang)))
                cv2.line(dashes, (int(px), int(py)), end, 1, 1)
            on = (dashes > 0) & (d > 0)
            new = np.where(on, d * rng.uniform(1.3, 2.0), d)
            new[on & (rng.random((h, w)) < 0.1)] = 0.0
        else:
            region = _ellipse(rng, y, x, 0.15, 0.45) < 1
            rot, step = rng.uniform(0, np.pi), rng.uniform(10, 30)
            u = (x * np.cos(rot) + y * np.sin(rot)) % step
            v = (-x * np.sin(rot) + y * np.cos(rot)) % step
            dot = (u < 1) & (v < 1)
            plus = cv2.dilate(dot.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))) > 0
            glint = region & (plus if rng.random() < 0.5 else dot)
            new = np.where(glint, rng.uniform(0.3, 1.0), d)
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if (where & (d > 0)).sum() >= 0.001 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def dark_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set R (written and sealed 2026-11-27, before the scene's repair kept only returns near their depth
    where it seldom returns, to judge that: decisions.md). Interference where this sensor returns little.
    One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-Q:

    * dark fill: over an ellipse (15-40% of the view), another sensor's light makes 30-70% of this frame's
      dropouts return, at a smooth wrong surface 0.5-2 m away (tilted by up to 0.5 m across the view), and
      reads 10% of its returns there 10-30% nearer;
    * edge spray: within 2-4 px of the scene's range edges (of some edges: 40-90% of the view's), 30-60% of
      the pixels read a depth drawn between 0.5 and 1.5 times their own, and dropouts there return at such a
      depth of a neighbour.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns or dropouts is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "r")
    dark = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(20):
        if dark:
            region = _ellipse(rng, y, x, 0.15, 0.40) < 1
            ang = rng.uniform(0, 2 * np.pi)
            plane = rng.uniform(0.5, 2.0) + rng.uniform(-0.5, 0.5) * (
                (x * np.cos(ang) + y * np.sin(ang)) / max(h, w)
            )
            lit = region & (d == 0) & (rng.random((h, w)) < rng.uniform(0.3, 0.7))
            near = region & (d > 0) & (rng.random((h, w)) < 0.1)
            new = np.where(lit, plane, np.where(near, d * rng.uniform(0.7, 0.9, (h, w)), d))
        else:
            filled = cv2.dilate(d.astype(np.float32), np.ones((5, 5), np.uint8))
            low = cv2.erode(np.where(filled > 0, filled, np.float32(1e3)), np.ones((5, 5), np.uint8))
            edge = ((filled - low) > 0.1).astype(np.uint8)
            keep = cv2.resize(rng.random((6, 8)).astype(np.float32), (w, h), interpolation=cv2.INTER_NEAREST)
            edge *= (keep < rng.uniform(0.4, 0.9)).astype(np.uint8)
            reach = int(rng.integers(2, 5))
            band = cv2.dilate(edge, np.ones((2 * reach + 1,) * 2, np.uint8)) > 0
            spray = band & (rng.random((h, w)) < rng.uniform(0.3, 0.6))
            source = np.where(d > 0, d, filled)
            new = np.where(spray & (source > 0), source * rng.uniform(0.5, 1.5, (h, w)), d)
        where = (np.abs(new - d) > 0.02) & ((d > 0) | (new > 0))
        if where.sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)


def veil_interference(frame: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """Set S (written and sealed 2026-11-27, before the scene's repair filled sparser patches where the
    scene nearly always returns, to judge that: decisions.md). Stray light another sensor scatters into this
    one. One of two models, chosen by the seed, neither in ``d2sr.sim`` nor in sets A-R:

    * speckle veil: 1-3 soft blobs (each 8-30% of the view) of another sensor's diffuse light; a return
      inside reads a haze 3-25% nearer than its surface with a chance that falls off from the blob's centre
      (25-60% there, none at its rim), and 5% of those drop out instead;
    * beam scatter: 3-12 straight bands (3-9 px wide, at random angles) where a scanning beam's scattered
      light lands; 20-50% of their returns read a depth pulled 30-80% of the way toward a plane 0.4-1.5 m
      away.

    Pixels that change by more than 2 cm count, with their dropouts; a draw that changes under 0.2% of the
    returns is drawn again."""
    rng, h, w, d = _start(frame, scale, seed, "s")
    veil = rng.random() < 0.5  # the first draw picks the model (``kind``)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    has = d > 0
    for _ in range(20):
        new = d.copy()
        if veil:
            chance = np.zeros((h, w))
            for _ in range(int(rng.integers(1, 4))):
                r2 = _ellipse(rng, y, x, 0.08, 0.30)
                chance = np.maximum(chance, rng.uniform(0.25, 0.6) * np.clip(1 - r2, 0, 1))
            hit = has & (rng.random((h, w)) < chance)
            new = np.where(hit, d * (1 - rng.uniform(0.03, 0.25, (h, w))), d)
            new = np.where(hit & (rng.random((h, w)) < 0.05), 0.0, new)
        else:
            band = np.zeros((h, w), bool)
            for _ in range(int(rng.integers(3, 13))):
                ang = rng.uniform(0, np.pi)
                s_ = x * np.cos(ang) + y * np.sin(ang)
                at = rng.uniform(s_.min(), s_.max())
                band |= np.abs(s_ - at) < rng.uniform(1.5, 4.5)
            hit = band & has & (rng.random((h, w)) < rng.uniform(0.2, 0.5))
            plane = rng.uniform(0.4, 1.5)
            new = np.where(hit, d + rng.uniform(0.3, 0.8) * (plane - d), d)
        where = (np.abs(new - d) > 0.02) & (has | (new > 0))
        if where.sum() >= 0.002 * max(int(np.count_nonzero(d)), 1):
            break
    return _written(frame, new, where, scale)
