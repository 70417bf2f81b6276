"""Generated training and test frames (numpy only): simulated rooms seen by several kinds of depth sensor,
and the wide interference generator on half of the frames.

Each frame is a pure function of its seed, so a data set is reproducible from (seed, count) alone and the
test set (other seeds) never overlaps the training set. Cameras stand by a wall looking across a room (like
the shared captures), belong to a multi-sensor rig with people walking (hard negatives), or stand anywhere
in a room of any size, at any height and tilt (far walls, floors filling the view). The sensor kind
(``sim.sensors``: L515, stereo, time of flight, structured light) sets the clean frame's artefacts and its
depth scale; the interference comes from ``sim.families``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from d2sr.atomic import atomic_dir
from d2sr.errors import InputError
from d2sr.frames.overlap import processes
from d2sr.sim.calibrate import static_camera
from d2sr.sim.families import WideSettings, wide_interference
from d2sr.sim.rooms import L515, Pose, Renderer, SensorModel, SensorNoise, make_room
from d2sr.sim.sensors import SENSOR_KINDS, observe, randomized_l515
from d2sr.sim.world import make_rig

__all__ = [
    "TEST_SEED",
    "VALIDATION_SEED",
    "SynthSet",
    "generate",
    "synth_frame",
    "synth_sequence_frame",
]

TEST_SEED = 1_000_000  # test sets start here; training seeds stay below
VALIDATION_SEED = 900_000  # choices made after training (mask threshold, int8 calibration): never tested on
FPS = 30.0  # how far back "the last clean frame" lies
VERSION = 6  # of the generator: data sets made by another version are not reused
KIND_WEIGHTS = (0.4, 0.25, 0.2, 0.15)  # l515, stereo, tof, structured: the L515 stays the main sensor


def synth_frame(
    seed: int, interfered: bool, config: WideSettings | None = None
) -> tuple[np.ndarray, np.ndarray, float]:
    """(frame, clean, depth scale), 480x640 uint16; frame == clean when not interfered."""
    s = synth_sequence_frame(seed, interfered, config, previous=False)
    return s.frame, s.clean, s.scale


def _camera(seed: int, rng: np.random.Generator, t: float) -> tuple[Renderer, Callable[[float], Renderer]]:
    """A camera at time ``t`` and how to render it at another time (a rig's robot moves)."""
    pick = rng.random()
    if pick < 0.3:
        cam = static_camera(seed)
        return cam, lambda _: cam
    if pick < 0.65:
        rig = make_rig(
            seed,
            sensors=int(rng.integers(2, 5)),
            moving_robot=bool(rng.random() < 0.3),
            people=int(rng.integers(0, 4)),
        )
        me = int(rng.integers(rig.n))
        return Renderer(rig.room, rig.intr, rig.pose(me, t)), lambda s: Renderer(
            rig.room, rig.intr, rig.pose(me, s)
        )
    size = (float(rng.uniform(3.0, 20.0)), float(rng.uniform(3.0, 14.0)), float(rng.uniform(2.3, 5.0)))
    pose = Pose(
        float(rng.uniform(0.3, size[0] - 0.3)),
        float(rng.uniform(0.3, size[1] - 0.3)),
        float(rng.uniform(0.2, 2.0)),
        float(rng.uniform(-np.pi, np.pi)),
        float(rng.uniform(-0.7, 0.25)),
    )
    room = make_room(seed, cameras=[pose], people=int(rng.integers(0, 3)), size=size)
    cam = Renderer(room, pose=pose)
    return cam, lambda _: cam


class Synth(NamedTuple):
    frame: np.ndarray  # uint16, what the sensor delivered
    clean: np.ndarray  # the same without interference
    previous: np.ndarray | None  # the sensor's last clean frame
    scale: float  # depth units per metre
    kind: str  # sensor kind (sim.sensors)
    families: list[str]  # interference families drawn (empty: clean)


def synth_sequence_frame(
    seed: int,
    interfered: bool,
    config: WideSettings | None = None,
    previous: bool = True,
    sensor: SensorModel | None = None,
) -> Synth:
    """One generated frame. The last clean frame is the same camera 1 to 12 frames earlier (people have
    walked, a robot has moved), seen by the same sensor. The frame is the same with and without
    ``previous`` (its extra draws come from their own stream). ``sensor``: the L515 fit that L515 frames
    are drawn around (default: the shipped fit, ``sim.scene.L515``)."""
    rng = np.random.default_rng([seed, 0x7EA1])
    t = float(rng.uniform(0, 60))
    cam, at = _camera(seed, rng, t)
    kind = str(rng.choice(SENSOR_KINDS, p=KIND_WEIGHTS))
    scene = cam.render(t)
    noise = None
    if kind == "l515":
        noise = SensorNoise(randomized_l515(sensor or L515, rng), scene.depth.shape, seed)
        for _ in range(int(rng.integers(0, 3))):  # speckle field at a random point of its evolution
            noise.observe(scene)
    draws = np.random.default_rng([seed, 0x5E50])
    clean, scale = observe(kind, scene, draws, noise)
    prev = None
    if previous:
        back = int(np.random.default_rng([seed, 0xBAC4]).integers(1, 13)) / FPS
        prev, _ = observe(kind, at(t - back).render(t - back), draws, noise)
    if not interfered:
        return Synth(clean, clean, prev, scale, kind, [])
    frame, _, families = wide_interference(clean, scale, seed, config)
    return Synth(frame, clean, prev, scale, kind, families)


def _chunk(args: tuple[Path, int, int, int, bool, WideSettings | None, SensorModel | None]) -> list[dict]:
    root, start, stop, seed, previous, config, sensor = args
    frames = np.load(root / "frames.npy", mmap_mode="r+")
    clean = np.load(root / "clean.npy", mmap_mode="r+")
    prev = np.load(root / "previous.npy", mmap_mode="r+") if previous else None
    rows = []
    for i in range(start, stop):
        s = synth_sequence_frame(seed + i, bool(i % 2), config, previous, sensor)
        frames[i], clean[i] = s.frame, s.clean
        if prev is not None:
            prev[i] = s.previous
        share = float((s.frame != s.clean).mean())
        rows.append({"scale": s.scale, "share": share, "kind": s.kind, "families": s.families})
    for a in (frames, clean, prev):
        if a is not None:
            a.flush()
    return rows


def generate(
    out: Path,
    count: int,
    seed: int = 0,
    workers: int = 2,
    progress: Callable[[int], None] | None = None,
    previous: bool = False,
    config: WideSettings | None = None,
    sensor: SensorModel | None = None,
) -> Path:
    """Write ``count`` frames (odd indices interfered) as ``frames.npy``, ``clean.npy`` (uint16 memory
    maps) and ``meta.json`` (each frame's depth scale and interfered share), atomically; with
    ``previous``, each frame's last clean frame as ``previous.npy``; ``sensor``: the L515 fit (as in
    ``synth_sequence_frame``)."""
    if count < 2:
        raise InputError(f"a data set needs at least 2 frames, got {count}")
    with atomic_dir(out) as tmp:
        for name in ("frames.npy", "clean.npy") + (("previous.npy",) if previous else ()):
            np.lib.format.open_memmap(tmp / name, "w+", np.uint16, (count, 480, 640)).flush()
        step = 50
        jobs = [(tmp, a, min(a + step, count), seed, previous, config, sensor) for a in range(0, count, step)]
        rows: list[dict] = []
        with processes(max(workers, 1)) as pool:
            for part in pool.map(_chunk, jobs):
                rows += part
                if progress:
                    progress(len(part))
        meta = {
            "seed": seed,
            "count": count,
            "version": VERSION,
            "families": list((config or WideSettings()).families),
            "sensor": (sensor or L515).model_dump(),
            "scales": [r["scale"] for r in rows],
            "mask_share": [r["share"] for r in rows],
            "kinds": [r["kind"] for r in rows],
            "frame_families": [r["families"] for r in rows],
        }
        (tmp / "meta.json").write_text(json.dumps(meta))
    return out


class SynthSet:
    """A generated data set on disk: frames, clean frames, labels (interfered = any pixel changed)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        try:
            self.meta = json.loads((root / "meta.json").read_text())
            self.frames = np.load(root / "frames.npy", mmap_mode="r")
            self.clean = np.load(root / "clean.npy", mmap_mode="r")
            prev = root / "previous.npy"
            self.previous = np.load(prev, mmap_mode="r") if prev.is_file() else None
        except (OSError, ValueError) as exc:
            raise InputError(f"{root}: not a generated data set ({exc})") from None
        if self.meta.get("version") != VERSION:
            raise InputError(f"{root}: made by an older generator; delete it to generate it again")
        self.scales = np.asarray(self.meta["scales"], np.float32)
        self.labels = np.array([s > 0 for s in self.meta["mask_share"]])
        self.kinds: list[str] = self.meta["kinds"]
        self.families: list[list[str]] = self.meta["frame_families"]

    def __len__(self) -> int:
        return len(self.labels)

    def metres(self, i: int, clean: bool = False) -> np.ndarray:
        """Frame ``i`` (or its clean frame) in metres."""
        return np.asarray((self.clean if clean else self.frames)[i], np.float32) / self.scales[i]
