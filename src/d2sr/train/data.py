"""Batches for training: generated frames (``SynthSet``) and users' labelled folders, with flips and a
depth gain as augmentation. Sampling is driven by a numpy generator, so a run is reproducible from its seed
(and each distributed rank draws its own stream)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from d2sr.contract.catalog import scale_at
from d2sr.contract.repair import LINES_UP, agreement
from d2sr.errors import InputError
from d2sr.frames import open_frames
from d2sr.frames.base import Frame, check_depth, probe, to_units
from d2sr.sim.dataset import VERSION, SynthSet, generate
from d2sr.sim.families import shell_interference
from d2sr.sim.rooms import L515, SensorModel
from d2sr.train.config import TrainSettings
from d2sr.train.cwtof import cw_tof_frames, cw_tof_root, moved
from d2sr.ui import warn

__all__ = ["Batch", "Pool", "Source", "synth_set"]

STACK_MAX = 3  # stack_interference: at most this many further patterns on a frame


@dataclass
class Batch:
    x: np.ndarray  # (N, C, H, W) float32 metres: what the sensor delivered (C=2: then an earlier frame)
    y: np.ndarray  # ground-truth depth (metres)
    m: np.ndarray  # true interference mask (float32 0/1)
    label: np.ndarray  # (N,) float32: frame interfered
    taught: tuple[np.ndarray, np.ndarray] | None = None  # a teacher's (mask, depth) like m, y (distillation)


@dataclass
class Source:
    frames: np.ndarray | list[np.ndarray]
    clean: np.ndarray | list[np.ndarray]
    masks: list[np.ndarray] | None
    scale: float | np.ndarray  # depth units per metre: one for the source, or one per frame
    labels: np.ndarray
    previous: np.ndarray | list[np.ndarray] | None = None  # each frame's last clean frame (temporal models)
    skip: np.ndarray | None = None  # frames left out of training (a held-out interference family)


def synth_set(
    cache: Path,
    count: int,
    seed: int,
    progress: bool = True,
    previous: bool = False,
    sensor: SensorModel | None = None,
) -> SynthSet:
    """The generated set for (seed, count), made on first use and kept under ``cache``; ``previous``: with
    each frame's last clean frame (a separate, slower set); ``sensor``: an L515 fit other than the shipped
    one (``TrainSettings.sensor``), kept apart by its hash."""
    fit = ""
    if sensor is not None and sensor != L515:
        fit = "-fit" + hashlib.sha256(sensor.model_dump_json().encode()).hexdigest()[:8]
    root = cache / f"synth-v{VERSION}-{seed}-{count}{'-seq' if previous else ''}{fit}"
    if not (root / "meta.json").is_file():
        if progress:
            from d2sr.ui import progress_bar

            with progress_bar() as bar:
                task = bar.add_task(f"generating {count} frames", total=count)
                advance = lambda n: bar.advance(task, n)  # noqa: E731
                generate(root, count, seed, progress=advance, previous=previous, sensor=sensor)
        else:
            generate(root, count, seed, previous=previous, sensor=sensor)
    return SynthSet(root)


def _cw_tof(ss: SynthSet, count: int, progress: bool) -> Source:
    """The CW-ToF source (``TrainSettings.cw_tof``): each frame with its clean and last clean frame from
    ``ss``; every kept frame interfered."""
    if progress and not (cw_tof_root(ss, count) / "meta.json").is_file():
        from d2sr.ui import progress_bar

        with progress_bar() as bar:
            task = bar.add_task(f"CW-ToF interference on {count} frames", total=count)
            frames, used = cw_tof_frames(ss, count, lambda n: bar.advance(task, n))
    else:
        frames, used = cw_tof_frames(ss, count)
    previous = [ss.previous[i] for i in range(count)] if ss.previous is not None else None
    clean = [ss.clean[i] for i in range(count)]
    masks = [moved(frames[i], clean[i], float(ss.scales[i])) for i in range(count)]
    return Source(frames, clean, masks, ss.scales[:count], used.copy(), previous, ~used)


def _folders(cfg: TrainSettings) -> list[Source]:
    out = []
    for f in cfg.folders:
        src, tgt = open_frames(f.input, f.topic), open_frames(f.target, f.topic)
        frames, clean = [fr.depth for fr in src], [fr.depth for fr in tgt]
        if len(frames) != len(clean) or not frames:
            raise InputError(
                f"{f.input} has {len(frames)} frames, {f.target} has {len(clean)}; need equal, > 0"
            )
        scale = src.depth_scale or 1000.0
        for path, seq in ((f.input, frames), (f.target, clean)):
            for i, d in enumerate(seq):
                if check_depth(d, f"{path} frame {i}").dtype != np.uint16:
                    raise InputError(f"{path} frame {i}: training folders hold 16-bit depth, got {d.dtype}")
            sampled = [
                Frame(f"{path} frame {i}", seq[i]) for i in np.linspace(0, len(seq) - 1, 12).astype(int)
            ]
            for w in probe(sampled, scale):  # the same checks as every command that reads depth
                warn(f"{path}: {w}")
        masks = None
        if f.masks is not None:
            masks = [m.depth > 0 for m in open_frames(f.masks)]
            if len(masks) != len(frames):
                raise InputError(f"{f.masks} has {len(masks)} masks for {len(frames)} frames")
        labels = np.array(
            [m.any() for m in masks]
            if masks
            else [(a != b).any() for a, b in zip(frames, clean, strict=True)]
        )
        out.append(Source(frames, clean, masks, scale, labels))
    return out


def lines_up(frame: np.ndarray, last: np.ndarray, scale: float) -> bool:
    """Whether ``--model auto`` would give this frame (depth units, ``scale`` per metre) to the temporal
    model with ``last`` as its last clean frame (``contract.agreement`` >= ``LINES_UP``)."""
    s = np.float32(scale)
    return agreement(frame.astype(np.float32) / s, last.astype(np.float32) / s) >= LINES_UP


def lay_pattern(frame: np.ndarray, clean: np.ndarray, onto: np.ndarray) -> np.ndarray:
    """``onto`` (same shape and dtype) with ``frame``'s interference laid over it: each pixel ``frame``
    changed from ``clean`` (a return there) takes the same depth ratio on ``onto`` (a dropout stays one)."""
    hit = (frame != clean) & (clean > 0)
    out = onto.copy()
    out[hit] = np.clip(np.rint(onto[hit] * (frame[hit].astype(np.float32) / clean[hit])), 0, 65535).astype(
        onto.dtype
    )
    return out


def mirror_pattern(frame: np.ndarray, clean: np.ndarray) -> np.ndarray:
    """``frame`` with each hit return's depth ratio to ``clean`` inverted (``clean**2 / frame``): a pixel
    read 0.6x too short reads 1/0.6x too far, and the other way round. Dropouts, spurious returns where
    ``clean`` has none, and the pattern's shape stay; values beyond the unit's range clip at its top."""
    hit = (frame != clean) & (clean > 0) & (frame > 0)
    out = frame.copy()
    c = clean[hit].astype(np.float64)
    out[hit] = np.clip(np.rint(c * c / frame[hit]), 1, np.iinfo(frame.dtype).max).astype(frame.dtype)
    return out


def warp_interference(
    rng: np.random.Generator, frame: np.ndarray, clean: np.ndarray, mask: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(frame, mask) with the interference moved by a smooth random displacement (2-16 px over 16-64 px):
    its bands bend, its blobs stretch, its edges wander, while the scene stays. The values a pattern puts
    on the scene travel with it, so the mask cannot learn a family's exact shape, only what interference
    does to depth. The mask is what then differs from ``clean``."""
    h, w = frame.shape
    cell = rng.uniform(16, 64)
    gh, gw = max(int(h / cell), 1) + 2, max(int(w / cell), 1) + 2
    amp = rng.uniform(2, 16)
    grid = rng.standard_normal((2, gh, gw)).astype(np.float32)
    dy, dx = (cv2.resize(g, (w, h), interpolation=cv2.INTER_CUBIC) for g in grid)
    dy, dx = (amp * d / max(float(np.abs(d).max()), 1e-6) for d in (dy, dx))
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    my, mx = yy + dy, xx + dx
    moved = cv2.remap(np.ascontiguousarray(frame), mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REFLECT)
    hit = cv2.remap(mask.astype(np.uint8), mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REFLECT) > 0
    out = np.where(hit, moved, clean)
    return out, out != clean


@dataclass(frozen=True)
class Augment:
    """How a pool varies its frames beyond the data (``TrainSettings``'s fields of the same meaning):
    ``gate_previous`` (``gate_previous``), the shares of frames whose interference is warped (``warp``),
    stacked (``stack``), mirrored (``mirror``) or shelled (``shell``), and a temporal detector scored
    against its own last clean frame (``clean_previous``)."""

    gate_previous: bool = False
    warp: float = 0.0
    stack: float = 0.0
    mirror: float = 0.0
    clean_previous: bool = False
    shell: float = 0.0


class Pool:
    """All training frames of a run. A temporal recovery model's second input is the sensor's last clean
    frame; a temporal detector's (``raw_previous``) is the sensor's previous frame as delivered, which may
    be interfered itself or missing (see ``_previous``)."""

    def __init__(
        self,
        sources: list[Source],
        frames: int = 1,
        raw_previous: bool = False,
        augment: Augment = Augment(),
    ) -> None:
        if not sources:
            raise InputError("no training data")
        if frames > 1 and any(s.previous is None for s in sources):
            raise InputError("a temporal model needs each frame's last clean frame: generated data only")
        self.sources, self.frames, self.raw_previous = sources, frames, raw_previous
        a = augment
        self.gate_previous, self.clean_previous = a.gate_previous, a.clean_previous
        self.warp, self.stack, self.mirror, self.shell = a.warp, a.stack, a.mirror, a.shell
        self._shares: np.ndarray | None = None  # each drawable frame's share of pixels hit (stack's weights)
        self._lined_up: dict[tuple[int, int], bool] = {}  # (source, frame): each frame is drawn many times
        self.index = [
            (s, i)
            for s, src in enumerate(sources)
            for i in range(len(src.labels))
            if src.skip is None or not src.skip[i]
        ]
        self.labels = np.array([sources[s].labels[i] for s, i in self.index])

    @classmethod
    def from_config(cls, cfg: TrainSettings, progress: bool = True, frames: int = 1) -> Pool:
        sources = []
        if cfg.synthetic:
            ss = synth_set(cfg.cache, cfg.synthetic, cfg.seed, progress, frames > 1, cfg.sensor_model())
            out = set(cfg.leave_out)
            skip = np.array([bool(out & set(f)) for f in ss.families])
            if cfg.task == "detector":
                shares = np.asarray(ss.meta["mask_share"])
                skip |= ss.labels & (shares < cfg.min_share)
            sources.append(Source(ss.frames, ss.clean, None, ss.scales, ss.labels, ss.previous, skip))
            if cfg.cw_tof:
                sources.append(_cw_tof(ss, cfg.cw_tof, progress))
        return cls(
            sources + _folders(cfg),
            frames,
            raw_previous=cfg.task == "detector",
            augment=Augment(
                cfg.gate_previous,
                cfg.warp_interference,
                cfg.stack_interference,
                cfg.mirror_interference,
                cfg.clean_previous,
                cfg.shell_interference,
            ),
        )

    def _previous(self, rng: np.random.Generator, frame: np.ndarray, last: np.ndarray) -> np.ndarray:
        """What a temporal detector sees as the previous frame, given the frame and the sensor's last clean
        one: the frame itself 15% of the time (no sequence: the single-frame path); 35% the last clean frame
        hit by another frame's interference (its mask and depth ratio: patterns change from frame to frame);
        else the last clean frame."""
        u = rng.random()
        if u < 0.15:
            return frame
        hit_frames = np.flatnonzero(self.labels)
        if u >= 0.5 or not len(hit_frames):
            return last
        s, j = self.index[int(rng.choice(hit_frames))]
        f, c = np.asarray(self.sources[s].frames[j]), np.asarray(self.sources[s].clean[j])
        if f.shape != last.shape:
            return last
        return lay_pattern(f, c, last)

    def _stacked(
        self, rng: np.random.Generator, frame: np.ndarray, clean: np.ndarray, mask: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``frame`` with another interfered frame's pattern laid over it too (its mask and depth ratio to its
        own clean frame: a further sensor), that frame drawn in proportion to its share of pixels hit, so
        that heavily hit frames, rare among generated ones, are met. Returns (frame, mask)."""
        if self._shares is None:
            self._shares = np.array(
                [
                    np.mean(np.asarray(self.sources[s].frames[i]) != np.asarray(self.sources[s].clean[i]))
                    if self.labels[k]
                    else 0.0
                    for k, (s, i) in enumerate(self.index)
                ]
            )
        w = self._shares
        if w.sum() <= 0:
            return frame, mask
        s, j = self.index[int(rng.choice(len(w), p=w / w.sum()))]
        f2, c2 = np.asarray(self.sources[s].frames[j]), np.asarray(self.sources[s].clean[j])
        if f2.shape != frame.shape:
            return frame, mask
        out = np.where(mask, frame, lay_pattern(f2, c2, clean))  # the frame's own pattern stays on top
        return out, mask | (out != clean)

    @staticmethod
    def _shell(
        rng: np.random.Generator, frame: np.ndarray, clean: np.ndarray, mask: np.ndarray, scale: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """``frame`` (units) with a depth-shell pattern added where it is not hit yet (its own pattern stays
        on top); returns (frame, mask)."""
        new, where = shell_interference(clean.astype(np.float32) / np.float32(scale), rng)
        out = np.where(where & ~mask, to_units(new, scale), frame)
        return out, mask | (out != clean)

    def _lines_up(self, s: int, i: int, frame: np.ndarray, last: np.ndarray) -> bool:
        key = (s, i)
        if key not in self._lined_up:
            self._lined_up[key] = lines_up(frame, last, scale_at(self.sources[s].scale, i))
        return self._lined_up[key]

    def _pick(self, rng: np.random.Generator, n: int, clean_share: float) -> np.ndarray:
        pos, neg = np.flatnonzero(self.labels), np.flatnonzero(~self.labels)
        if not len(pos) or not len(neg):
            return rng.integers(0, len(self.index), n)
        k = rng.binomial(n, clean_share)
        return np.concatenate([rng.choice(neg, k), rng.choice(pos, n - k)])

    def batch(
        self, rng: np.random.Generator, n: int, crop: tuple[int, int] | None, clean_share: float = 0.5
    ) -> Batch:
        xs, ys, ms, ls = [], [], [], []
        for j in self._pick(rng, n, clean_share):
            s, i = self.index[j]
            src = self.sources[s]
            f, c = np.asarray(src.frames[i]), np.asarray(src.clean[i])
            m = src.masks[i] if src.masks is not None else f != c
            for _ in range(STACK_MAX if self.stack and src.labels[i] else 0):  # each further one as likely
                if rng.random() >= self.stack:
                    break
                f, m = self._stacked(rng, f, c, m)
            if self.mirror and src.labels[i] and rng.random() < self.mirror:
                f = mirror_pattern(f, c)  # the same pixels differ from c: the mask stands
            ins = [f]
            if self.frames > 1 and src.previous is not None:
                last = np.asarray(src.previous[i])
                if self.gate_previous and not self._lines_up(s, i, f, last):
                    last = np.zeros_like(last)
                if self.clean_previous:  # the last clean frame where it lines up, else (and 15%) the frame
                    ins.append(last if rng.random() >= 0.15 and self._lines_up(s, i, f, last) else f)
                else:
                    ins.append(self._previous(rng, f, last) if self.raw_previous else last)
            if crop is not None:
                h, w = f.shape
                ch, cw = min(crop[0], h), min(crop[1], w)
                a, b = int(rng.integers(0, h - ch + 1)), int(rng.integers(0, w - cw + 1))
                ins = [v[a : a + ch, b : b + cw] for v in ins]
                c, m = c[a : a + ch, b : b + cw], m[a : a + ch, b : b + cw]
            if self.warp and src.labels[i] and rng.random() < self.warp:
                ins[0], m = warp_interference(rng, ins[0], c, m)
            if self.shell and src.labels[i] and rng.random() < self.shell:
                ins[0], m = self._shell(rng, ins[0], c, m, scale_at(src.scale, i))
            gain = np.float32(rng.uniform(0.85, 1.15) / scale_at(src.scale, i))
            x, y = np.stack([v.astype(np.float32) * gain for v in ins]), c.astype(np.float32) * gain
            if len(ins) > 1 and not self.raw_previous and rng.random() < 0.1:
                x[1] = 0  # no clean frame yet (start-up): the model must fall back on the fill
            if rng.random() < 0.5:
                x, y, m = x[:, :, ::-1], y[:, ::-1], m[:, ::-1]
            xs.append(x)
            ys.append(y)
            ms.append(m.astype(np.float32))
            # With masks, a crop that holds none of the frame's masked pixels shows a clean frame.
            ls.append(float(src.labels[i] and (src.masks is None or bool(m.any()))))
        return Batch(
            np.ascontiguousarray(np.stack(xs)),
            np.ascontiguousarray(np.stack(ys)[:, None]),
            np.ascontiguousarray(np.stack(ms)[:, None]),
            np.array(ls, np.float32),
        )
