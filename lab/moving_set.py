"""Sequences of a moving sensor with interference the project's models never saw, for the moving-sensor scene
reference (issue 42). The simulator's moving robot (its own L515, people walking), every frame with its
odometry; about half the frames corrupted.

* ``dev``: rooms of seeds 0-2 corrupted by set G's CW-ToF light (``bench.outside``'s ``tof_interference``), an open
  set: what the reference's tolerance and threshold were chosen on.
* ``j`` (written and sealed 2026-11-27, before the moving reference ran on it; its rule is in
  lab/notes/decisions.md): rooms of seeds 100-103, never rendered before, corrupted by
  ``passing_tof``, which is in neither ``d2sr.sim`` nor sets A-I; the odometry the reference gets drifts
  as a robot's does.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from d2sr.frames.base import Intrinsics
from d2sr.jobs.session import odometry, rig_intrinsics
from d2sr.sim.lockstep import SimRoom
from d2sr.sim.rooms import Room
from d2sr.sim.timing import TimingSettings
from d2sr.sim.world import make_rig
from d2sr.synth.warp import Pose

SEEDS = {"dev": (0, 1, 2), "j": (100, 101, 102, 103)}
SECONDS = 5.0


@dataclass(frozen=True)
class Shot:
    depth: np.ndarray  # uint16, what the sensor gave (corrupted or not)
    interfered: bool
    pose: Pose  # camera to world, as odometry gives it (drifting in set j)
    scale: float
    intrinsics: Intrinsics


def sequences(which: str) -> Iterator[list[Shot]]:
    """Each room's sequence of the robot's frames, in time order."""
    from bench.outside.sets_a_i import tof_interference

    for seed in SEEDS[which]:
        rig = make_rig(seed, sensors=1, moving_robot=True)
        room = SimRoom(rig, TimingSettings.make(active_frames=30), seed=seed, seconds=SECONDS, render=True)
        k, scale = rig_intrinsics(rig), float(room.model.depth_scale)
        rng = np.random.default_rng(7000 + seed)
        other = _other_camera(rng, rig.room) if which == "j" else None
        drift = Pose.identity()
        out = []
        for i, ev in enumerate(room.slots(SECONDS)):
            f = ev.frame
            if f is None:
                continue
            true = odometry(rig, 0, f.time_s)
            bad = (which == "dev" and i % 2 == 1) or (which == "j" and bool(rng.random() < 0.5))
            if which == "j":
                drift = drift.then(_step(rng))
                depth = passing_tof(f.depth, scale, k, true, other, f.time_s, rng) if bad else f.depth
                # a frame its light barely reaches (under 1% of the returns moved) stays a clean frame
                bad = bad and np.count_nonzero(depth != f.depth) >= 0.01 * max(np.count_nonzero(f.depth), 1)
                depth = depth if bad else f.depth
                pose = true.then(drift)  # what odometry says: the truth moved by the drift so far
            else:
                depth = tof_interference(f.depth, scale, 1000 * seed + i) if bad else f.depth
                pose = true
            out.append(Shot(depth, bad, pose, scale, k))
        yield out


def _step(rng: np.random.Generator) -> Pose:
    """One frame's odometry error: 2 mm and 0.05 degrees (1 sigma), accumulating as a random walk."""
    a = rng.normal(0.0, np.deg2rad(0.05), 3)
    rx, ry, rz = a
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    r = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    r = r @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Pose(r, rng.normal(0.0, 0.002, 3))


@dataclass(frozen=True)
class _Other:
    start: np.ndarray  # world position of the other robot's camera at t = 0 (m)
    velocity: np.ndarray  # m/s
    peak: float  # largest shift (m)
    sign: float  # -1: surfaces read nearer
    reach: float  # how far its light carries (m)


def _other_camera(rng: np.random.Generator, room: Room) -> _Other:
    """Another robot's CW-ToF camera driving through the room at 0.3-0.8 m/s, somewhere in its middle."""
    lo, hi = _bounds(room)
    start = lo + rng.uniform(0.35, 0.65, 3) * (hi - lo)
    start[2] = rng.uniform(0.3, 1.2)
    heading = rng.uniform(0, 2 * np.pi)
    speed = rng.uniform(0.3, 0.8)
    velocity = np.array([np.cos(heading) * speed, np.sin(heading) * speed, 0.0])
    return _Other(start, velocity, rng.uniform(0.02, 0.05), -1.0 if rng.random() < 0.75 else 1.0,
                  rng.uniform(2.0, 5.0))  # fmt: skip


def _bounds(room: Room) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(3), np.asarray(room.size, np.float64)


def passing_tof(
    frame: np.ndarray, scale: float, k: Intrinsics, pose: Pose, other: _Other | None, t: float,
    rng: np.random.Generator,
) -> np.ndarray:  # fmt: skip
    """Set J (written and sealed 2026-11-27, before the moving reference ran on it): another robot's
    continuous-wave ToF camera drives through the room. Its light, from where that camera is now, pulls the
    phase of every surface it reaches: a surface reads shifted (nearer on three sequences in four) by up to
    2-5 cm, falling off with the square of the surface's distance from that camera and fading to nothing at
    its reach, with a ripple as the relative phase turns across the surface. The lit region is anchored in
    the world, so it slides across this sensor's view as both robots move. Where the pull nearly cancels
    this camera's own phasor (1% of lit pixels at most), nothing returns."""
    assert other is not None
    d = frame.astype(np.float64) / scale
    h, w = d.shape
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    cam = np.stack([(u - k.px) / k.fx * d, (v - k.py) / k.fy * d, d], -1)
    world = cam @ np.asarray(pose.R, np.float64).T + np.asarray(pose.t, np.float64)
    src = other.start + other.velocity * t
    r = np.linalg.norm(world - src, axis=-1)
    lit = (d > 0) & (r < other.reach)
    fall = np.clip(1.0 - r / other.reach, 0.0, 1.0) / np.maximum(r, 0.5) ** 2
    ripple = 0.75 + 0.25 * np.sin(2 * np.pi * r / rng.uniform(0.5, 1.5) + rng.uniform(0, 2 * np.pi))
    pull = fall * ripple
    top = float(pull[lit].max()) if lit.any() else 1.0
    new = d + other.sign * other.peak * pull / max(top, 1e-9)
    new = np.where(lit & (rng.random((h, w)) < rng.uniform(0.0, 0.01)), 0.0, new)
    where = lit & (np.abs(new - d) > 0.01)
    out = frame.copy()
    out[where] = np.clip(np.rint(new[where] * scale), 0, 65535).astype(np.uint16)
    return out
