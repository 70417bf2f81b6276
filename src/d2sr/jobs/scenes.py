"""``d2sr scene learn`` in the library: a still sensor's scene learned from a clean recording and stored."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from d2sr.atomic import check_out
from d2sr.config import check_callbacks, check_instances, check_paths
from d2sr.errors import InputError
from d2sr.frames import Reader
from d2sr.frames.checks import checked_counts, open_input
from d2sr.runtime.settings import RunSettings
from d2sr.scene.stored import StoredScene, learn_scene

__all__ = ["check_stored", "learn_scene_recording", "open_recording"]


def learn_scene_recording(
    clean: Path,
    out: Path,
    settings: RunSettings | None = None,
    *,
    overwrite: bool = False,
    say: Callable[[str], object] | None = None,
) -> StoredScene:
    """Learn the scene of ``clean`` (any recording d2sr reads: its frames must be clean, the sensor still;
    read as ``settings`` say: depth scale, topic, range) and store it in ``out`` (a ``.npz`` file)."""
    check_paths(clean=clean)  # check_out skips an input of None, and reads --out's own
    check_instances(settings=(settings, RunSettings))
    check_callbacks(say=say)
    check_out(out, is_dir=False, overwrite=overwrite, inputs=[clean])
    s = settings if settings is not None else RunSettings()
    if Path(out).suffix != ".npz":
        raise InputError(f"{out}: a stored scene is a .npz file", "out")
    reader, scale = open_input(
        clean, s.topic, s.depth_scale, "clean", 1000.0, s.max_range, say, s.recording_scale_wrong
    )
    if reader.depth_scale is None and s.depth_scale is None and say is not None:
        say(f"{clean}: no depth scale given or recorded; the scene is stored at {scale:g} units per metre")
    frames = lambda: (f.depth for f in checked_counts(reader, scale, "clean frame"))  # noqa: E731
    stored = learn_scene(frames, scale, str(clean), len(reader))
    stored.save(out)
    return stored


def check_stored(settings: RunSettings, reader: Reader, scale: float) -> None:
    """The stored scene ``settings`` name fits the recording (its frames' size and depth scale), checked
    before any work; nothing to check without one."""
    if settings.scene_from is None or not settings.scene:
        return
    st = StoredScene.load(settings.scene_from)
    first = next(iter(reader.sample(1)), None)
    if first is not None:  # frames in metres are judged in millimetres (``loop._in_units``)
        units = 1000.0 if first.depth.dtype.kind == "f" else scale
        st.check_fits(first.depth.shape, units, settings.scene_from)


def open_recording(
    input: Path, settings: RunSettings, say: Callable[[str], object] | None = None
) -> tuple[Reader, float]:
    """A recording's reader and depth scale as ``settings`` say (topic, scale, range; ``open_input`` prints
    through ``say``), with the stored scene they name checked against it before any work."""
    s = settings
    reader, scale = open_input(
        input, s.topic, s.depth_scale, "input", 1000.0, s.max_range, say, s.recording_scale_wrong
    )
    check_stored(s, reader, scale)
    return reader, scale
