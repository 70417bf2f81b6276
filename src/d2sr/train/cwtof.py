"""Continuous-wave ToF interference as a training source (``TrainSettings.cw_tof``): the generated set's clean
frames as a CW-ToF camera beside others of its model would deliver them (``sim.cwtof``), made once and kept
beside the set they come from."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from d2sr.atomic import atomic_dir
from d2sr.errors import InputError
from d2sr.frames.overlap import processes
from d2sr.sim.cwtof import CAMERAS, cw_tof_interference
from d2sr.sim.dataset import SynthSet

__all__ = ["MIN_MOVED", "VERSION", "cw_tof_frames", "cw_tof_root", "moved"]

VERSION = 2  # of this source's frames: sets made by another version are made again under a new name
MIN_MOVED = 100  # a frame counts when more than this many pixels moved more than 2 cm (issue 80's bar)
TRIES = 6  # seeds tried per clean frame before it is left out (the other cameras spared it)


def moved(frame: np.ndarray, clean: np.ndarray, scale: float) -> np.ndarray:
    """The pixels a frame got wrong by more than noise: moved more than 2 cm, or a return lost or made."""
    f, c = np.asarray(frame), np.asarray(clean)
    return ((f > 0) != (c > 0)) | ((f > 0) & (np.abs(f.astype(np.float32) - c) > 0.02 * scale))


def _chunk(args: tuple[Path, Path, int, int]) -> list[int]:
    """Fill rows ``start:stop`` of ``frames.npy``; each row's source index in the set (-1: left out)."""
    root, synth, start, stop = args
    ss = SynthSet(synth)
    frames = np.load(root / "frames.npy", mmap_mode="r+")
    cams = sorted(CAMERAS)
    rows = []
    for i in range(start, stop):
        clean, scale = np.asarray(ss.clean[i]), float(ss.scales[i])
        used = -1
        for t in range(TRIES):
            seed = i * TRIES + t
            frame, _ = cw_tof_interference(clean, scale, seed, CAMERAS[cams[seed % len(cams)]])
            if moved(frame, clean, scale).sum() > MIN_MOVED:
                frames[i] = frame
                used = i
                break
        rows.append(used)
    frames.flush()
    return rows


def cw_tof_root(ss: SynthSet, count: int) -> Path:
    """Where ``cw_tof_frames(ss, count)`` keeps its frames (made when it holds a ``meta.json``)."""
    return ss.root.parent / f"{ss.root.name}-cwtof-v{VERSION}-{count}"


def cw_tof_frames(
    ss: SynthSet, count: int, progress: Callable[[int], None] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(frames, used): CW-ToF interference on the first ``count`` clean frames of ``ss``, a uint16 memory
    map, and which of them count (``used``: the other cameras left the rest almost untouched after
    ``TRIES`` draws, and their rows are zeros). Made once, kept beside ``ss``, named after it."""
    if not 0 < count <= len(ss):
        raise InputError(f"cw_tof: between 1 and the generated set's {len(ss)} frames, got {count}")
    root = cw_tof_root(ss, count)
    if not (root / "meta.json").is_file():
        with atomic_dir(root) as tmp:
            shape = (count, *ss.clean.shape[1:])
            np.lib.format.open_memmap(tmp / "frames.npy", "w+", np.uint16, shape).flush()
            jobs = [(tmp, ss.root, a, min(a + 50, count)) for a in range(0, count, 50)]
            rows: list[int] = []
            with processes(2) as pool:
                for part in pool.map(_chunk, jobs):
                    rows += part
                    if progress:
                        progress(len(part))
            (tmp / "meta.json").write_text(json.dumps({"version": VERSION, "count": count, "used": rows}))
    try:
        meta = json.loads((root / "meta.json").read_text())
        frames = np.load(root / "frames.npy", mmap_mode="r")
    except (OSError, ValueError) as exc:
        raise InputError(f"{root}: not a CW-ToF set ({exc})") from None
    if meta.get("version") != VERSION or len(meta.get("used", ())) != count or len(frames) != count:
        raise InputError(f"{root}: made by another version; delete it to make it again")
    return frames, np.asarray(meta["used"]) >= 0
