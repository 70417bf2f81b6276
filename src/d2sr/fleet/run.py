"""``recover_fleet``: many recordings repaired on Ray, one task each, into one output folder."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from d2sr.atomic import check_out, record_manifest
from d2sr.config import check_callbacks, check_instances, check_paths
from d2sr.errors import ConfigError, D2SRError, InputError, OutputError
from d2sr.fleet.cluster import Cluster, connected
from d2sr.fleet.ledger import LEDGER, Ledger, Outcome, fingerprint
from d2sr.fleet.names import output_names
from d2sr.frames.rosbag import bag_root
from d2sr.jobs.recordings import Written, recover_recording
from d2sr.provenance import command_as
from d2sr.runtime.settings import RunSettings
from d2sr.ui import take_warnings

__all__ = ["FleetProgress", "FleetSummary", "recover_fleet"]

RETRIES = 3  # a task whose worker died (killed, out of memory) runs again this many times
REPORT_EVERY = 10  # frames between a worker's progress reports
POLL_S = 0.2  # how often the progress is read (it changes nothing but the display)


@dataclass(frozen=True)
class FleetProgress:
    """Where a fleet stands: ``frames`` repaired so far of ``total`` (the frames of the recordings started
    so far: it grows as they start), recordings ``done``, ``failed`` and ``remaining``, and those
    ``running`` (name -> the process repairing it)."""

    frames: int
    total: int
    done: int
    failed: int
    remaining: int
    running: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class FleetSummary:
    """What a fleet run did: every recording's ``Outcome`` in the order given (``skipped``: those a run
    before had finished, left as they were), the frames this run repaired and its wall time."""

    out: Path
    outcomes: list[Outcome]
    skipped: int
    frames: int
    seconds: float

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.status == "failed"]

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


def recover_fleet(
    recordings: Sequence[Path],
    out: Path,
    settings: RunSettings | None = None,
    written: Written | None = None,
    *,
    cluster: Cluster | None = None,
    progress: Callable[[FleetProgress], None] | None = None,
) -> FleetSummary:
    """Repair every recording as ``recover_recording`` does, each into ``out/<name>`` (``fleet.names``), on
    Ray (``cluster``). ``out/<name>`` holds exactly what ``d2sr recover REC --out out/<name>`` writes (its
    manifest names the fleet's command). ``out/fleet.json`` records each recording's outcome and the
    settings; run again, the recordings done are skipped and the rest redone (a recording's output a run
    stopped before recording it is replaced: d2sr made it). ``written.overwrite`` redoes them all; other
    settings than the folder's are refused unless it is given. A recording that fails does not stop the
    others: it is an ``Outcome`` with its reason (``FleetSummary.failed``)."""
    check_instances(settings=(settings, RunSettings), written=(written, Written), cluster=(cluster, Cluster))
    check_callbacks(progress=progress)
    s = settings if settings is not None else RunSettings()
    wr = written if written is not None else Written()
    cl = cluster if cluster is not None else Cluster()
    if isinstance(recordings, str | os.PathLike) or not isinstance(recordings, Sequence):
        raise ConfigError(f"recordings must be a list of paths, got {type(recordings).__name__}")
    check_paths(out=out, **{f"recording {k}": r for k, r in enumerate(recordings)})
    if not recordings:
        raise ConfigError("no recordings given")
    if s.repair == "none":
        raise ConfigError("a fleet repairs frames: repair must be flagged or all", "repair")
    if wr.rerun is not None:
        raise ConfigError("rerun: view a fleet's recordings one by one (recover each with rerun)", "rerun")
    if s.threads is None:  # one core a task: recordings run side by side, not frames
        s = s.model_copy(update={"threads": 1})
    paths = [Path(r) for r in recordings]
    names = output_names(paths)
    root = _open_folder(Path(out), paths)
    wanted = {"run": s.model_dump(mode="json"), "written": _written(wr)}
    ledger = Ledger.read(root)
    done = {} if ledger is None or wr.overwrite else ledger.settled()
    if done and ledger is not None and ledger.settings != wanted:  # what is done was done otherwise
        raise ConfigError(f"{root} was repaired with other settings ({_changed(ledger.settings, wanted)}); "
                          "allow overwrite to redo it, or name a new output folder",
            "overwrite",)  # fmt: skip
    where = dict(zip(names, paths, strict=True))
    kept = {n: o for n, o in done.items() if n in where and _still(o, root / n, where[n])}
    outcomes: dict[str, Outcome] = dict(kept)
    new = ledger is None
    ledger = Ledger(settings=wanted, recordings=[outcomes[n] for n in names if n in outcomes])
    todo = [(n, p) for n, p in zip(names, paths, strict=True) if n not in kept]
    started = time.perf_counter()
    frames = 0
    if todo:
        with connected(cl) as ray:  # before anything is written: a cluster that is not there leaves nothing
            root.mkdir(parents=True, exist_ok=True)
            ledger.write(root)
            if new:  # the folder is the fleet's from now on: a later run takes it, nothing else does
                record_manifest(root, [LEDGER])
            frames = _run(ray, _Job(root, s, wr, names, ledger, outcomes), todo, cl.workers, progress)
    seconds = time.perf_counter() - started
    final = [outcomes[n] for n in names]
    ledger = Ledger(settings=wanted, recordings=final)
    ledger.write(root, _totals(final, len(kept), frames, seconds))
    return FleetSummary(root, final, len(kept), frames, seconds)


@dataclass
class _Job:
    """A fleet run's folder, settings and record, as its recordings finish."""

    root: Path
    settings: RunSettings
    written: Written
    names: list[str]
    ledger: Ledger
    outcomes: dict[str, Outcome]

    def finished(self, o: Outcome) -> None:
        """One more outcome, recorded at once (a run stopped after this keeps it)."""
        self.outcomes[o.name] = o
        self.ledger.recordings = [self.outcomes[n] for n in self.names if n in self.outcomes]
        self.ledger.write(self.root)


def _run(
    ray: Any,
    job: _Job,
    todo: list[tuple[str, Path]],
    workers: int | None,
    progress: Callable[[FleetProgress], None] | None,
) -> int:
    """Run the recordings ``todo`` on Ray, at most ``workers`` at once, each outcome recorded as it comes;
    the frames repaired."""
    root, s, wr, outcomes = job.root, job.settings, job.written, job.outcomes
    argv = list(sys.argv)
    cap = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
    task = ray.remote(num_cpus=1, max_retries=RETRIES)(_task)
    tally = ray.remote(num_cpus=0)(Tally).remote()
    shared = ray.put((s, argv))
    waiting = list(reversed(todo))
    running: dict[Any, tuple[str, Path]] = {}
    before = len(outcomes)
    while waiting or running:
        while waiting and len(running) < cap:
            name, path = waiting.pop()
            redo = wr.overwrite or (root / name).exists() or (root / name).is_symlink()
            how = Written(wr.format, None, wr.colour_topic, redo, wr.report)
            ref = task.remote(name, str(path), str(root / name), how, shared, tally)
            running[ref] = (name, path)
        ready, _ = ray.wait(list(running), num_returns=1, timeout=POLL_S)
        for ref in ready:
            name, path = running.pop(ref)
            job.finished(_outcome(ray, ref, name, path))
        if progress is not None:
            frames, total, live = ray.get(tally.read.remote())
            failed = sum(o.status == "failed" for o in outcomes.values())
            finished = len(outcomes) - before
            progress(FleetProgress(frames, total, len(outcomes) - failed, failed,
                                   len(todo) - finished, live))  # fmt: skip
    frames_done: int = ray.get(tally.read.remote())[0]
    return frames_done


def _task(name: str, input: str, out: str, written: Written, shared: tuple[RunSettings, list[str]],
          tally: Any) -> Outcome:  # fmt: skip
    """One recording, in a worker: ``recover_recording`` on one core, its manifest naming the fleet's
    command. Every error is its outcome (the other recordings go on); a worker that dies is Ray's to retry."""
    settings, argv = shared
    started = time.perf_counter()
    tally.start.remote(name, os.getpid())

    def progress(done: int, total: int) -> None:
        if done % REPORT_EVERY == 0 or done == total:
            tally.add.remote(name, done, total)

    take_warnings()  # an earlier task's in this worker were handed on with it
    base: dict[str, Any] = {"name": name, "input": input}
    try:
        with command_as(argv):
            s = recover_recording(Path(input), Path(out), settings, written, progress=progress, cores=1)
    except (InputError, ConfigError) as exc:  # the recording's own: the same again next time
        return Outcome(**base, status="failed", reason=_line(exc), fingerprint=fingerprint(Path(input)))
    except D2SRError as exc:
        return Outcome(**base, status="failed", reason=_line(exc))
    except Exception as exc:  # a reader's own error on a broken file: the recording's, not the fleet's
        return Outcome(**base, status="failed", reason=f"{type(exc).__name__}: {_line(exc)}")
    finally:
        tally.stop.remote(name)
        base["warnings"] = [_line(Exception(w)) for w in take_warnings()]
    report = str(s.report.relative_to(Path(out).parent)) if s.report is not None else None
    seconds = round(time.perf_counter() - started, 3)
    return Outcome(**base, status="done", frames=s.frames, flagged=s.flagged, repaired=s.repaired,
                   changed=s.changed, pixels=s.pixels, seconds=seconds, report=report)  # fmt: skip


class Tally:
    """Frames done per recording, reported by the workers (a Ray actor): the progress bar's source only."""

    def __init__(self) -> None:
        self.done: dict[str, tuple[int, int]] = {}
        self.live: dict[str, int] = {}

    def start(self, name: str, pid: int) -> None:
        self.done[name] = (0, self.done.get(name, (0, 0))[1])  # a retried recording starts again
        self.live[name] = pid

    def add(self, name: str, done: int, total: int) -> None:
        self.done[name] = (done, total)

    def stop(self, name: str) -> None:
        self.live.pop(name, None)

    def read(self) -> tuple[int, int, dict[str, int]]:
        return sum(d for d, _ in self.done.values()), sum(t for _, t in self.done.values()), dict(self.live)


def _outcome(ray: Any, ref: Any, name: str, path: Path) -> Outcome:
    try:
        got: Outcome = ray.get(ref)
        return got
    except Exception as exc:  # the task's worker died RETRIES + 1 times, or the cluster went away
        why = f"{type(exc).__name__}: {_line(exc)}"
        return Outcome(name=name, input=str(path), status="failed", reason=f"its worker failed ({why})")


def _open_folder(out: Path, inputs: list[Path]) -> Path:
    """The fleet's output folder: new, empty, or a fleet's (its ``fleet.json``); never one holding anything
    else, nor an input, inside one or around one."""
    roots = [*inputs, *(bag_root(p) for p in inputs)]
    root = check_out(out, is_dir=True, inputs=roots, resume=True)
    if root.exists() and any(root.iterdir()) and not (root / LEDGER).is_file():
        raise OutputError(f"{out} is a d2sr output but not a fleet's (no {LEDGER}); name a new folder", "out")
    return root


def _still(o: Outcome, out: Path, input: Path) -> bool:
    """An outcome a run recorded holds: a recording done still has its output (a user may have removed
    it); one that failed on its own is as it was."""
    if o.status == "done":
        return out.exists() and not out.is_symlink()
    return o.fingerprint == fingerprint(input)


def _written(wr: Written) -> dict[str, Any]:
    return {"format": wr.format, "colour_topic": wr.colour_topic, "report": wr.report}


def _changed(old: dict[str, Any], new: dict[str, Any]) -> str:
    diffs = []
    for group in ("run", "written"):
        a, b = old.get(group, {}), new.get(group, {})
        a = a if isinstance(a, dict) else {}
        diffs += [
            f"{k}: {a.get(k)!r} -> {b.get(k)!r}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)
        ]
    return "; ".join(diffs[:3]) or "unreadable"


def _totals(outcomes: list[Outcome], skipped: int, frames: int, seconds: float) -> dict[str, Any]:
    return {
        "recordings": len(outcomes),
        "done": sum(o.status == "done" for o in outcomes),
        "failed": sum(o.status == "failed" for o in outcomes),
        "skipped": skipped,
        "frames_this_run": frames,
        "seconds_this_run": round(seconds, 3),
    }


def _line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__
