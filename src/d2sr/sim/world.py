"""Several sensors posed in one room: which parts of each image the others light (from geometry), the
overlap graph that feeds the timing world, and a moving robot's trajectory."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from d2sr.errors import ConfigError
from d2sr.frames.base import Intrinsics
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.rooms import L515_INTRINSICS, Pose, Renderer, Room, along_loop, make_room

__all__ = ["Rig", "Trajectory", "direct_view", "lit_region", "make_rig", "overlap_graph"]


@dataclass(frozen=True)
class Trajectory:
    """A robot driving a closed loop of waypoints at constant speed, looking where it goes."""

    waypoints: tuple[tuple[float, float], ...]
    speed: float = 0.5
    height: float = 0.9

    def pose(self, t: float) -> Pose:
        p, heading = along_loop(self.waypoints, t * self.speed)
        return Pose(float(p[0]), float(p[1]), self.height, float(np.arctan2(heading[1], heading[0])), -0.05)


@dataclass(frozen=True)
class Rig:
    """Sensors in one room; sensor ``i`` follows ``trajectories[i]`` when it has one, else ``poses[i]``."""

    room: Room
    poses: tuple[Pose, ...]
    trajectories: tuple[Trajectory | None, ...]
    intr: Intrinsics = L515_INTRINSICS

    @property
    def n(self) -> int:
        return len(self.poses)

    def pose(self, i: int, t: float) -> Pose:
        tr = self.trajectories[i]
        return self.poses[i] if tr is None else tr.pose(t)

    def moving(self) -> bool:
        return any(tr is not None for tr in self.trajectories)


def make_rig(
    seed: int,
    sensors: int = 3,
    moving_robot: bool = False,
    people: int | None = None,
    intr: Intrinsics = L515_INTRINSICS,
) -> Rig:
    """Sensors around the walls of a random room, all looking into the middle (so their views overlap, as
    in the paper's stationary arc); with ``moving_robot`` the last one drives a loop through the room."""
    if sensors < 1:
        raise ConfigError(f"need at least one sensor, got {sensors}")
    rng = np.random.default_rng([seed, 0x816])
    base = make_room(seed, people=0)
    lx, ly, _ = base.size
    fixed = sensors - 1 if moving_robot else sensors
    poses = []
    for k in range(fixed):
        a = 2 * np.pi * (k / max(fixed, 1)) + rng.uniform(-0.3, 0.3)
        x = lx / 2 + (lx / 2 - 0.25) * np.clip(1.3 * np.cos(a), -1, 1)
        y = ly / 2 + (ly / 2 - 0.25) * np.clip(1.3 * np.sin(a), -1, 1)
        yaw = np.arctan2(ly / 2 - y, lx / 2 - x) + rng.uniform(-0.35, 0.35)
        poses.append(
            Pose(float(x), float(y), float(rng.uniform(1.0, 1.8)), float(yaw), float(rng.uniform(-0.2, 0.0)))
        )
    trajs: list[Trajectory | None] = [None] * fixed
    if moving_robot:
        m = 1.0
        loop = ((m, m), (lx - m, m), (lx - m, ly - m), (m, ly - m))
        tr = Trajectory(loop, speed=float(rng.uniform(0.3, 0.6)))
        trajs.append(tr)
        poses.append(tr.pose(0.0))
    room = make_room(seed, cameras=poses, people=people, size=base.size)
    return Rig(room, tuple(poses), tuple(trajs), intr)


def lit_region(
    victim: Renderer, depth: np.ndarray, source: Renderer, source_depth: np.ndarray, max_range: float = 9.0
) -> np.ndarray:
    """Pixels of the victim whose surface point the source's laser reaches (inside its field of view,
    within range and not hidden from it): where scattering interference can appear."""
    assert victim.pose is not None and source.pose is not None
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w]
    ax = victim.pose.axes()
    cam = (
        np.stack(
            [
                (u + 0.5 - victim.intr.px) / victim.intr.fx,
                (v + 0.5 - victim.intr.py) / victim.intr.fy,
                np.ones((h, w)),
            ],
            -1,
        )
        * depth[..., None]
    )
    pts = victim.pose.position + cam @ ax
    su, sv, sz = source.project(pts)
    inside = (depth > 0) & (sz > 0.1) & (sz < max_range) & (su >= 0) & (su < source.intr.width)
    inside &= (sv >= 0) & (sv < source.intr.height)
    iu = np.clip(np.nan_to_num(su).astype(np.int64), 0, source.intr.width - 1)
    iv = np.clip(np.nan_to_num(sv).astype(np.int64), 0, source.intr.height - 1)
    seen = sz <= source_depth[iv, iu] * 1.03 + 0.05  # not behind what the source sees there
    return inside & seen


def direct_view(victim: Renderer, depth: np.ndarray, source: Renderer) -> tuple[float, float] | None:
    """Where the source's emitter appears in the victim's image when the two face each other with nothing
    in between (direct interference); None otherwise."""
    assert victim.pose is not None and source.pose is not None
    us, vs, zs = victim.project(source.pose.position[None])
    u, v, z = float(us[0]), float(vs[0]), float(zs[0])
    if not (z > 0.1 and 0 <= u < victim.intr.width and 0 <= v < victim.intr.height):
        return None
    if depth[int(v), int(u)] and depth[int(v), int(u)] < z * 0.97:
        return None  # something stands in between
    _, _, back = source.project(victim.pose.position[None])
    su, sv, _ = source.project(victim.pose.position[None])
    if not (back[0] > 0.1 and 0 <= su[0] < source.intr.width and 0 <= sv[0] < source.intr.height):
        return None
    return u, v


def overlap_graph(rig: Rig, duration_s: float, min_share: float = 0.02) -> OverlapGraph:
    """Directed edges source -> victim where the source lights at least ``min_share`` of the victim's image
    or faces it directly; scheduled per second when a sensor moves."""
    steps = max(1, int(np.ceil(duration_s))) if rig.moving() else 1
    pairs = [(a, b) for a in range(rig.n) for b in range(rig.n) if a != b]
    live = np.zeros((len(pairs), steps), dtype=bool)
    small = rig.intr.scaled(160, 120)  # the share of lit pixels does not need full resolution
    cams = [Renderer(rig.room, small) for _ in range(rig.n)]
    for s in range(steps):
        depths = []
        for i, c in enumerate(cams):
            pose = rig.pose(i, float(s))
            if c.pose != pose:
                c.move(pose)
            depths.append(c.static().depth)
        for e, (a, b) in enumerate(pairs):
            lit = lit_region(cams[b], depths[b], cams[a], depths[a])
            live[e, s] = lit.mean() >= min_share or direct_view(cams[b], depths[b], cams[a]) is not None
    src = np.array([p[0] for p in pairs], dtype=np.int64)
    dst = np.array([p[1] for p in pairs], dtype=np.int64)
    if steps == 1:
        keep = live[:, 0]
        return OverlapGraph(rig.n, src[keep], dst[keep])
    return OverlapGraph(rig.n, src, dst, live=live)
