"""A run's output folder: repaired frames, masks and a per-frame log, safe against being killed.

The run writes into a working folder next to ``OUT`` (``.<out>.d2sr-<pid>-<random>.partial``, marked
inside by ``RUN_MARK``); each PNG lands under a temporary name and is renamed, and its log line is written
(and flushed) only after both of the frame's PNGs exist. So a killed run leaves only complete files. A
rerun with the same settings on a recording resumes from the log (the controller is replayed from the
logged flags); anything else starts in a fresh working folder. Only folders with d2sr's name and marker
are ever resumed or removed. ``finish`` renames the folder to ``OUT`` in one step, so ``OUT`` only ever
holds a complete run.
"""

from __future__ import annotations

import contextlib
import csv
import glob
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.atomic import commit, ours, sibling, state, writing
from d2sr.config import read_json
from d2sr.errors import D2SRError
from d2sr.frames.layout import RUN, RUN_FILLED, FrameFolder, sensor_dir
from d2sr.frames.overlap import Behind
from d2sr.runtime.loop import Result
from d2sr.synth.recording import confidence_image
from d2sr.ui import NA

__all__ = ["LOG_COLUMNS", "RUN_MARK", "RunFolder", "SensorSink", "SynthFrame"]

RUN_MARK = ".d2sr-run.json"  # inside a run's working folder: whose it is
MAX_SENSORS = 64  # sensors one run folder holds (a log naming more is not d2sr's)

LOG_COLUMNS = [
    "sensor",
    "frame",
    "time_s",
    "period",
    "slot",
    "offset",
    "score",
    "flagged",
    "repaired_share",
    "interfered",
    "true_share",
    "ms",
    "synthesized",  # 1: a slot the laser skipped, synthesized (d2sr run --fill; score and flag n/a)
]


class RunFolder:
    """``with RunFolder(out, settings, resumable) as run:`` ``run.write(sensor, result)``, then
    ``run.finish(summary)``. Leaving the block on a D2SRError (bad input) discards the partial run; a kill
    leaves it for the next run to resume."""

    def __init__(self, out: Path, settings: dict[str, Any], resumable: bool, fill: bool = False) -> None:
        """``fill``: the run also holds synthesized frames, and every frame its ``confidence``."""
        self.out = Path(out)
        self.layout = RUN_FILLED if fill else RUN
        self.settings = json.loads(json.dumps(settings, default=str))
        self.done: dict[tuple[int, str], dict[str, Any]] = {}
        self.resumed = False
        self._folders: dict[int, FrameFolder] = {}
        self._before = state(self.out)  # what is there as the run begins: nothing else is replaced
        earlier = self._earlier()
        match = next((p for p in earlier if resumable and _settings(p) == self.settings), None)
        with writing(self.out):
            for p in earlier:  # a run that cannot be resumed is not kept
                if p != match:
                    shutil.rmtree(p, ignore_errors=True)
            if match is not None:
                self.partial = match
                for torn in match.rglob(".*.png.tmp"):  # a PNG a kill cut short
                    torn.unlink()
                self.done = self._read_log()
                self.resumed = bool(self.done)
            else:
                self.partial = sibling(self.out, "partial")
                self.partial.mkdir(parents=True)
                (self.partial / RUN_MARK).write_text(json.dumps({"made_by": "d2sr", "out": self.out.name}))
                (self.partial / "settings.json").write_text(json.dumps(self.settings, indent=1) + "\n")
        new = not (self.partial / "log.csv").is_file()
        # Names are any bytes a file system allows: surrogateescape writes them back as they were.
        self._log = open(self.partial / "log.csv", "a", newline="", errors="surrogateescape")  # noqa: SIM115
        self._csv = csv.writer(self._log)
        if new:
            self._csv.writerow(LOG_COLUMNS)
            self._log.flush()
        self._writes = Behind()

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self.close()
        if kind is not None and issubclass(kind, D2SRError):
            shutil.rmtree(self.partial, ignore_errors=True)

    def _earlier(self) -> list[Path]:
        """Working folders an earlier run on ``out`` left (d2sr's by name and by marker)."""
        found, name = [], self.out.name
        for p in sorted(self.out.parent.glob(f".{glob.escape(self.out.name)}.d2sr-*.partial")):
            if ours(p, ("partial",)) is None or p.is_symlink() or not p.is_dir():
                continue
            with contextlib.suppress(OSError, ValueError):
                mark = read_json(p / RUN_MARK)
                if isinstance(mark, dict) and mark.get("made_by") == "d2sr" and mark.get("out") == name:
                    found.append(p)
        return found

    def _read_log(self) -> dict[tuple[int, str], dict[str, Any]]:
        """Complete log lines whose PNGs exist; the log is cut back to them (a killed run's last line may
        be torn)."""
        path = self.partial / "log.csv"
        try:
            lines = path.read_text(errors="surrogateescape").splitlines(keepends=True)
        except OSError:
            return {}
        keep, done = lines[:1], {}
        for line in lines[1:]:
            if not line.endswith("\n"):
                break
            row = next(csv.reader([line]))
            if len(row) != len(LOG_COLUMNS):
                break
            rec = dict(zip(LOG_COLUMNS, row, strict=True))
            if not rec["sensor"].isdigit() or int(rec["sensor"]) >= MAX_SENSORS:
                break
            if not self._folder(int(rec["sensor"]), create=False).has(rec["frame"]):
                break
            done[(int(rec["sensor"]), rec["frame"])] = rec
            keep.append(line)
        path.write_text("".join(keep), errors="surrogateescape")
        return done

    def _folder(self, sensor: int, create: bool = True) -> FrameFolder:
        """Sensor ``sensor``'s frames in the partial run (made on first write)."""
        if sensor not in self._folders:
            folder = FrameFolder(sensor_dir(self.partial, sensor), self.layout, create)
            if not create:
                return folder
            self._folders[sensor] = folder
        return self._folders[sensor]

    def sink(self, sensor: int) -> SensorSink:
        """This folder as one sensor's ``Sink`` (what ``SensorLoop(sink=...)`` takes)."""
        return SensorSink(self, sensor)

    def write(self, sensor: int, res: Result) -> None:
        """Queue the frame's PNGs; its log line follows once they are on disk."""
        self._writes.submit(self._write, sensor, res)

    def _write(self, sensor: int, res: Result) -> None:
        name = res.capture.name
        extra = {"confidence": confidence_image(res.depth > 0)} if self.layout is RUN_FILLED else {}
        self._folder(sensor).write(name, depth=res.depth, masks=res.mask, **extra)
        cap = res.capture
        truth = cap.interfered
        self._csv.writerow(
            [
                sensor,
                name,
                NA if cap.frame.timestamp_ns is None else f"{cap.frame.timestamp_ns / 1e9:.6f}",
                res.period,
                NA if cap.slot is None else cap.slot,
                res.offset,
                f"{res.score:.6f}",
                int(res.flagged),
                f"{res.mask.mean():.5f}",
                NA if truth is None else int(truth),
                NA if cap.mask is None else f"{cap.mask.mean():.5f}",
                f"{res.seconds * 1000:.2f}",
                0,
            ]
        )
        self._log.flush()

    def write_synthesized(self, sensor: int, frame: SynthFrame) -> None:
        """Queue a synthesized frame (``d2sr run --fill``): its depth, an empty mask and its confidence."""
        if self.layout is not RUN_FILLED:
            raise ValueError("a run folder without fill=True holds no synthesized frames")
        self._writes.submit(self._write_synthesized, sensor, frame)

    def _write_synthesized(self, sensor: int, f: SynthFrame) -> None:
        masks, conf = np.zeros(f.depth.shape, bool), confidence_image(f.confidence)
        self._folder(sensor).write(f.name, depth=f.depth, masks=masks, confidence=conf)
        t = NA if f.timestamp_ns is None else f"{f.timestamp_ns / 1e9:.6f}"
        self._csv.writerow(
            [
                sensor,
                f.name,
                t,
                f.period,
                NA if f.slot is None else f.slot,
                f.offset,
                NA,
                NA,
                NA,
                NA,
                NA,
                f"{f.ms:.2f}",
                1,
            ]
        )
        self._log.flush()

    def drain(self) -> None:
        self._writes.drain()

    def finish(self, summary: dict[str, Any]) -> Path:
        """Write ``summary.json`` and move the complete run into place."""
        self.drain()
        self._log.close()
        with writing(self.out):
            (self.partial / "summary.json").write_text(json.dumps(summary, indent=1, default=str) + "\n")
            (self.partial / RUN_MARK).unlink()
        commit(self.partial, self.out, self._before)
        return self.out

    def close(self) -> None:
        self._writes.close()
        if not self._log.closed:
            self._log.close()


@dataclass(frozen=True)
class SynthFrame:
    """A frame synthesized for a slot the laser skipped, as a run folder logs it: ``depth`` in the run's
    units, ``confidence`` per pixel in [0, 1], and where it lies (its period, slot and the window offset)."""

    name: str
    depth: np.ndarray
    confidence: np.ndarray
    timestamp_ns: int | None
    period: int
    slot: int | None  # None: a recording's or an open-loop camera's (no clock says)
    offset: int
    ms: float


@dataclass
class SensorSink:
    folder: RunFolder
    sensor: int

    def write(self, res: Result) -> None:
        self.folder.write(self.sensor, res)


def _settings(folder: Path) -> dict[str, Any] | None:
    try:
        data = read_json(folder / "settings.json")
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
