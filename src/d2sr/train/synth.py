"""Generated training and test frames (numpy only): simulated rooms, the calibrated sensor model, and the
simulator's interference on half of the frames.

Each frame is a pure function of its seed, so a data set is reproducible from (seed, count) alone and the
test set (other seeds) never overlaps the training set. Half of the cameras stand by a wall looking across
an empty room (like the shared captures); the others belong to a multi-sensor rig, often with people
walking (hard negatives for the detector), and take their interference only where another rig sensor's
laser lands.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from d2sr.atomic import atomic_dir
from d2sr.errors import InputError
from d2sr.sim.calibrate import static_camera
from d2sr.sim.interference import InterferenceConfig, Interferer, interfere
from d2sr.sim.scene import L515, Renderer, SensorModel, SensorNoise
from d2sr.sim.world import lit_region, make_rig

__all__ = ["TEST_SEED", "VALIDATION_SEED", "SynthSet", "generate", "synth_frame", "synth_sequence_frame"]

TEST_SEED = 1_000_000  # test sets start here; training seeds stay below
VALIDATION_SEED = 900_000  # choices made after training (mask threshold, int8 calibration): never tested on
MIN_REGION = 0.04  # a lit region smaller than this share of the image is treated as "everywhere"


FPS = 30.0  # the L515's frame rate: how far back "the last clean frame" lies


def synth_frame(
    seed: int, interfered: bool, model: SensorModel = L515, config: InterferenceConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(frame, clean) uint16 at ``model.depth_scale``, 480x640; frame == clean when not interfered."""
    frame, clean, _ = synth_sequence_frame(seed, interfered, model, config, previous=False)
    return frame, clean


def synth_sequence_frame(
    seed: int,
    interfered: bool,
    model: SensorModel = L515,
    config: InterferenceConfig | None = None,
    previous: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """``synth_frame`` plus the sensor's last clean frame: the same camera 1 to 12 frames earlier (a moving
    robot has moved, people have walked), observed by the same evolving sensor noise. The frame itself is
    the same as ``synth_frame``'s (the extra draws come after, from their own stream)."""
    rng = np.random.default_rng([seed, 0x7EA1])
    t = float(rng.uniform(0, 60))
    sources: list[Renderer] = []
    rig, me = None, 0
    if rng.random() < 0.5:
        cam = static_camera(seed)
    else:
        rig = make_rig(
            seed,
            sensors=int(rng.integers(2, 5)),
            moving_robot=bool(rng.random() < 0.3),
            people=int(rng.integers(0, 4)),
        )
        me = int(rng.integers(rig.n))
        cam = Renderer(rig.room, rig.intr, rig.pose(me, t))
        sources = [
            Renderer(rig.room, rig.intr.scaled(160, 120), rig.pose(j, t)) for j in range(rig.n) if j != me
        ]
    scene = cam.render(t)
    noise = SensorNoise(_randomized(model, rng), scene.depth.shape, seed)
    for _ in range(int(rng.integers(0, 3))):  # speckle field at a random point of its evolution
        noise.observe(scene)
    clean = noise.observe(scene)
    prev = None
    if previous:
        back = int(np.random.default_rng([seed, 0xBAC4]).integers(1, 13)) / FPS
        past = cam if rig is None else Renderer(rig.room, rig.intr, rig.pose(me, t - back))
        prev = noise.observe(past.render(t - back))
    if not interfered:
        return clean, clean, prev
    shape = clean.shape
    count = int(rng.choice([1, 2, 3], p=[0.6, 0.3, 0.1]))
    its = []
    for j in range(count):
        region = None
        if sources:
            src = sources[j % len(sources)]
            lit = lit_region(cam, scene.depth, src, src.static().depth, model.max_range)
            region = lit if lit.mean() >= MIN_REGION else None
        its.append(Interferer.draw(shape, seed * 8 + j, config, region=region))
    frame, mask = interfere(clean, model.depth_scale, its, int(rng.integers(0, 1000)), seed, None, config)
    if not mask.any():  # pattern missed every pixel: draw again without regions
        its = [Interferer.draw(shape, seed * 8 + j, config) for j in range(count)]
        frame, mask = interfere(clean, model.depth_scale, its, 0, seed, None, config)
    return frame, clean, prev


def _randomized(model: SensorModel, rng: np.random.Generator) -> SensorModel:
    """The calibrated sensor with its noise drawn around the fit. Real units differ from the fit (the L515
    captures speckle at the pixel scale, in sparse salt-like returns on far surfaces), and a detector
    that has seen only one noise texture takes any other for interference."""
    lu = lambda lo, hi: float(np.exp(rng.uniform(np.log(lo), np.log(hi))))  # noqa: E731
    return model.model_copy(
        update={
            "speckle_px": lu(0.4, 2.5),
            "signal_ref": model.signal_ref * lu(0.4, 2.5),
            "signal_shape": float(rng.uniform(0.7, 3.0)),
            "noise_base": model.noise_base * lu(0.5, 2.0),
            "noise_per_m": model.noise_per_m * lu(0.5, 2.0),
            "flicker": float(rng.uniform(0.3, 0.9)),
            "edge_drop": float(rng.uniform(0.2, 0.95)),
        }
    )


def _chunk(args: tuple[Path, int, int, int, bool]) -> list[float]:
    root, start, stop, seed, previous = args
    frames = np.load(root / "frames.npy", mmap_mode="r+")
    clean = np.load(root / "clean.npy", mmap_mode="r+")
    prev = np.load(root / "previous.npy", mmap_mode="r+") if previous else None
    shares = []
    for i in range(start, stop):
        f, c, p = synth_sequence_frame(seed + i, interfered=bool(i % 2), previous=previous)
        frames[i], clean[i] = f, c
        if prev is not None:
            prev[i] = p
        shares.append(float((f != c).mean()))
    for a in (frames, clean, prev):
        if a is not None:
            a.flush()
    return shares


def generate(
    out: Path,
    count: int,
    seed: int = 0,
    workers: int = 2,
    progress: Callable[[int], None] | None = None,
    previous: bool = False,
) -> Path:
    """Write ``count`` frames (odd indices interfered) as ``frames.npy``, ``clean.npy`` (uint16 memory
    maps) and ``meta.json``, atomically; with ``previous``, each frame's last clean frame as
    ``previous.npy``."""
    if count < 2:
        raise InputError(f"a data set needs at least 2 frames, got {count}")
    with atomic_dir(out) as tmp:
        for name in ("frames.npy", "clean.npy") + (("previous.npy",) if previous else ()):
            np.lib.format.open_memmap(tmp / name, "w+", np.uint16, (count, 480, 640)).flush()
        step = 50
        jobs = [(tmp, a, min(a + step, count), seed, previous) for a in range(0, count, step)]
        shares: list[float] = []
        with ProcessPoolExecutor(max_workers=max(workers, 1)) as pool:
            for part in pool.map(_chunk, jobs):
                shares += part
                if progress:
                    progress(len(part))
        meta = {"seed": seed, "count": count, "depth_scale": L515.depth_scale, "mask_share": shares}
        (tmp / "meta.json").write_text(json.dumps(meta))
    return out


class SynthSet:
    """A generated data set on disk: frames, clean frames, labels (interfered = any pixel changed)."""

    def __init__(self, root: Path) -> None:
        try:
            self.meta = json.loads((root / "meta.json").read_text())
            self.frames = np.load(root / "frames.npy", mmap_mode="r")
            self.clean = np.load(root / "clean.npy", mmap_mode="r")
            prev = root / "previous.npy"
            self.previous = np.load(prev, mmap_mode="r") if prev.is_file() else None
        except (OSError, ValueError) as exc:
            raise InputError(f"{root}: not a generated data set ({exc})") from None
        self.depth_scale = float(self.meta["depth_scale"])
        self.labels = np.array([s > 0 for s in self.meta["mask_share"]])

    def __len__(self) -> int:
        return len(self.labels)
