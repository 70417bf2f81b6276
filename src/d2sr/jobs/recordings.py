"""A recording through one sensor's loop, as ``d2sr detect`` and ``d2sr recover`` run it: frames are read
ahead on a thread, decided in order (the detector weighs the frame before; a temporal model gets the last
clean frame), repaired several at a time, and written in input order by a bounded writer.

``detect_recording`` writes ``frame,score,interfered,reason`` (CSV); ``recover_recording`` writes a PNG folder
(``<name>.png`` repaired, ``masks/<name>.png``) or, for a ROS bag, a bag of the same kind with every input
message and ``T/repaired`` and ``T/mask`` added (``d2sr.frames.bagcopy``).
"""

from __future__ import annotations

import contextlib
import csv
import io
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from d2sr.atomic import CSV_HEADERS, atomic_dir, atomic_write, check_out
from d2sr.atomic.naming import cell
from d2sr.config import check_callbacks, check_instances, check_paths
from d2sr.contract.catalog import DETECTOR
from d2sr.desync import TOTAL_FRAMES, make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame, Intrinsics, detect_format, open_colours
from d2sr.frames.base import to_metres, to_units
from d2sr.frames.checks import checked, checked_counts
from d2sr.frames.layout import REPAIRED, FrameFolder
from d2sr.frames.overlap import Behind, prefetch
from d2sr.jobs.memory import reuse_freed_memory
from d2sr.jobs.report import Report
from d2sr.jobs.scenes import open_recording
from d2sr.runtime.loop import Capture, Result, SensorLoop
from d2sr.runtime.pipeline import model_settings, open_models
from d2sr.runtime.settings import RunSettings
from d2sr.runtime.workers import in_order, repair_workers

__all__ = [
    "CSV_HEADER",
    "FORMATS",
    "Progress",
    "Summary",
    "Written",
    "detect_recording",
    "recover_recording",
]

Progress = Callable[[int, int], None]  # (frames done, frames in all)
CSV_HEADER = CSV_HEADERS[0].split(",")  # detect's columns (how --overwrite knows its file)
FORMATS = ("auto", "png", "bag")  # recover's outputs: auto is a bag for a ROS bag, else a PNG folder


@dataclass(frozen=True)
class Summary:
    """What a recording job did: ``frames`` read, ``flagged`` by the detector (and the scene), ``repaired``
    (given to the repair: the flagged ones, or every frame), ``changed`` of them (their depth changed) and
    the ``pixels`` changed, written to ``out`` (``format``: png, ros1 or ros2) with ``model`` on
    ``backend`` at ``depth_scale`` units per metre."""

    frames: int
    flagged: int
    repaired: int
    out: Path
    format: str
    model: str
    backend: str
    depth_scale: float
    synthesized: int = 0  # frames made for colour frames no depth frame joined (a bag's colour topic)
    scene_used: int | None = None  # frames whose verdict the sensor's scene weighed (None: not judged)
    report: Path | None = None  # what the job did, for a person (report.html)
    changed: int = 0
    pixels: int = 0

    def scene_note(self) -> str:
        """'; N judged against the sensor's own scene too' for a command's summary line ('' where no scene
        was judged): the frames in which the sensor held still long enough for its scene to weigh in."""
        if self.scene_used is None:
            return ""
        return f"; {self.scene_used} also judged against the sensor's own scene (it held still)"

    def line(self) -> str:
        """The summary a command prints: what was flagged, and what changed, in frames and pixels."""
        given = (
            "every frame repaired"
            if self.repaired == self.frames > self.flagged
            else f"{self.flagged} flagged"
        )
        return (
            f"{self.frames} frames: {given}, {self.changed} changed ({self.pixels:,} pixels)"
            + (
                f"; {self.synthesized} synthesized for colour frames without depth"
                if self.synthesized
                else ""
            )
            + f"{self.scene_note()} -> {self.out}"
        )


def _quiet(line: str) -> None:
    """A library call says nothing unless asked (``say``)."""


class _Sink(Protocol):
    def write(self, frame: Frame, depth: np.ndarray, mask: np.ndarray, repaired: bool) -> None: ...

    def finish(self, scale: float, intrinsics: Intrinsics | None) -> None: ...


class _PngSink:
    """``<name>.png`` and ``masks/<name>.png`` in a folder, encoded ``Behind`` the loop."""

    def __init__(self, root: Path, writes: Behind) -> None:
        self.root = root
        self.folder = FrameFolder(root, REPAIRED)
        self.writes = writes
        self.rows: list[dict[str, Any]] = []

    def write(self, frame: Frame, depth: np.ndarray, mask: np.ndarray, repaired: bool) -> None:
        self.writes.submit(self.folder.write, frame.name, depth=depth, masks=mask)
        self.rows.append({"name": frame.name, "timestamp_ns": frame.timestamp_ns, "repaired": repaired})

    def finish(self, scale: float, intrinsics: Intrinsics | None) -> None:
        self.writes.drain()
        self.folder.finish(scale, intrinsics, self.rows)


class _BagFiller:
    """``bagcopy.Synthesis`` through ``d2sr.synth``: the frames of a bag's colour messages no depth
    message joins."""

    def __init__(self, topic: str, scale: float, intrinsics: Intrinsics | None) -> None:
        from d2sr.synth import Filler

        self.topic, self.scale, self.filler = topic, scale, Filler(intrinsics)
        self.started = False  # a real frame came: something to synthesize from

    def real(self, depth: np.ndarray, colour: np.ndarray | None) -> None:
        if depth.dtype != np.uint16:
            raise InputError(
                "colour_topic: frames are synthesized into 16-bit depth topics; this one is 32FC1",
                "colour_topic",
            )
        self.filler.real(to_metres(depth, self.scale), colour)
        self.started = True

    def skipped(self, colour: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        from d2sr.synth.recording import confidence_image

        if not self.started:
            return None
        s = self.filler.synthesize(colour)
        return to_units(s.depth, self.scale), confidence_image(s.confidence)


@contextlib.contextmanager
def _open_sink(
    kind: str, out: Path, input: Path, reader: Any, colour: _BagFiller | None = None
) -> Iterator[_Sink]:
    """The output, in place only when the block ends without error (nothing half-written otherwise)."""
    if kind == "png":
        with atomic_dir(out) as tmp:
            writes = Behind()
            try:
                yield _PngSink(tmp, writes)
            finally:
                writes.close()
        return
    from d2sr.frames.bagcopy import BagCopy

    bag = BagCopy(Path(input), reader.topic, Path(out), ros1=kind == "ros1", colour=colour)
    try:
        yield bag
    except BaseException:
        bag.abort()
        raise
    bag.close()


def detect_recording(
    input: Path,
    out: Path,
    settings: RunSettings | None = None,
    *,
    overwrite: bool = False,
    progress: Progress | None = None,
    say: Callable[[str], object] | None = None,
) -> Summary:
    """Score every frame of a recording: ``out`` is a CSV of ``frame,score,interfered,reason`` (score: the
    detector's probability that the frame is interfered, exact for every frame, so that any threshold can
    be applied to it later; interfered: 1 at or above ``settings.threshold``, and with ``settings.scene``
    as the still sensor's own scene weighs it, primed on the recording's first ``settings.prime`` frames;
    reason: why, one of ``runtime.loop.REASONS``). ``progress(done, total)`` follows the frames; ``say``
    gets the one line on the input and its scale."""
    check_paths(input=input, out=out)
    check_instances(settings=(settings, RunSettings))
    check_callbacks(progress=progress, say=say)
    s = settings if settings is not None else RunSettings()
    check_out(out, is_dir=False, overwrite=overwrite, inputs=_inputs(input))
    reuse_freed_memory()
    net = open_models(model_settings(s), recovery=False)
    reader, scale = open_recording(input, s, say or _quiet)
    judge = s.model_copy(update={"repair": "none"})
    # exact_scores: the CSV's scores serve any threshold the user picks later
    loop = SensorLoop(
        net, make_controller("static", TOTAL_FRAMES, TOTAL_FRAMES), settings=judge, exact_scores=True
    )
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_HEADER)
    flagged = done = used = 0
    with prefetch(checked(reader, scale)) as frames:
        caps = (Capture(f, scale) for f in frames)
        for res in map(loop.process, loop.primed(caps, s.prime)):
            flagged += res.flagged
            used += bool(res.scene)
            w.writerow([cell(res.capture.name), f"{res.score:.6f}", int(res.flagged), res.reason])
            done += 1
            if progress is not None:
                progress(done, len(reader))
    atomic_write(out, buf.getvalue())
    return Summary(
        done, flagged, 0, Path(out), "csv", DETECTOR, net.name, scale, 0, used if s.scene else None
    )


@dataclass(frozen=True)
class Written:
    """How ``recover_recording`` writes: ``format`` ``auto`` (a ROS 1 or ROS 2 bag gives a bag of its kind,
    anything else a PNG folder), ``png`` or ``bag``; ``rerun``: also log the run to a ``.rrd`` file or the
    ``live`` viewer; ``colour_topic`` (a bag in and out, 16-bit depth): every colour message no depth
    message joins gets a synthesized frame (``d2sr.frames.bagcopy``); ``overwrite``: replace an output d2sr
    made; ``report``: write ``report.html`` (``jobs.report``) in a PNG folder out, beside a bag out
    (``OUT.report.html``)."""

    format: str = "auto"
    rerun: str | None = None
    colour_topic: str | None = None
    overwrite: bool = False
    report: bool = True


def recover_recording(
    input: Path,
    out: Path,
    settings: RunSettings | None = None,
    written: Written | None = None,
    *,
    progress: Progress | None = None,
    say: Callable[[str], object] | None = None,
    cores: int | None = None,
) -> Summary:
    """Repair a recording as ``settings`` say: only the frames the detector flags (with ``scene``, weighed
    against the still sensor's own scene), or every frame (``repair="all"``); the scene's own depth where it
    is trusted (``RunSettings.repairs_scene``); the recording's first ``prime`` frames primed into the
    scene. ``written``: how the output is written (``Written``); ``cores``: how many it may use (default:
    the machine's; the output is the same). Frames that are not flagged (unless every frame is repaired)
    come out bit for bit as they went in."""
    from d2sr.jobs.viewer import LIVE, RerunLog

    check_paths(input=input, out=out)
    check_instances(settings=(settings, RunSettings), written=(written, Written))
    check_callbacks(progress=progress, say=say)
    s = settings if settings is not None else RunSettings()
    wr = written if written is not None else Written()
    if s.repair == "none":
        raise ConfigError("recover repairs frames: repair must be flagged or all", "repair")
    every = s.repair == "all"
    kind = _out_format(input, wr.format)
    if wr.colour_topic is not None and kind == "png":
        raise ConfigError(
            "colour_topic: frames are synthesized into a bag; give a ROS bag and a bag out", "colour_topic"
        )
    check_out(out, is_dir=kind != "ros1", overwrite=wr.overwrite, inputs=_inputs(input))
    beside = Path(out).with_name(Path(out).name + ".report.html") if wr.report and kind != "png" else None
    if beside is not None:
        check_out(beside, is_dir=False, overwrite=wr.overwrite, inputs=_inputs(input), name="out's report")
    if wr.rerun is not None and wr.rerun != LIVE:
        check_out(
            Path(wr.rerun),
            is_dir=False,
            overwrite=wr.overwrite,
            inputs=[*_inputs(input), out],
            name="rerun",
        )
    reuse_freed_memory()
    if cores is not None and cores < 1:
        raise ConfigError(f"cores must be at least 1, got {cores}", "cores")
    workers, threads = repair_workers(cores)
    # Repairing every frame, the scene's verdicts would go unused: it is judged only for its repair.
    scene_repair = s.repairs_scene
    scene = s.scene and (not every or scene_repair)
    # Repairing every frame needs no detector (its verdict would go unused) unless a view shows it, a temporal
    # model needs to know which frames were clean, or the scene is judged (its upkeep needs every verdict).
    judged = not every or bool(wr.rerun) or scene
    models = model_settings(s.model_copy(update={"threads": s.threads if s.threads is not None else threads}))
    net = open_models(models, detector=judged)
    if every and not wr.rerun and net.frames > 1:
        net = open_models(models)
    if net.name != "onnxruntime":
        workers = 1
    reader, scale = open_recording(input, s, say or _quiet)
    filler = None
    if wr.colour_topic is not None:
        open_colours(Path(input), wr.colour_topic)  # a topic the bag has, of images
        if getattr(reader, "msgtype", "") != "sensor_msgs/msg/Image":
            raise InputError(f"{input}: a colour topic needs the depth as sensor_msgs/Image")
        filler = _BagFiller(wr.colour_topic, scale, reader.intrinsics)
    loop = SensorLoop(
        net,
        make_controller("static", TOTAL_FRAMES, TOTAL_FRAMES),
        settings=s.model_copy(update={"scene": scene, "scene_repair": scene_repair}),
        detect=judged or net.frames > 1,
        # Repairing every frame, a temporal model's detector only picks the last clean frame (unless a view
        # shows its scores or the scene is judged): it runs where that can change.
        judge_every=judged or net.frames == 1,
    )
    log: AbstractContextManager[Any] = (
        RerunLog(wr.rerun, 1, f"d2sr recover {input}") if wr.rerun else nullcontext()
    )
    flagged = repaired = done = used = changed = pixels = 0
    report = Report(f"d2sr recover {input}") if wr.report else None
    report_path: Path | None = None
    read = checked_counts(reader, scale, "frame") if kind == "png" else checked(reader, scale)
    with (
        log as view,
        _open_sink(kind, Path(out), Path(input), reader, filler) as sink,
        prefetch(read) as frames,
    ):
        caps = loop.primed((Capture(f, scale) for f in frames), s.prime)
        for res in in_order(loop, caps, workers):
            if view is not None:
                view.write(0, res)
            fix = every or res.flagged
            sink.write(res.capture.frame, res.depth, res.mask, fix)
            flagged += res.flagged
            repaired += fix
            moved = _changed(res)
            changed += moved > 0
            pixels += moved
            used += bool(res.scene)
            done += 1
            if report is not None:
                report.add(res)
            if progress is not None:
                progress(done, len(reader))
        if report is not None and isinstance(sink, _PngSink):
            report.write(sink.root / "report.html")
            report_path = Path(out) / "report.html"
        sink.finish(scale, reader.intrinsics)
    if report is not None and beside is not None:
        report.write(beside)
        report_path = beside
    made = getattr(sink, "synthesized", 0)
    return Summary(
        done,
        flagged,
        repaired,
        Path(out),
        kind,
        s.model,
        net.name,
        scale,
        made,
        used if scene else None,
        report_path,
        changed,
        pixels,
    )


def _changed(res: Result) -> int:
    """Pixels of a result's depth that differ from the frame's (only the repair's mask may)."""
    if not res.mask.any():
        return 0
    raw = res.capture.frame.depth
    # Whole frames compared and masked: a third of the time of gathering the masked pixels of both.
    return int(np.count_nonzero((res.depth != raw) & res.mask))


def _inputs(input: Path) -> list[Path]:
    """What an output may not be, lie in or hold: the input, and a ROS 2 bag's whole folder when the input
    names the .db3/.mcap file inside it."""
    from d2sr.frames.rosbag import bag_root

    return list(dict.fromkeys([Path(input), bag_root(Path(input))]))


def _out_format(input: Path, format: str) -> str:
    """png, ros1 or ros2: what recover writes for this input."""
    if format not in FORMATS:
        raise ConfigError(f"format must be one of {', '.join(FORMATS)}, got {format!r}", "format")
    kind = detect_format(Path(input))
    if format == "png" or (format == "auto" and kind not in ("ros1", "ros2")):
        return "png"
    if kind not in ("ros1", "ros2"):
        raise InputError(f"{input}: a bag out needs a ROS 1 or ROS 2 bag in (this is a {kind} recording)")
    return kind
