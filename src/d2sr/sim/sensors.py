"""Clean frames as different kinds of depth sensor deliver them, so that a detector trained on them does not
take one sensor's natural artefacts for interference.

* ``l515``: the calibrated L515 model (``sim.scene.SensorNoise``), drawn around its fit; 4000 units/m.
* ``stereo`` (D435-like active stereo): depth from quantized disparity with spatially correlated matching
  noise (error grows with the square of range), holes where one camera is occluded, foreground edges
  fattened over the background, low-texture holes, a few 65535 spikes of stereo mismatch; mm.
* ``tof`` (Azure Kinect-like AMCW time of flight): flying pixels mixing foreground and background at depth
  edges, multipath bias in concave corners, saturation dropouts on near bright surfaces, low-signal
  dropouts, often an octagonal or circular field-of-view mask; mm.
* ``structured`` (Kinect v1 / Xtion-like structured light): depth on quantized disparity steps, shadow
  holes beside foreground edges, no return on dark, oblique or far surfaces; mm or 5000 units/m (TUM).

Each returns a uint16 frame and its depth scale, as a pure function of the generator state.
"""

from __future__ import annotations

import cv2
import numpy as np

from d2sr.errors import InputError
from d2sr.sim.rooms import L515, Render, SensorModel, SensorNoise

__all__ = ["SENSOR_KINDS", "observe"]

SENSOR_KINDS = ("l515", "stereo", "tof", "structured")


def randomized_l515(model: SensorModel, rng: np.random.Generator) -> SensorModel:
    """The calibrated sensor with its noise drawn around the fit. Real units differ from the fit, and a
    detector that has seen only one noise texture takes any other for interference."""
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
            "pinhole": min(model.pinhole * lu(0.4, 2.5), 0.3),
            "speckle_fine": min(model.speckle_fine * lu(0.4, 2.5), 0.9),
        }
    )


def _field(shape: tuple[int, int], sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance Gaussian noise, spatially correlated at ``sigma`` pixels."""
    g: np.ndarray = rng.standard_normal(shape).astype(np.float32)
    if sigma > 0.3:
        g = cv2.GaussianBlur(g, (0, 0), sigma)
        g = g / max(float(g.std()), 1e-6)
    return g


def _edges(z: np.ndarray, jump: float) -> np.ndarray:
    k = np.ones((3, 3), np.uint8)
    return (cv2.dilate(z, k) - cv2.erode(z, k)) > jump * np.maximum(z, 0.1)


def _shadow(disp: np.ndarray, side: int, reach: int) -> np.ndarray:
    """Pixels hidden from the second viewpoint (baseline along the rows, towards ``side``): a nearer
    pixel ``k`` columns away whose disparity exceeds this one's by more than ``k``."""
    hidden = np.zeros(disp.shape, bool)
    for k in range(1, reach + 1):
        other = np.roll(disp, -side * k, axis=1)
        hidden |= other - disp > k
    return hidden


def _low_signal(r: Render, ref: float, rng: np.random.Generator) -> np.ndarray:
    """No return where reflectivity x incidence / range^2 is weak (random threshold around ``ref``), in
    patches rather than salt: the matcher or the demodulator fails over a window, not per pixel."""
    d = np.maximum(r.depth, 1e-3)
    signal = r.refl * np.maximum(r.cos, 0.05) / (d * d)
    p = 1 - np.exp(-((signal / ref) ** 2))
    u = 1 / (1 + np.exp(-1.702 * _field(r.depth.shape, rng.uniform(0.0, 4.0), rng)))  # ~uniform, patchy
    return u > p


def _stereo(r: Render, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    z = r.depth.astype(np.float32)
    fb = rng.uniform(12.0, 40.0)  # focal length x baseline, px*m (D435 at 640x480: ~19)
    disp = np.where(z > 0, fb / np.maximum(z, 1e-3), 0).astype(np.float32)
    sub = 2.0 ** -int(rng.integers(3, 6))  # subpixel step
    noise = rng.uniform(0.03, 0.2) * _field(z.shape, rng.uniform(1.5, 8.0), rng)
    d = np.round((disp + noise) / sub) * sub
    out = np.where(d > 0.05, fb / np.maximum(d, 0.05), 0)
    if rng.random() < 0.8:  # edge fattening: the foreground spreads over the background
        k = int(rng.integers(2, 6))
        fat = cv2.erode(np.where(out > 0, out, 1e3).astype(np.float32), np.ones((1, k), np.uint8))
        edge = _edges(z, 0.05)
        edge = cv2.dilate(edge.astype(np.uint8), np.ones((1, k), np.uint8)).astype(bool)
        out = np.where(edge & (fat < 1e3), fat, out)
    hole = _shadow(disp, int(rng.choice([-1, 1])), 40) & (rng.random() < 0.9)
    hole |= _field(z.shape, rng.uniform(3, 15), rng) > rng.uniform(1.5, 3.5)  # low texture
    hole |= _low_signal(r, rng.uniform(0.0003, 0.01), rng)
    hole |= (z < rng.uniform(0.15, 0.35)) | (z > rng.uniform(8.0, 30.0))
    out = np.where(hole, 0, out)
    frame = np.clip(np.rint(out * 1000), 0, 65535).astype(np.uint16)
    # Stereo mismatch: the maximum value, often in clusters and most on far, weakly textured surfaces.
    far = np.clip(z / 8.0, 0.1, 1.0)
    spikes = rng.random(z.shape) < rng.uniform(0, 0.004) * far
    if rng.random() < 0.7:
        k = int(rng.integers(2, 6))
        spikes = cv2.dilate(spikes.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
    frame[spikes & (rng.random() < 0.6)] = 65535
    return frame, 1000.0


def _tof(r: Render, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    z = r.depth.astype(np.float32)
    out = z + (rng.uniform(0.001, 0.004) + rng.uniform(0, 0.003) * z) * _field(z.shape, 0.0, rng)
    # Multipath: concave corners read long (light arriving over two bounces).
    concave = np.maximum(cv2.GaussianBlur(z, (0, 0), rng.uniform(8, 25)) - z, 0)
    out = out + rng.uniform(0, 0.15) * concave
    # Flying pixels: on depth edges, a mix of the two surfaces.
    lo, hi = cv2.erode(z, np.ones((3, 3), np.uint8)), cv2.dilate(z, np.ones((3, 3), np.uint8))
    edge = _edges(z, 0.03)
    fly = edge & (rng.random(z.shape) < rng.uniform(0.2, 0.9))
    mix = rng.random(z.shape).astype(np.float32)
    out = np.where(fly, lo + mix * (hi - lo), out)
    drop = edge & ~fly & (rng.random(z.shape) < rng.uniform(0, 0.7))
    # Saturation: near, bright, facing surfaces return nothing; weak signal returns nothing.
    strong = r.refl * np.maximum(r.cos, 0) / np.maximum(z, 0.1) ** 2
    drop |= strong > rng.uniform(0.8, 4.0)
    drop |= _low_signal(r, rng.uniform(0.001, 0.01), rng)
    drop |= (z < rng.uniform(0.25, 0.5)) | (z > rng.uniform(3.0, 6.0))
    out = np.where(drop, 0, out)
    h, w = z.shape
    fov = rng.random()
    if fov < 0.5:  # the NFOV octagon or the WFOV circle of an Azure Kinect
        img = np.zeros((h, w), np.uint8)
        cx, cy = w / 2 + rng.uniform(-20, 20), h / 2 + rng.uniform(-20, 20)
        if fov < 0.25:
            a, b, k = rng.uniform(0.45, 0.7) * w, rng.uniform(0.45, 0.7) * h, rng.uniform(0.5, 0.8)
            xs = np.array([-1, -k, k, 1, 1, k, -k, -1]) * a + cx
            ys = np.array([-k, -1, -1, -k, k, 1, 1, k]) * b + cy
            cv2.fillPoly(img, [np.stack([xs, ys], 1).astype(np.int32)], 1)
        else:
            cv2.circle(img, (int(cx), int(cy)), int(rng.uniform(0.5, 0.75) * w), 1, -1)
        out = np.where(img.astype(bool), out, 0)
    return np.clip(np.rint(out * 1000), 0, 65535).astype(np.uint16), 1000.0


def _structured(r: Render, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    z = r.depth.astype(np.float32)
    fb = rng.uniform(30.0, 60.0)  # Kinect v1: 580 px x 7.5 cm
    disp = np.where(z > 0, fb / np.maximum(z, 1e-3), 0).astype(np.float32)
    sub = 1 / 8
    d = np.round((disp + rng.uniform(0.02, 0.1) * _field(z.shape, rng.uniform(1.0, 4.0), rng)) / sub) * sub
    out = np.where(d > 0.05, fb / np.maximum(d, 0.05), 0)
    hole = _shadow(disp, int(rng.choice([-1, 1])), 60)
    hole |= _edges(z, 0.04) & (rng.random(z.shape) < rng.uniform(0.2, 0.9))
    hole |= _low_signal(r, rng.uniform(0.003, 0.03), rng)
    hole |= (z < rng.uniform(0.4, 0.6)) | (z > rng.uniform(3.5, 8.0))
    out = np.where(hole, 0, out)
    scale = 5000.0 if rng.random() < 0.5 else 1000.0
    return np.clip(np.rint(out * scale), 0, 65535).astype(np.uint16), scale


def observe(
    kind: str, r: Render, rng: np.random.Generator, noise: SensorNoise | None = None
) -> tuple[np.ndarray, float]:
    """(uint16 frame, depth scale) of rendered scene ``r`` as sensor ``kind`` sees it; ``noise``: an L515's
    evolving speckle state (made fresh when None)."""
    if kind == "l515":
        if noise is None:
            noise = SensorNoise(randomized_l515(L515, rng), r.depth.shape, int(rng.integers(2**31)))
        return noise.observe(r), noise.model.depth_scale
    if kind == "stereo":
        return _stereo(r, rng)
    if kind == "tof":
        return _tof(r, rng)
    if kind == "structured":
        return _structured(r, rng)
    raise InputError(f"unknown sensor kind {kind!r}: one of {', '.join(SENSOR_KINDS)}")
