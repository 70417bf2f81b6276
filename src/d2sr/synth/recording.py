"""``d2sr fill``: a recording as a duty-cycled sensor would have delivered it, with every frame the laser
skipped synthesized. Frames in slots ``offset .. offset + n - 1`` of every 30 are kept exactly as they are;
every other frame is written synthesized under its own name, with its per-pixel confidence, and
``fill.csv`` lists each frame: kept or synthesized, how, and how much of it has a value."""

from __future__ import annotations

import contextlib
import csv
import io
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from pydantic import Field

from d2sr.atomic import atomic_dir, check_out
from d2sr.atomic.naming import cell
from d2sr.config import Settings, check_callbacks, check_paths
from d2sr.desync import TOTAL_FRAMES
from d2sr.errors import ConfigError, InputError
from d2sr.frames.base import Frame, to_metres, to_units
from d2sr.frames.checks import checked_counts, open_input
from d2sr.frames.encoded import check_encoded
from d2sr.frames.layout import FrameFolder
from d2sr.frames.overlap import Behind, prefetch
from d2sr.synth.fill import Filler

__all__ = ["FILLED", "FillSummary", "colour_frames", "confidence_image", "fill_recording", "kept"]

FILLED = {"depth": "", "confidence": "confidence"}  # stream -> sub-folder of a fill output
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


@dataclass(frozen=True)
class FillSummary:
    frames: int
    kept: int
    synthesized: int
    method: str  # how the synthesized frames were made (the most common way)
    out: Path
    intrinsics: str  # "recorded" or "guessed"


def kept(index: int, active_frames: int, offset: int, total: int = TOTAL_FRAMES) -> bool:
    """Whether frame ``index`` lies in the window of slots ``offset .. offset + active_frames - 1``."""
    return (index % total - offset) % total < active_frames


def colour_frames(folder: Path) -> list[Path]:
    """The colour images of ``folder`` in name order."""
    if not folder.is_dir():
        raise InputError(f"colour {folder}: no such folder", "colour")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    if not files:
        raise InputError(f"colour {folder}: no .png or .jpg colour frames", "colour")
    return files


class FillSettings(Settings):
    """What ``fill_recording`` keeps and synthesizes: the window of ``active_frames`` from slot ``offset``
    of every 30-slot period is kept; ``colour``: a folder of the colour frames the others are synthesized from
    [none: the last kept frame held]; ``depth_scale`` and ``topic``: how the recording is read."""

    active_frames: int = Field(ge=1, le=TOTAL_FRAMES)
    offset: int = Field(0, ge=0, lt=TOTAL_FRAMES)
    colour: Path | None = None
    depth_scale: float | None = Field(None, gt=0, allow_inf_nan=False)
    topic: str | None = None


def fill_recording(
    input: Path,
    out: Path,
    settings: FillSettings,
    *,
    overwrite: bool = False,
    progress: Callable[[int, int], None] | None = None,
    say: Callable[[str], object] | None = None,
) -> FillSummary:
    """Keep the window's frames of ``input`` and synthesize the others into the PNG folder ``out``: from the
    colour frames of ``settings.colour`` (paired in name order; extra ones are ignored) when given, else by
    holding the last kept frame."""
    if not isinstance(settings, FillSettings):
        raise ConfigError(f"settings must be FillSettings, got {type(settings).__name__}", "settings")
    check_paths(input=input, out=out)
    check_callbacks(progress=progress, say=say)
    active_frames, offset, rgb = settings.active_frames, settings.offset, settings.colour
    depth_scale, topic = settings.depth_scale, settings.topic
    check_out(out, is_dir=True, overwrite=overwrite, inputs=[input, rgb])
    reader, scale = open_input(input, topic, depth_scale, "input", 1000.0, say=say)
    colours = colour_frames(rgb) if rgb is not None else None
    if colours is not None and len(colours) < len(reader):
        raise InputError(
            f"colour {rgb}: {len(colours)} colour frames for {len(reader)} depth frames", "colour"
        )
    filler = Filler(reader.intrinsics)
    rows: list[dict[str, object]] = []
    methods: dict[str, int] = {}

    def read() -> Iterator[tuple[Frame, np.ndarray | None]]:
        for i, frame in enumerate(checked_counts(reader, scale, "frame")):
            yield frame, _colour(colours[i]) if colours is not None else None

    # Depth and colour are decoded ahead and the outputs encoded behind, on threads of their own: the
    # synthesis in between has the main thread (the job's speed: docs/fill.md).
    with atomic_dir(out) as tmp, contextlib.closing(Behind()) as writes, prefetch(read()) as frames:
        folder = FrameFolder(tmp, FILLED)
        for i, (frame, colour) in enumerate(frames):
            if frame.depth.dtype != np.uint16:
                raise InputError(f"{frame.name}: d2sr fill writes 16-bit frames; this recording's are metres")
            if kept(i, active_frames, offset):
                filler.real(to_metres(frame.depth, scale), colour)
                writes.submit(
                    folder.write, frame.name, depth=frame.depth, confidence=confidence_image(frame.depth > 0)
                )
                rows.append(_row(frame.name, i, "real", 0, frame.depth > 0, frame.depth > 0))
                continue
            try:
                s = filler.synthesize(colour)
            except InputError:  # nothing real yet (a window that starts after the recording does)
                empty = np.zeros_like(frame.depth)
                writes.submit(
                    folder.write, frame.name, depth=empty, confidence=np.zeros(empty.shape, np.uint8)
                )
                rows.append(_row(frame.name, i, "none", 0, empty > 0, empty > 0))
                continue
            depth = to_units(s.depth, scale)
            writes.submit(folder.write, frame.name, depth=depth, confidence=confidence_image(s.confidence))
            rows.append(_row(frame.name, i, s.method, s.since_real, depth > 0, s.confidence))
            methods[s.method] = methods.get(s.method, 0) + 1
            if progress is not None:
                progress(i + 1, len(reader))
        writes.drain()
        folder.finish(scale, reader.intrinsics, [{"name": r["frame"]} for r in rows])
        (tmp / "fill.csv").write_text(_csv(rows), errors="surrogateescape")
    k = filler.intrinsics
    recorded = reader.intrinsics is not None
    if say is not None and not recorded and k is not None and colours is not None:
        say(f"intrinsics not recorded: guessed fx = fy = {k.fx:.0f} px, centre ({k.px:.1f}, {k.py:.1f})")
    n_kept = sum(r["synthesized"] == 0 for r in rows)
    method = max(methods, key=lambda m: methods[m]) if methods else "none"
    intrinsics = "recorded" if recorded else "guessed"
    return FillSummary(len(rows), n_kept, len(rows) - n_kept, method, Path(out), intrinsics)


def _colour(path: Path) -> np.ndarray:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    check_encoded(data, str(path), "PNG or JPEG")
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(f"{path}: not a readable colour image")
    return img


def confidence_image(conf: np.ndarray) -> np.ndarray:
    """A per-pixel confidence in [0, 1] (or a bool) as the uint8 PNG its folder holds (255 = 1)."""
    return np.clip(np.rint(conf.astype(np.float32) * 255), 0, 255).astype(np.uint8)


def _row(name: str, i: int, method: str, since: int, has: np.ndarray, conf: np.ndarray) -> dict[str, object]:
    return {
        "frame": name,
        "slot": i % TOTAL_FRAMES,
        "synthesized": int(method != "real"),
        "method": method,
        "frames_since_real": since,
        "coverage": round(float(has.mean()), 4),
        "mean_confidence": round(float(np.asarray(conf, np.float32).mean()), 4),
    }


def _csv(rows: list[dict[str, object]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else ["frame"])
    w.writeheader()
    w.writerows(
        {k: cell(v) if k == "frame" and isinstance(v, str) else v for k, v in r.items()} for r in rows
    )
    return buf.getvalue()
