"""Procedural indoor rooms, a ray-casting depth renderer and an L515-like sensor model (numpy + OpenCV).

World frame: x east, y north, z up, metres; a room spans ``[0, size]`` on each axis. Cameras look along
their yaw (from +x, counter-clockwise) tilted by pitch (positive = up); image u goes right, v down.
Depth is z-depth along the optical axis, as depth cameras report it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from pydantic import Field

from d2sr.config import Settings, check_whole
from d2sr.frames.base import Intrinsics

__all__ = [
    "L515",
    "L515_INTRINSICS",
    "Box",
    "Person",
    "Pose",
    "Render",
    "Renderer",
    "Room",
    "SensorModel",
    "SensorNoise",
    "make_room",
]

#: Mean of the two shared L515 captures' intrinsics (../shared/data/l515/*/intrinsics.json).
L515_INTRINSICS = Intrinsics(640, 480, 457.4, 457.3, 312.9, 250.1)
#: Share of surfaces that are dark to the sensor (checked by ``d2sr calibrate``).
DARK = 0.35
MAX_PEOPLE = 20  # walking in one room of at most 8 x 7 m: more is a crowd the renderer takes hours over


@dataclass(frozen=True)
class Pose:
    """Camera position (m) and heading (radians)."""

    x: float
    y: float
    z: float
    yaw: float
    pitch: float = 0.0

    def axes(self) -> np.ndarray:
        """Rows: right, down, forward (camera x, y, z) in world coordinates."""
        cy, sy, cp, sp = np.cos(self.yaw), np.sin(self.yaw), np.cos(self.pitch), np.sin(self.pitch)
        fwd = np.array([cy * cp, sy * cp, sp])
        right = np.array([sy, -cy, 0.0])
        down = np.cross(fwd, right)
        return np.stack([right, down, fwd])

    @property
    def position(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in its own frame, turned by ``yaw`` about its vertical centre line."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    refl: float
    yaw: float = 0.0
    kind: str = "box"

    def corners(self) -> np.ndarray:
        lo, hi = np.array(self.lo), np.array(self.hi)
        c = (lo + hi) / 2
        pts = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        shift = np.array([c[0], c[1], 0.0])
        return _turn(pts - shift, self.yaw) + shift


@dataclass(frozen=True)
class Person:
    """A vertical cylinder walking a closed loop of waypoints at constant speed."""

    waypoints: tuple[tuple[float, float], ...]
    speed: float = 1.0
    radius: float = 0.22
    height: float = 1.75
    refl: float = 0.4

    def at(self, t: float) -> tuple[float, float]:
        p, _ = along_loop(self.waypoints, t * self.speed)
        return float(p[0]), float(p[1])


def along_loop(waypoints: tuple[tuple[float, float], ...], s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and heading after travelling ``s`` metres along a closed loop of waypoints."""
    pts = np.array(waypoints + waypoints[:1], dtype=float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if seg.sum() == 0:
        return pts[0], np.array([1.0, 0.0])
    s %= seg.sum()
    i = min(int(np.searchsorted(np.cumsum(seg), s, side="right")), len(seg) - 1)
    f = (s - seg[:i].sum()) / max(seg[i], 1e-9)
    return pts[i] + f * (pts[i + 1] - pts[i]), pts[i + 1] - pts[i]


@dataclass(frozen=True)
class Room:
    size: tuple[float, float, float]
    #: Reflectivity of the faces x-, x+, y-, y+, floor, ceiling.
    face_refl: tuple[float, ...]
    boxes: tuple[Box, ...] = ()
    people: tuple[Person, ...] = ()


def _turn(p: np.ndarray, yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    out = p.copy()
    out[..., 0] = c * p[..., 0] - s * p[..., 1]
    out[..., 1] = s * p[..., 0] + c * p[..., 1]
    return out


# ---------------------------------------------------------------- room generator
def _furniture(rng: np.random.Generator, size: np.ndarray, keep_out: list[np.ndarray]) -> list[Box]:
    """Tables, chairs, shelves and boxes, mostly along walls, away from ``keep_out`` points (cameras)."""
    out: list[Box] = []
    kinds = rng.choice(
        ["table", "chair", "shelf", "box"], size=int(rng.integers(5, 11)), p=[0.25, 0.3, 0.2, 0.25]
    )
    for kind in kinds:
        for _ in range(20):  # a few tries to place it clear of the cameras
            wall = rng.random() < 0.6 and kind in ("shelf", "box", "table")
            yaw = float(rng.choice([0, np.pi / 2]) if wall else rng.uniform(0, np.pi))
            cx, cy = rng.uniform(0.4, size[0] - 0.4), rng.uniform(0.4, size[1] - 0.4)
            if wall:
                side = int(rng.integers(4))
                cx = 0.35 if side == 0 else size[0] - 0.35 if side == 1 else cx
                cy = 0.35 if side == 2 else size[1] - 0.35 if side == 3 else cy
            if all(np.hypot(cx - k[0], cy - k[1]) > 1.0 for k in keep_out):
                break
        r = _reflectivity(rng)
        out += _piece(str(kind), cx, cy, yaw, r, rng)
    return out


def _reflectivity(rng: np.random.Generator, dark: float = DARK) -> float:
    """Indoor surfaces are either dark to the sensor's infrared (black plastic, glass, screens: almost no
    return) or reasonably bright; that split is what makes real L515 frames about two-thirds zeros."""
    return float(rng.uniform(0.005, 0.03) if rng.random() < dark else rng.uniform(0.3, 1.0))


def _piece(kind: str, cx: float, cy: float, yaw: float, refl: float, rng: np.random.Generator) -> list[Box]:
    def part(dx: float, dy: float, sx: float, sy: float, z0: float, z1: float) -> Box:
        c = _turn(np.array([dx, dy, 0.0]), yaw)
        return Box(
            (cx + c[0] - sx, cy + c[1] - sy, z0), (cx + c[0] + sx, cy + c[1] + sy, z1), refl, yaw, kind
        )

    if kind == "table":
        w, d, h = rng.uniform(0.5, 0.9), rng.uniform(0.35, 0.5), rng.uniform(0.7, 0.78)
        legs = [
            part(sx * (w - 0.04), sy * (d - 0.04), 0.025, 0.025, 0, h - 0.04)
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
        return [part(0, 0, w, d, h - 0.04, h), *legs]
    if kind == "chair":
        s, h = rng.uniform(0.2, 0.25), rng.uniform(0.42, 0.48)
        legs = [
            part(sx * (s - 0.02), sy * (s - 0.02), 0.02, 0.02, 0, h - 0.03)
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
        return [part(0, 0, s, s, h - 0.03, h), part(-s + 0.02, 0, 0.02, s, h, h + 0.45), *legs]
    if kind == "shelf":
        return [part(0, 0, rng.uniform(0.15, 0.25), rng.uniform(0.4, 0.8), 0, rng.uniform(1.5, 2.1))]
    e = rng.uniform(0.15, 0.4)
    return [part(0, 0, e, rng.uniform(0.15, 0.4), 0, 2 * rng.uniform(0.15, 0.4))]


def make_room(
    seed: int,
    cameras: list[Pose] | None = None,
    people: int | None = None,
    size: tuple[float, float, float] | None = None,
) -> Room:
    """A random furnished room (4-8 m by 4-7 m); furniture keeps clear of the given camera positions."""
    if people is not None:
        check_whole("people", people, 0, MAX_PEOPLE)
    rng = np.random.default_rng([seed, 0x5CE])
    dims = np.array(size or (rng.uniform(4.0, 8.0), rng.uniform(4.0, 7.0), rng.uniform(2.5, 3.2)))
    keep = [np.array([p.x, p.y]) for p in cameras or []]
    faces = (*(_reflectivity(rng) for _ in range(4)), _reflectivity(rng, 0.5), 0.7)
    boxes = tuple(_furniture(rng, dims, keep))
    n_people = int(rng.integers(0, 3)) if people is None else people
    walkers = []
    for _ in range(n_people):
        pts = tuple(
            (float(rng.uniform(0.6, dims[0] - 0.6)), float(rng.uniform(0.6, dims[1] - 0.6))) for _ in range(4)
        )
        walkers.append(Person(pts, speed=float(rng.uniform(0.6, 1.4)), refl=float(rng.uniform(0.2, 0.6))))
    return Room((float(dims[0]), float(dims[1]), float(dims[2])), faces, boxes, tuple(walkers))


# ---------------------------------------------------------------- renderer
@dataclass
class Render:
    """z-depth (m, 0 = nothing), surface reflectivity and cosine of the incidence angle."""

    depth: np.ndarray
    refl: np.ndarray
    cos: np.ndarray

    def copy(self) -> Render:
        return Render(self.depth.copy(), self.refl.copy(), self.cos.copy())


@dataclass
class Renderer:
    """Renders one camera in one room. Walls and furniture are cast once per pose and cached; people are
    cast each frame only inside their bounding rectangle on the image, which keeps a static camera cheap."""

    room: Room
    intr: Intrinsics = L515_INTRINSICS
    pose: Pose | None = None
    _static: Render | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        u = (np.arange(self.intr.width, dtype=np.float32) - self.intr.px + 0.5) / self.intr.fx
        v = (np.arange(self.intr.height, dtype=np.float32) - self.intr.py + 0.5) / self.intr.fy
        self._cam = np.stack(np.broadcast_arrays(u[None, :], v[:, None], np.float32(1)), axis=-1)
        if self.pose is not None:
            self.move(self.pose)

    def move(self, pose: Pose) -> None:
        """Point the camera elsewhere (drops the cache)."""
        self.pose = pose
        self._axes = pose.axes().astype(np.float32)
        self._dirs = self._cam @ self._axes  # world direction whose forward component is 1: t = z-depth
        self._static = None

    def project(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World points -> (u, v, z) image coordinates (float)."""
        assert self.pose is not None
        c = (pts - self.pose.position) @ self._axes.T.astype(np.float64)
        z = c[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = c[..., 0] / z * self.intr.fx + self.intr.px
            v = c[..., 1] / z * self.intr.fy + self.intr.py
        return u, v, z

    def points(self, depth: np.ndarray) -> np.ndarray:
        """World points (H, W, 3) of a z-depth image rendered from this pose."""
        assert self.pose is not None
        return self.pose.position.astype(np.float32) + depth[..., None] * self._dirs

    def _window(self, corners: np.ndarray) -> tuple[slice, slice] | None:
        """Image rectangle that holds the projection of these corners (None: not in view)."""
        u, v, z = self.project(corners)
        if (z <= 0.05).all():
            return None
        if (z <= 0.05).any():
            return slice(0, self.intr.height), slice(0, self.intr.width)
        u0, u1 = int(max(np.floor(u.min()) - 1, 0)), int(min(np.ceil(u.max()) + 1, self.intr.width))
        v0, v1 = int(max(np.floor(v.min()) - 1, 0)), int(min(np.ceil(v.max()) + 1, self.intr.height))
        if u0 >= u1 or v0 >= v1:
            return None
        return slice(v0, v1), slice(u0, u1)

    def static(self) -> Render:
        if self._static is None:
            self._static = self._cast_static()
        return self._static

    def _cast_static(self) -> Render:
        assert self.pose is not None
        o = self.pose.position.astype(np.float32)
        d = self._dirs
        size = np.array(self.room.size, dtype=np.float32)
        safe = np.where(np.abs(d) < 1e-9, np.float32(1e-9), d)
        # Inside the room: the nearest exit plane on each axis.
        t_axis = np.where(safe > 0, (size - o) / safe, -o / safe)
        axis = np.argmin(t_axis, axis=-1)
        depth = np.take_along_axis(t_axis, axis[..., None], -1)[..., 0]
        positive = np.take_along_axis(safe, axis[..., None], -1)[..., 0] > 0
        face = axis * 2 + positive
        refl = np.asarray(self.room.face_refl, dtype=np.float32)[face]
        dn = np.linalg.norm(d, axis=-1)
        cos = np.abs(np.take_along_axis(d, axis[..., None], -1)[..., 0]) / dn
        out = Render(depth.astype(np.float32), refl, cos.astype(np.float32))
        for box in self.room.boxes:
            self._cast_box(box, o, out)
        return out

    def _cast_box(self, box: Box, o: np.ndarray, out: Render) -> None:
        win = self._window(box.corners())
        if win is None:
            return
        lo, hi = np.array(box.lo, np.float32), np.array(box.hi, np.float32)
        c = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0], np.float32)
        d = _turn(self._dirs[win], -box.yaw)
        ob = _turn((o - c)[None], -box.yaw)[0] + c
        safe = np.where(np.abs(d) < 1e-9, np.float32(1e-9), d)
        t1, t2 = (lo - ob) / safe, (hi - ob) / safe
        tmin = np.minimum(t1, t2)
        near = tmin.max(axis=-1)
        far = np.maximum(t1, t2).min(axis=-1)
        hit = (near <= far) & (near > 0) & (near < out.depth[win])
        if not hit.any():
            return
        axis = np.argmax(tmin, axis=-1)
        cos = np.abs(np.take_along_axis(d, axis[..., None], -1)[..., 0]) / np.linalg.norm(d, axis=-1)
        out.depth[win] = np.where(hit, near, out.depth[win])
        out.refl[win] = np.where(hit, np.float32(box.refl), out.refl[win])
        out.cos[win] = np.where(hit, cos, out.cos[win])

    def render(self, t: float = 0.0) -> Render:
        """The scene at time ``t`` seconds (people placed on their loops)."""
        out = self.static().copy()
        assert self.pose is not None
        o = self.pose.position.astype(np.float32)
        for person in self.room.people:
            px, py = person.at(t)
            r, h = person.radius, person.height
            corners = np.array(
                [[px + a * r, py + b * r, z] for a in (-1, 1) for b in (-1, 1) for z in (0, h)]
            )
            win = self._window(corners)
            if win is None:
                continue
            d = self._dirs[win]
            ox, oy = o[0] - px, o[1] - py
            a = d[..., 0] ** 2 + d[..., 1] ** 2
            b = 2 * (ox * d[..., 0] + oy * d[..., 1])
            cc = ox * ox + oy * oy - r * r
            disc = b * b - 4 * a * cc
            ok = (disc > 0) & (a > 1e-12)
            with np.errstate(invalid="ignore", divide="ignore"):
                t_hit = (-b - np.sqrt(np.where(ok, disc, 0))) / (2 * np.where(ok, a, 1))
            z = o[2] + t_hit * d[..., 2]
            hit = ok & (t_hit > 0) & (z >= 0) & (z <= h) & (t_hit < out.depth[win])
            if not hit.any():
                continue
            nx, ny = ox + t_hit * d[..., 0], oy + t_hit * d[..., 1]
            cos = np.abs(nx * d[..., 0] + ny * d[..., 1]) / (r * np.linalg.norm(d, axis=-1))
            out.depth[win] = np.where(hit, t_hit, out.depth[win]).astype(np.float32)
            out.refl[win] = np.where(hit, np.float32(person.refl), out.refl[win])
            out.cos[win] = np.where(hit, cos, out.cos[win]).astype(np.float32)
        return out


# ---------------------------------------------------------------- sensor model
#: A pixel of the real L515 that drops out alone does so again in 39% of the next frames and 41% of those
#: 20 frames later (../shared/data/l515/dev1): weak pixels, fixed per unit, that fail at random.
PINHOLE_REPEAT = 0.4
#: Blur (pixels) of the dropout field's fine part. The real L515's far dropouts come at every scale: holes of
#: 2-10 pixels hold 1.8% of the returning pixels' count, 0.9% with one Gaussian scale (speckle_px).
FINE_PX = 0.6


class SensorModel(Settings):
    """An L515-like depth sensor. Defaults come from ``d2sr calibrate`` against the shared L515 captures
    (docs/results/calibration)."""

    depth_scale: float = Field(4000.0, gt=0, description="units per metre of the output (L515: 4000)")
    max_range: float = Field(9.0, gt=0, description="no return beyond this range (m)")
    min_range: float = Field(0.25, ge=0, description="no return closer than this (m)")
    noise_base: float = Field(0.003921, ge=0, description="range noise floor, sd in metres")
    noise_per_m: float = Field(0.001782, ge=0, description="range noise sd growth per metre of range")
    signal_ref: float = Field(0.036524, gt=0, description="signal refl*cos/r^2 at which 63% of pixels return")
    signal_shape: float = Field(2.0, gt=0, description="steepness of the return probability in signal")
    speckle_px: float = Field(2.0, gt=0, description="size of dropout speckles (Gaussian sigma, pixels)")
    flicker: float = Field(0.681406, ge=0, lt=1, description="frame-to-frame correlation of speckle")
    edge_drop: float = Field(0.7, ge=0, le=1, description="chance a pixel on a depth edge drops out")
    edge_jump: float = Field(0.06, gt=0, description="relative depth jump that counts as an edge")
    speckle_fine: float = Field(
        0.274219, ge=0, lt=1, description="share of the dropout field's variance at the pixel scale (FINE_PX)"
    )
    pinhole: float = Field(
        0.0, ge=0, lt=PINHOLE_REPEAT, description="share of returning pixels lost alone per frame"
    )

    def return_prob(self, r: Render) -> np.ndarray:
        d = np.maximum(r.depth, 1e-3)
        signal = r.refl * np.maximum(r.cos, 0.05) / (d * d)
        p = 1 - np.exp(-((signal / self.signal_ref) ** self.signal_shape))
        p[(r.depth <= self.min_range) | (r.depth > self.max_range)] = 0
        return p.astype(np.float32)


L515 = SensorModel()


class SensorNoise:
    """One sensor's noise over time: a speckle field that evolves frame to frame (AR(1)), so dropouts
    flicker the way the real sensor's do instead of being independent per frame."""

    def __init__(self, model: SensorModel, shape: tuple[int, int], seed: int) -> None:
        self.model = model
        self.rng = np.random.default_rng([seed, 0x5E45])
        self.field = self._fresh(shape)
        self.weak = self.rng.random(shape, dtype=np.float32) < model.pinhole / PINHOLE_REPEAT

    def _fresh(self, shape: tuple[int, int]) -> np.ndarray:
        g: np.ndarray = self.rng.standard_normal(shape, dtype=np.float32)
        s = self.model.speckle_px
        g = cv2.GaussianBlur(g, (0, 0), s)
        g = g / np.float32(0.5 / (np.sqrt(np.pi) * s))  # unit variance after the blur
        a = self.model.speckle_fine
        if a > 0:  # a pixel-scale part: the real sensor's small ragged holes
            f = cv2.GaussianBlur(self.rng.standard_normal(shape, dtype=np.float32), (0, 0), FINE_PX)
            g = np.float32(np.sqrt(1 - a)) * g + np.float32(np.sqrt(a)) * f / max(float(f.std()), 1e-6)
        return g

    def observe(self, r: Render) -> np.ndarray:
        """A uint16 frame at ``model.depth_scale`` from a rendered scene."""
        m = self.model
        rho = np.float32(m.flicker)
        self.field = rho * self.field + np.sqrt(1 - rho * rho) * self._fresh(r.depth.shape)
        p = np.clip(m.return_prob(r), 1e-6, 1 - 1e-6)
        # Return where the field is below the p-quantile (logistic approximation of the normal quantile).
        keep = self.field < np.log(p / (1 - p)) / np.float32(1.702)
        keep &= ~self._edges(r.depth)
        keep &= ~(self.weak & (self.rng.random(r.depth.shape, dtype=np.float32) < PINHOLE_REPEAT))
        noise = self.rng.standard_normal(r.depth.shape, dtype=np.float32)
        z = r.depth + noise * (np.float32(m.noise_base) + np.float32(m.noise_per_m) * r.depth)
        out = np.where(keep, np.clip(np.rint(z * m.depth_scale), 1, 65535), 0)
        return out.astype(np.uint16)

    def _edges(self, depth: np.ndarray) -> np.ndarray:
        m = self.model
        if m.edge_drop == 0:
            return np.zeros(depth.shape, bool)
        hi = cv2.dilate(depth, np.ones((3, 3), np.uint8))
        lo = cv2.erode(depth, np.ones((3, 3), np.uint8))
        edge = (hi - lo) > m.edge_jump * np.maximum(depth, 0.1)
        return edge & (self.rng.random(depth.shape, dtype=np.float32) < m.edge_drop)
