"""Runs in Rerun (``pip install '.[viewer]'``): each sensor's input and repaired depth, the predicted
mask over the repair (and the true mask over the input in simulation), and time series of the detector
score, the flag, the window offset and the share of pixels repaired. The timeline is the frames' own
timestamps (``time``), with the frame count beside it (``frame``).

``RerunLog(target)``: ``target`` is a ``.rrd`` file (written under a temporary name, renamed when the log
closes) or ``live`` (spawns a viewer, or connects to the one already running). Its ``write(sensor,
result)`` is what a run calls for every frame; ``view(run_folder)`` replays a finished run folder.
"""

from __future__ import annotations

import csv
import os
import queue
import socket
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from d2sr.atomic import commit, discard, state, temp_for
from d2sr.config import read_json
from d2sr.errors import InputError
from d2sr.frames.base import check_name
from d2sr.frames.layout import RUN, FrameFolder, sensor_dir
from d2sr.frames.png import decode_png
from d2sr.jobs.output import MAX_SENSORS
from d2sr.runtime.loop import Result

__all__ = ["LIVE", "RerunLog", "view"]

LIVE = "live"
VIEWER_PORT = 9876  # where a Rerun viewer listens by default


def _rerun() -> Any:
    try:
        import rerun
    except ImportError:
        raise InputError("Rerun logging needs rerun-sdk: pip install '.[viewer]'") from None
    return rerun


class RerunLog:
    """One Rerun recording of a run (see the module docstring)."""

    def __init__(
        self,
        target: str | Path,
        sensors: int,
        name: str = "d2sr run",
        stride: int = 2,
        asked: tuple[str, str] = ("--rerun live", "--rerun FILE.rrd"),
    ) -> None:
        """``asked``: how the caller asked for a live viewer and how it saves a file instead (named in
        the one-line errors)."""
        rr = self.rr = _rerun()
        self._asked = asked
        # Images are logged at every ``stride``-th pixel: a view, not the record (the run folder keeps
        # every pixel); 2 keeps logging under 10% of a 2-core loop's time (bench/rerun_overhead.py).
        self.stride = max(1, int(stride))
        self.rec = rr.RecordingStream("d2sr", recording_id=None)
        self.rec.send_recording_name(name)
        self.path: Path | None = None
        self._tmp: Path | None = None
        if str(target) == LIVE:
            self._spawn()
        else:
            self.path = Path(target)
            self._tmp = temp_for(self.path, is_dir=False)
            self._before = state(self.path)
            self.rec.save(str(self._tmp))
        self.rec.send_blueprint(self._blueprint(sensors))
        self._frames = [0] * sensors
        # Logging happens on a thread of its own, a few frames behind: the loop hands results over and
        # goes on (the arrays are not touched again), so the viewer costs the loop little.
        self._queue: queue.Queue[tuple[int, Result] | None] = queue.Queue(maxsize=8)
        self._error: BaseException | None = None
        self._worker = threading.Thread(target=self._drain, daemon=True)
        self._worker.start()

    def _drain(self) -> None:
        while (item := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._log(*item)
                except BaseException as exc:  # re-raised in the loop's thread at the next write / close
                    self._error = exc

    def _spawn(self) -> None:
        """Reach the viewer running on this machine, or start one, and stream to it. The viewer binary
        comes with rerun-sdk next to this Python; a shell that did not activate the environment lacks it
        in PATH. Without a screen (no DISPLAY or Wayland) no viewer can start: a one-line error."""
        with socket.socket() as s:
            s.settimeout(0.2)
            running = s.connect_ex(("127.0.0.1", VIEWER_PORT)) == 0
        if running:
            self.rec.connect_grpc()
            return
        if sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        ):
            raise InputError(
                f"{self._asked[0]}: no viewer is running and there is no screen to start one; start `rerun` "
                f"where you can see it, or save with {self._asked[1]}"
            )
        here = str(Path(sys.executable).parent)
        path = os.environ.get("PATH", "")
        if here not in path.split(os.pathsep):
            os.environ["PATH"] = here + os.pathsep + path
        try:
            self.rec.spawn()
        except (RuntimeError, OSError) as exc:
            reason = str(exc).strip().splitlines()[0]
            raise InputError(
                f"{self._asked[0]}: cannot start a Rerun viewer ({reason}); save with {self._asked[1]}"
            ) from None

    def _blueprint(self, sensors: int) -> Any:
        rrb = self.rr.blueprint
        rows = [
            rrb.Horizontal(
                rrb.Spatial2DView(origin=f"sensor{i}/input", name=f"sensor {i}: input"),
                rrb.Spatial2DView(origin=f"sensor{i}/repaired", name=f"sensor {i}: repaired, predicted mask"),
                rrb.TimeSeriesView(origin=f"series/sensor{i}", name=f"sensor {i}: score, flag, window"),
            )
            for i in range(sensors)
        ]
        return rrb.Blueprint(rrb.Vertical(*rows), collapse_panels=True)

    def _time(self, sensor: int, timestamp_ns: int | None) -> None:
        self.rec.set_time("frame", sequence=self._frames[sensor])
        self._frames[sensor] += 1
        if timestamp_ns is not None:
            self.rec.set_time("time", timestamp=np.datetime64(int(timestamp_ns), "ns"))

    def write(self, sensor: int, res: Result) -> None:
        """Log one frame's input, repair, masks and figures (on the logging thread)."""
        if self._error is not None:
            raise self._error
        self._queue.put((sensor, res))

    def _log(self, sensor: int, res: Result) -> None:
        rr, cap = self.rr, res.capture
        self._time(sensor, cap.frame.timestamp_ns)
        meter = 1.0 if cap.frame.depth.dtype == np.float32 else cap.scale
        base, s = f"sensor{sensor}", self.stride
        self.rec.log(f"{base}/input", rr.DepthImage(cap.frame.depth[::s, ::s], meter=meter))
        self.rec.log(f"{base}/repaired", rr.DepthImage(res.depth[::s, ::s], meter=meter))
        self.rec.log(f"{base}/repaired/mask", rr.SegmentationImage(res.mask[::s, ::s].astype(np.uint8)))
        if cap.mask is not None:
            self.rec.log(f"{base}/input/true_mask", rr.SegmentationImage(cap.mask[::s, ::s].astype(np.uint8)))
        self._series(sensor, res.score, res.flagged, res.offset, float(res.mask.mean()), cap.interfered)

    def _series(
        self, sensor: int, score: float, flagged: bool, offset: int, share: float, truth: bool | None
    ) -> None:
        rr, s = self.rr, f"series/sensor{sensor}"
        self.rec.log(f"{s}/score", rr.Scalars(score))
        self.rec.log(f"{s}/flagged", rr.Scalars(float(flagged)))
        self.rec.log(f"{s}/window_offset", rr.Scalars(float(offset)))
        self.rec.log(f"{s}/repaired_share", rr.Scalars(share))
        if truth is not None:
            self.rec.log(f"{s}/interfered", rr.Scalars(float(truth)))

    def close(self, ok: bool = True) -> None:
        """Finish the recording; a file appears at its path only when the run ended well."""
        if self._worker.is_alive():
            self._queue.put(None)
            self._worker.join()
        failed, self._error = self._error, None
        self.rec.flush(timeout_sec=10.0)  # a viewer that went away must not hold the run
        self.rec.disconnect()
        if self._tmp is not None and self.path is not None:
            if ok and failed is None:
                commit(self._tmp, self.path, self._before)
            else:
                discard(self._tmp)
            self._tmp = None
        if ok and failed is not None:  # the run went well but its log did not
            raise failed

    def __enter__(self) -> RerunLog:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close(ok=kind is None)


@dataclass(frozen=True)
class _Logged:
    """One line of a run's ``log.csv``, checked."""

    sensor: int
    frame: str
    stamp: int | None
    score: float | None
    flagged: bool
    offset: int
    repaired: float
    truth: bool | None


def _row(r: dict[str, str | None], line: int, run: Path) -> _Logged:
    """A log line as values, or an InputError naming the line (a run folder is data: nothing is trusted)."""

    def num(key: str) -> float | None:
        v = r.get(key)
        if v in ("", "n/a"):
            return None
        x = float(v or "nan")
        if not np.isfinite(x):
            raise ValueError(f"line {line}: {key} is {v!r}")
        return x

    try:
        sensor = int(r.get("sensor") or "")
        if not 0 <= sensor < MAX_SENSORS:
            raise ValueError(f"line {line}: sensor {sensor} (a run holds sensors 0..{MAX_SENSORS - 1})")
        frame = check_name(r.get("frame"), f"{run}/log.csv line {line}")
        t, score, share = num("time_s"), num("score"), num("repaired_share")
        return _Logged(
            sensor, frame, None if t is None else round(t * 1e9), score, r.get("flagged") == "1",
            int(num("offset") or 0), share or 0.0, None if r.get("interfered") in ("", "n/a", None)
            else r.get("interfered") == "1",
        )  # fmt: skip
    except (TypeError, OverflowError) as exc:
        raise ValueError(f"line {line}: {exc}") from None


def _png(path: Path, dtype: type) -> np.ndarray:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    return decode_png(data, str(path), dtype)


def view(run: Path, target: str | Path) -> int:
    """Replay a finished ``d2sr run`` folder (repaired frames, predicted masks, log.csv) into Rerun;
    returns the frames logged."""
    log_path = Path(run) / "log.csv"
    if not log_path.is_file():
        raise InputError(f"{run}: not a finished d2sr run folder (no log.csv)")
    try:
        settings = read_json(Path(run) / "settings.json")
        with log_path.open(newline="", errors="surrogateescape") as fh:
            rows = [_row(r, k + 2, run) for k, r in enumerate(csv.DictReader(fh))]
    except (OSError, ValueError, csv.Error) as exc:
        raise InputError(f"{run}: cannot read the run's log ({str(exc)[:100]})") from None
    scale = settings.get("depth_scale") if isinstance(settings, dict) else None
    if (
        not isinstance(scale, int | float)
        or isinstance(scale, bool)
        or not (np.isfinite(scale) and scale > 0)
    ):
        scale = 4000.0
    sensors = 1 + max((r.sensor for r in rows), default=0)
    folders = [FrameFolder(sensor_dir(Path(run), i), RUN, create=False) for i in range(sensors)]
    asked = ("d2sr view (no --save)", "--save FILE.rrd")
    with RerunLog(target, sensors, f"d2sr run {Path(run).name}", asked=asked) as log:
        for r in rows:
            log._time(r.sensor, r.stamp)
            depth = _png(folders[r.sensor].path("depth", r.frame), np.uint16)
            mask = _png(folders[r.sensor].path("masks", r.frame), np.uint8) > 0
            log.rec.log(f"sensor{r.sensor}/repaired", log.rr.DepthImage(depth, meter=float(scale)))
            log.rec.log(f"sensor{r.sensor}/repaired/mask", log.rr.SegmentationImage(mask.astype(np.uint8)))
            if r.score is not None:  # a synthesized frame has no score, flag or repair
                log._series(r.sensor, r.score, r.flagged, r.offset, r.repaired, r.truth)
    return len(rows)
