"""d2sr: decentralized detection, de-synchronization and recovery of depth-sensor interference.

The library in a few names (``docs/api.md`` has runnable examples):

- ``RunSettings``: how a run judges and repairs (model, threshold, scene, ...), one frozen object that
  every entry point below takes (``settings=``), its fields also by keyword.
- ``repair(depth, depth_scale=None, settings=None, **fields)``: one frame detected and repaired.
- ``Pipeline(depth_scale=None, settings=None, desync=None, **fields)``: one sensor's loop,
  ``.process(depth)``; ``DesyncSettings``: its controller and active window.
- ``recover_recording(input, out, settings)``, ``detect_recording(input, out, settings)``: a recording in,
  a recording out (what ``d2sr recover`` and ``d2sr detect`` run); ``fill_recording(input, out,
  active_frames, ...)``: the frames a duty-cycled laser skipped, synthesized (``d2sr fill``).
- ``recover_fleet(recordings, out, settings, cluster=Cluster(workers=2))``: many recordings repaired on Ray,
  each as ``recover_recording`` repairs it (``d2sr fleet``; the ``fleet`` extra).
- ``open_frames(path)``: read any supported recording; ``make_controller(name, ...)``: a de-synchronization
  controller on its own.
- ``reuse_freed_memory()``: for your own frame loop, once, process-wide: a frame's freed buffers serve the
  next frame's instead of being faulted in afresh (glibc; what ``d2sr ros2``, ``recover`` and ``run`` do).
- ``D2SRError`` and its kinds ``InputError``, ``ConfigError``, ``OutputError``: what d2sr raises on purpose.

Names load on first use, so ``import d2sr`` stays light.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from d2sr.version import __version__

_WHERE = {
    "repair": "d2sr.runtime.pipeline",
    "Pipeline": "d2sr.runtime.pipeline",
    "Repaired": "d2sr.runtime.pipeline",
    "Window": "d2sr.runtime.pipeline",
    "recover_recording": "d2sr.jobs.recordings",
    "recover_fleet": "d2sr.fleet",
    "Cluster": "d2sr.fleet",
    "detect_recording": "d2sr.jobs.recordings",
    "Summary": "d2sr.jobs.recordings",
    "Written": "d2sr.jobs.recordings",
    "RunSettings": "d2sr.runtime.settings",
    "DesyncSettings": "d2sr.runtime.settings",
    "fill_recording": "d2sr.synth",
    "learn_scene_recording": "d2sr.jobs.scenes",
    "StoredScene": "d2sr.scene.stored",
    "open_frames": "d2sr.frames",
    "make_controller": "d2sr.desync",
    "D2SRError": "d2sr.errors",
    "InputError": "d2sr.errors",
    "ConfigError": "d2sr.errors",
    "OutputError": "d2sr.errors",
    "reuse_freed_memory": "d2sr.jobs.memory",
}

__all__ = [
    "Cluster",
    "ConfigError",
    "D2SRError",
    "DesyncSettings",
    "InputError",
    "OutputError",
    "Pipeline",
    "Repaired",
    "RunSettings",
    "StoredScene",
    "Summary",
    "Window",
    "Written",
    "__version__",
    "detect_recording",
    "fill_recording",
    "learn_scene_recording",
    "make_controller",
    "open_frames",
    "recover_fleet",
    "recover_recording",
    "repair",
    "reuse_freed_memory",
]

if TYPE_CHECKING:
    from d2sr.desync import make_controller
    from d2sr.errors import ConfigError, D2SRError, InputError, OutputError
    from d2sr.fleet import Cluster, recover_fleet
    from d2sr.frames import open_frames
    from d2sr.jobs.memory import reuse_freed_memory
    from d2sr.jobs.recordings import Summary, Written, detect_recording, recover_recording
    from d2sr.jobs.scenes import learn_scene_recording
    from d2sr.runtime.pipeline import Pipeline, Repaired, Window, repair
    from d2sr.runtime.settings import DesyncSettings, RunSettings
    from d2sr.scene.stored import StoredScene
    from d2sr.synth import fill_recording


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'd2sr' has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
