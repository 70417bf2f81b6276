"""Input checks before any work: a recording that is not empty, a depth scale that makes indoor sense
(given, said by the recording, or a default), and frames whose values are depth. Shared by the library's
recording jobs and every command that reads depth."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from d2sr.errors import InputError
from d2sr.frames import Frame, Reader, check_depth, open_frames, to_metres
from d2sr.frames.base import KNOWN_SCALES, PLAUSIBLE_M, probe
from d2sr.ui import print_line, warn

__all__ = ["SAMPLED", "Checked", "checked", "checked_counts", "checked_frames", "open_input"]


def open_input(
    path: Path,
    topic: str | None,
    scale: float | None,
    what: str,
    default: float | None = None,
    max_range: float = PLAUSIBLE_M[1],
    say: Callable[[str], object] | None = None,
    recording_wrong: bool | None = None,
) -> tuple[Reader, float]:
    """A non-empty recording and its depth scale: ``scale`` if given, else what the recording says, else
    ``default`` (None: the user must say). A given scale that contradicts the recording's is refused (every
    clean frame would read off by their ratio and be judged and repaired so) unless ``recording_wrong``
    (the ``RunSettings`` field of that name; None: the caller has no such setting). Frames sampled through
    it are checked before any work (values, size, a scale that makes indoor sense); the scale used and where
    it came from are printed."""
    reader = open_frames(path, topic=topic)
    notes = []  # warnings wait until every check passed: an error stays the only line
    if scale is not None:
        use, source = scale, "as given"
        own = reader.depth_scale
        if own and abs(own - scale) > 1e-6 * scale:
            if not recording_wrong:
                fix = (
                    "" if recording_wrong is None else ", or set recording_scale_wrong if the recording's is"
                )
                raise InputError(
                    f"{path}: depth_scale {scale:g} given, but the recording says {own:g} units per metre; "
                    f"drop depth_scale to use the recording's{fix}",
                    "depth_scale",
                )
            notes.append(f"it says its depth scale is {own:g}; using the one given, {scale:g}")
    elif reader.depth_scale:
        use, source = reader.depth_scale, "from the recording"
    else:
        if default is None:
            raise InputError(f"{path}: the recording does not say its depth scale; give one", "depth_scale")
        use, source = default, f"default: {KNOWN_SCALES.get(default, 'given')}"
    if not (np.isfinite(use) and use > 0):
        raise InputError(f"depth scale must be a positive number, got {use}", "depth_scale")
    if not (np.isfinite(max_range) and max_range > PLAUSIBLE_M[0]):
        raise InputError(
            f"max_range must be a number of metres above {PLAUSIBLE_M[0]}, got {max_range}", "max_range"
        )
    if len(reader) == 0:
        raise InputError(f"{path}: the {what} sequence is empty")
    for w in notes + probe(reader.sample(SAMPLED), float(use), max_range):
        warn(f"{path}: {w}")
    (say or print_line)(f"{path}: {len(reader)} frames, depth scale {use:g} units per metre ({source})")
    return reader, float(use)


SAMPLED = 12  # frames checked before a recording is processed


def _metres(f: Frame, scale: float) -> np.ndarray:
    return to_metres(f.depth, 1.0 if f.depth.dtype == np.float32 else scale)


def checked(reader: Iterable[Frame], scale: float) -> Iterator[Frame]:
    """Frames whose values pass ``check_depth`` (the scale was checked by ``open_input``); frames with no
    valid depth are counted and named in one warning at the end."""
    empty: list[str] = []
    count = 0
    for f in reader:
        check_depth(f.depth, f"frame {f.name}")
        count += 1
        if not f.depth.any():
            empty.append(f.name)
        yield f
    if empty:
        warn(
            f"{len(empty)} of {count} frames have no valid depth (e.g. {empty[0]}); "
            "they pass through as they are"
        )


def checked_counts(reader: Iterable[Frame], scale: float, what: str) -> Iterator[Frame]:
    """``checked`` frames that must be 16-bit counts (commands that write or label 16-bit PNGs)."""
    for f in checked(reader, scale):
        if f.depth.dtype != np.uint16:
            raise InputError(f"{what} {f.name} is {f.depth.dtype}; this command needs 16-bit depth")
        yield f


def checked_frames(reader: Iterable[Frame], scale: float) -> Iterator[tuple[Frame, np.ndarray]]:
    """``checked`` frames with their depth in metres."""
    for f in checked(reader, scale):
        yield f, _metres(f, scale)


class Checked:
    """A recording whose frames pass ``checked`` as they are read, its length known up front."""

    def __init__(self, reader: Reader, scale: float) -> None:
        self.reader, self.scale = reader, scale

    def __len__(self) -> int:
        return len(self.reader)

    def __iter__(self) -> Iterator[Frame]:
        yield from checked(self.reader, self.scale)
