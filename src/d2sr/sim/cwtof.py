"""Continuous-wave time-of-flight interference, from its physics (issue 80).

A CW-ToF camera (Kinect v2, Azure Kinect, Orbbec Femto) measures each pixel's phase at a few modulation
frequencies: its own light, modulated at ``f``, comes back as a phasor of phase ``4 pi f d / c``. Another
camera's light that reaches the same surface adds a second phasor, of relative size ``r`` (the two
irradiances on that surface: the return path to this camera is shared, so albedo and optics cancel) and
phase ``theta + 2 pi f (L - d) / c`` (the other camera's oscillator phase ``theta``, its path ``L`` to the
surface against this camera's ``d``). The measured phase and amplitude move by ``arg(1 + z)`` and
``|1 + z|``; each frequency moves its own way, and multi-frequency unwrapping turns that into a weighted
mean of the per-frequency depths, a wrong wrap (a jump of metres) or an invalid pixel.

What makes it coherent patches of either sign: ``r`` is smooth over a surface facing the other camera
(its beam, the incidence, the distances), and ``L - d`` changes slowly across it. What makes it come and
go: only captures that overlap in time at the same frequency interfere (``overlap``), and two oscillators
a few ppm apart average each other out over a capture (``sinc``); both change from frame to frame.

Published parameters: Kinect v2 modulates at 80, 16 and 120 MHz and unwraps to 18.75 m (Sell and
O'Connor, IEEE Micro 34(2), 2014; the same values in libfreenect2 and in Jaremo Lawin et al., ECCV 2016,
arXiv:1608.05209); its depth field of view is 70.6 x 60 degrees. Azure Kinect / Orbbec Femto (the same
Microsoft sensor): modulation up to 320 MHz (Bamji et al., ISSCC 2018), NFOV 75 x 65 degrees, laser
captures of about 125 us (Azure Kinect DK documentation, multi-device synchronization); its frequency
plan is not published, so ``AZURE`` assumes the Kinect v2's at twice its frequencies (160, 32, 240 MHz:
the same 2:3 pair and low tone, a 9.4 m range). Assumed, not published: the Kinect v2's capture lengths,
the oscillators' tolerance, the beam profile and the unwrapping's rejection rules.

Pixels without a return stay without one (a camera whose background is dark sees no other camera's light
there either), and so do depths beyond the camera's range (another sensor's values it could not report).
Pure numpy and OpenCV, a pure function of the seed; no torch.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import to_units

__all__ = ["AZURE", "CAMERAS", "KINECT2", "CwTofCamera", "cw_tof_interference"]

C = 299_792_458.0  # m/s


@dataclass(frozen=True)
class CwTofCamera:
    """One CW-ToF camera model: what its interference depends on."""

    name: str
    frequencies_hz: tuple[int, ...]
    fov_deg: tuple[float, float]  # depth field of view, horizontal x vertical
    capture_ms: tuple[float, float]  # one capture's length, drawn between (assumed)

    @property
    def unwrap_m(self) -> float:
        """The unwrapping's range, where all frequencies wrap together: depths are searched below it."""
        return C / (2 * float(np.gcd.reduce(np.asarray(self.frequencies_hz, np.int64))))


KINECT2 = CwTofCamera("kinect2", (80_000_000, 16_000_000, 120_000_000), (70.6, 60.0), (0.5, 2.0))
AZURE = CwTofCamera("azure", (160_000_000, 32_000_000, 240_000_000), (75.0, 65.0), (0.1, 0.15))
CAMERAS = {c.name: c for c in (KINECT2, AZURE)}

PPM = (2e-6, 100e-6)  # two cameras' oscillators differ by this much, log-uniform (assumed)
MIN_AMPLITUDE = 0.3  # of the camera's own: below it a frequency's return is rejected (assumed)
MAX_RESIDUAL_RAD = 0.6  # unwrapped frequencies that disagree by more are rejected (assumed)
SATURATION = 6.0  # another camera's light this many times the own saturates the pixel (assumed)
FAINT = 1e-3  # a pixel whose interference phasors are all smaller is left as it was


def _points(d: np.ndarray, fov_deg: tuple[float, float]) -> np.ndarray:
    """(H, W, 3) camera-frame points in metres for depth ``d`` (metres, 0: none), a pinhole of ``fov``."""
    h, w = d.shape
    fx = (w / 2) / np.tan(np.radians(fov_deg[0]) / 2)
    fy = (h / 2) / np.tan(np.radians(fov_deg[1]) / 2)
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([(u - (w - 1) / 2) / fx * d, (v - (h - 1) / 2) / fy * d, d], axis=-1)


def _normals(d: np.ndarray, fov_deg: tuple[float, float]) -> np.ndarray:
    """Unit surface normals facing the camera, from the depth smoothed over its returns (a 5-pixel
    Gaussian, so that depth steps of one unit do not tilt them); the viewing ray where a neighbour has
    no return."""
    has = (d > 0).astype(np.float32)
    weight = cv2.GaussianBlur(has, (5, 5), 1.2)
    smooth = np.where(has > 0, cv2.GaussianBlur(d * has, (5, 5), 1.2) / np.maximum(weight, 1e-6), 0)
    p = _points(smooth.astype(np.float32), fov_deg)
    du = np.gradient(p, axis=1)
    dv = np.gradient(p, axis=0)
    n = np.cross(du, dv)
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    ray = p / np.maximum(np.linalg.norm(p, axis=-1, keepdims=True), 1e-6)
    ok = (length[..., 0] > 1e-9) & (cv2.erode(has, np.ones((3, 3), np.uint8)) > 0)
    n = np.where(ok[..., None], n / np.maximum(length, 1e-12), -ray)
    facing = np.sum(n * ray, axis=-1, keepdims=True) < 0
    return np.where(facing, n, -n)


def _beam(cos_axis: np.ndarray, half_deg: float) -> np.ndarray:
    """A flat-topped beam: about 1 inside ``half_deg`` off its axis, falling off steeply beyond."""
    angle = np.degrees(np.arccos(np.clip(cos_axis, -1.0, 1.0)))
    return np.exp(-((angle / half_deg) ** 6))


def _lit(points: np.ndarray, valid: np.ndarray, source: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Which points the other camera's light reaches: a coarse depth buffer seen from ``source`` along
    ``axis``, a point lit when it is within 5 cm of the nearest point in its direction."""
    z_axis = axis / np.linalg.norm(axis)
    x_axis = np.cross(z_axis, [0.0, 1.0, 0.0])
    x_axis = x_axis / max(float(np.linalg.norm(x_axis)), 1e-9)
    y_axis = np.cross(z_axis, x_axis)
    rel = points[valid] - source
    z = rel @ z_axis
    front = z > 0.05
    u = np.where(front, (rel @ x_axis) / np.maximum(z, 1e-6), 99.0)
    v = np.where(front, (rel @ y_axis) / np.maximum(z, 1e-6), 99.0)
    bins = 128
    iu = np.clip(((u + 1.5) / 3.0 * bins).astype(np.int64), 0, bins - 1)
    iv = np.clip(((v + 1.5) / 3.0 * bins).astype(np.int64), 0, bins - 1)
    dist = np.linalg.norm(rel, axis=-1)
    nearest = np.full(bins * bins, np.inf)
    cell = iv * bins + iu
    np.minimum.at(nearest, cell[front], dist[front])
    lit = np.zeros(valid.shape, bool)
    lit[valid] = front & (dist <= nearest[cell] + 0.05)
    return lit


def _phasors(d: np.ndarray, camera: CwTofCamera, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(z, own): each frequency's interference phasor relative to the own return, (F, H, W) complex, from
    one or two other cameras of the same model placed around the scene; ``own`` marks pixels with a return."""
    h, w = d.shape
    valid = d > 0
    pts = _points(d, camera.fov_deg)
    normals = _normals(d, camera.fov_deg)
    dist_own = np.linalg.norm(pts, axis=-1)
    ray = pts / np.maximum(dist_own[..., None], 1e-6)
    cos_own = np.maximum(np.sum(-ray * normals, axis=-1), 0.2)
    own_beam = _beam(ray[..., 2], max(camera.fov_deg) / 2 + 5)
    z = np.zeros((len(camera.frequencies_hz), h, w), np.complex64)
    ys, xs = np.nonzero(valid)
    for _ in range(int(rng.integers(1, 3))):
        k = int(rng.integers(len(ys)))
        aim = pts[ys[k], xs[k]]
        # The other camera stands beside this one, looking at the same scene: its direction from the aimed
        # point is this camera's turned 25-110 degrees about the vertical, tilted up to 20 degrees.
        back = -aim / max(float(np.linalg.norm(aim)), 1e-6)
        yaw = np.radians(rng.uniform(25, 110)) * rng.choice([-1, 1])
        pitch = np.radians(rng.uniform(-20, 20))
        c, s = np.cos(yaw), np.sin(yaw)
        turned = np.array([c * back[0] + s * back[2], back[1], -s * back[0] + c * back[2]])
        turned[1] += np.sin(pitch)
        turned /= np.linalg.norm(turned)
        source = aim + turned * float(np.linalg.norm(aim)) * rng.uniform(0.5, 2.0)
        axis = aim + rng.normal(0, 0.1, 3) - source
        to_src = source - pts
        dist_src = np.linalg.norm(to_src, axis=-1)
        dir_src = to_src / np.maximum(dist_src[..., None], 1e-6)
        cos_in = np.maximum(np.sum(dir_src * normals, axis=-1), 0.0)
        cos_axis = np.sum(-dir_src * (axis / np.linalg.norm(axis)), axis=-1)
        beam = _beam(cos_axis, max(camera.fov_deg) / 2)
        # The two irradiances on the surface (the same emitter power): the shared return path cancels.
        r = beam * cos_in * dist_own**2 / (own_beam * cos_own * np.maximum(dist_src, 0.05) ** 2)
        r = np.where(valid & _lit(pts, valid, source, axis), r, 0.0)
        # Captures of the same frequency overlap for a share of their length (the cameras run free), and
        # oscillators `delta` apart average each other out over a capture.
        overlap = rng.uniform(0.0, 1.0)
        delta = float(np.exp(rng.uniform(*np.log(PPM))))
        capture_s = rng.uniform(*camera.capture_ms) / 1000
        for j, f in enumerate(camera.frequencies_hz):
            coherence = abs(float(np.sinc(f * delta * capture_s)))
            theta = rng.uniform(0, 2 * np.pi)
            phase = theta + 2 * np.pi * f * (dist_src - dist_own) / C
            z[j] += (overlap * coherence * r * np.exp(1j * phase)).astype(np.complex64)
    return z, valid


def _unwrap(d: np.ndarray, z: np.ndarray, camera: CwTofCamera) -> np.ndarray:
    """Depths (metres, 0: rejected) the camera reports for true depths ``d`` (M,) whose returns carry
    interference phasors ``z`` (F, M): each frequency's wrapped phase, the wrap of the highest that makes
    the others agree best (weighted by frequency and amplitude), the weighted mean of the unwrapped
    depths; rejected where a frequency's amplitude is cancelled or the frequencies disagree."""
    f = np.asarray(camera.frequencies_hz)[:, None]
    amp = np.abs(1 + z)
    measured = np.mod(4 * np.pi * f * d[None] / C + np.angle(1 + z), 2 * np.pi)
    weight = (f * amp) ** 2
    hi = int(np.argmax(camera.frequencies_hz))
    wrap = C / (2 * camera.frequencies_hz[hi])
    base = measured[hi] / (2 * np.pi) * wrap
    hyps = base[None] + wrap * np.arange(int(np.ceil(camera.unwrap_m / wrap)))[:, None]  # (N, M)

    # Each frequency's residual phase at each hypothesis, wrapped to (-pi, pi].
    res = np.angle(np.exp(1j * (measured[:, None] - 4 * np.pi * f[:, :, None] * hyps[None] / C)))
    metres = res * C / (4 * np.pi * f[:, :, None])
    cost = np.sum(weight[:, None] * metres**2, axis=0)
    cost[hyps >= camera.unwrap_m] = np.inf  # the range's end wraps to its start
    best = np.argmin(cost, axis=0)
    cols = np.arange(d.size)
    picked = metres[:, best, cols]
    out = hyps[best, cols] + np.sum(weight * picked, axis=0) / np.sum(weight, axis=0)
    worst = np.max(np.abs(res[:, best, cols]), axis=0)
    bad = (np.min(amp, axis=0) < MIN_AMPLITUDE) | (worst > MAX_RESIDUAL_RAD)
    return np.where(bad, 0.0, out)


def cw_tof_interference(
    depth: np.ndarray, depth_scale: float, seed: int, camera: CwTofCamera = KINECT2
) -> tuple[np.ndarray, np.ndarray]:
    """(interfered uint16 frame, mask of changed pixels) for a clean uint16 ``depth`` seen by ``camera``
    while one or two others of its model run beside it. The mask may be empty (the others' captures did
    not overlap, or their light landed elsewhere): a frame the cameras happened to spare."""
    if depth.dtype != np.uint16 or depth.ndim != 2:
        raise InputError(f"interference works on uint16 depth images, got {depth.dtype} {depth.shape}")
    if not depth_scale > 0:
        raise InputError(f"depth_scale must be positive, got {depth_scale}")
    rng = np.random.default_rng([seed, 0xC770F])
    d = depth.astype(np.float32) / np.float32(depth_scale)
    if not (d > 0).any():
        return depth.copy(), np.zeros(depth.shape, bool)
    z, valid = _phasors(d, camera, rng)
    strength = np.abs(z).max(axis=0)
    hit = valid & (strength > FAINT) & (d < camera.unwrap_m)
    out = d.astype(np.float64)
    if hit.any():
        new = _unwrap(d[hit].astype(np.float64), z[:, hit], camera)
        new[strength[hit] > SATURATION] = 0.0
        out[hit] = new
    frame = to_units(out, depth_scale)
    return frame, frame != depth
