"""``d2sr run`` in the library: the three stages together on a simulated room, a recording or a live camera,
as one ``RunSettings`` and one ``LoopSettings`` say. Every check of the combination lives here; the command
line only parses."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from pathlib import Path
from typing import Any

from d2sr.atomic import check_out
from d2sr.errors import ConfigError, InputError
from d2sr.frames import open_colours
from d2sr.frames.checks import Checked
from d2sr.jobs.live import CAMERAS, check_camera, run_live
from d2sr.jobs.memory import reuse_freed_memory
from d2sr.jobs.scenes import open_recording
from d2sr.runtime.pipeline import model_settings, open_models
from d2sr.runtime.settings import LoopSettings, RunSettings

__all__ = ["run"]

Progress = Callable[[str, float], None]  # (what runs, share done)


def run(
    source: str,
    out: Path,
    settings: RunSettings | None = None,
    loop_settings: LoopSettings | None = None,
    *,
    rerun: str | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Run ``source`` (``sim``, ``realsense[:SERIAL]`` / ``orbbec[:SERIAL]`` or a recording) into the run
    folder ``out``; ``rerun``: also log it to a ``.rrd`` file or the ``live`` viewer. Returns the summary.
    The scene is judged on a recording's or a camera's frames unless ``settings.scene`` is False; a
    simulated room has none (asking for it is an error)."""
    from d2sr.jobs import session
    from d2sr.jobs.viewer import LIVE, RerunLog

    s = settings if settings is not None else RunSettings()
    ls = loop_settings if loop_settings is not None else LoopSettings()
    is_live = source.partition(":")[0] in CAMERAS
    is_recording = source != "sim" and not is_live
    _check(source, s, ls, is_live, is_recording)
    if source == "sim":
        s = s.model_copy(update={"scene": False, "scene_repair": False})
    inputs = [Path(source)] if is_recording else []
    check_out(out, is_dir=True, overwrite=overwrite, inputs=inputs)
    if rerun is not None and rerun != LIVE:
        check_out(Path(rerun), is_dir=False, overwrite=overwrite, inputs=inputs, name="rerun")
    reuse_freed_memory()
    net = open_models(model_settings(s), recovery=s.repair != "none")
    say = progress or (lambda what, done: None)
    shown = ls.sensors if source == "sim" else 1
    with RerunLog(rerun, shown, f"d2sr run {source}") if rerun else nullcontext() as log:
        on_result = log.write if log is not None else None
        if source == "sim":
            what = f"{ls.sensors} sensors, {ls.controller} ({net.name})"
            return session.run_sim(net, out, s, ls, progress=lambda f: say(what, f), on_result=on_result)
        if is_live:
            return run_live(net, out, source, s, ls, on_result=on_result)
        path = Path(source)
        reader, scale = open_recording(path, s)
        colours = open_colours(path, ls.colour_topic) if ls.colour_topic is not None else None
        recording = session.Recording(Checked(reader, scale), scale, str(path.resolve()), colours)
        what = f"{path.name} ({net.name})"
        return session.run_recording(
            net, recording, out, s, ls, progress=lambda f: say(what, f), on_result=on_result
        )


def _check(source: str, s: RunSettings, ls: LoopSettings, is_live: bool, is_recording: bool) -> None:
    """The settings make sense together for this source (a ConfigError naming the setting otherwise)."""
    if ls.controller == "oracle" and source != "sim":
        raise ConfigError("the oracle controller needs the simulated world's global knowledge (source 'sim')",
                          "controller")  # fmt: skip
    if ls.colour_topic is not None and not (ls.fill and is_recording):
        raise ConfigError("colour_topic is a bag's colour stream for fill: set fill too", "fill")
    if ls.fill and is_recording and ls.colour_topic is None:
        raise ConfigError(
            "fill on a recording needs its colour stream (a bag's colour topic); a recording with every "
            "frame: d2sr fill",
            "colour_topic",
        )
    if source == "sim" and "scene" in s.model_fields_set and s.scene:
        raise ConfigError("the scene judges a recording's or a camera's frames; not 'sim'", "scene")
    if ls.trigger is not None and not is_live:
        raise ConfigError("a trigger needs a live camera (realsense[:SERIAL] or orbbec[:SERIAL])", "trigger")
    if is_live:
        check_camera(source, ls.trigger, ls.fill)
    if is_recording and not Path(source).exists():
        raise InputError(f"{source}: no such recording (or use 'sim' / 'realsense')")
