"""The closed-loop runtime: one sensor's loop, the simulated room, run folders (resume, replay), d2sr run."""

from __future__ import annotations

import csv
import hashlib
import re
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.contract.catalog import THRESHOLD
from d2sr.desync import make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame
from d2sr.frames.png import PngWriter
from d2sr.jobs.session import Recording, run_recording, run_sim
from d2sr.runtime.backends import Gated, open_backend
from d2sr.runtime.loop import Capture, PeriodEnd, SensorLoop
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.sim.lockstep import SimRoom, Start
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.timing import TimingSettings
from d2sr.sim.world import make_rig
from helpers import FakeNet, d2sr


class Recorder:
    def __init__(self) -> None:
        self.calls: list[tuple[int, int]] = []

    def set_offset(self, period: int, offset: int) -> None:
        self.calls.append((period, offset))


def _cap(name: str, bad: bool, slot: int | None = None) -> Capture:
    d = np.full((8, 16), 8000, np.uint16)
    d[0, 0] = 1 if bad else 8000
    return Capture(Frame(name, d), 4000.0, slot)


def test_open_loop_makes_a_period_of_every_n_frames_and_repairs_only_flagged():
    ctrl = make_controller("d2sr", 30, 3, seed=0, offset=5)
    net = FakeNet()
    loop = SensorLoop(net, ctrl)
    results = [loop.process(_cap(f"{i}", bad=i in (1, 4))) for i in range(6)]
    assert loop.period == 2 and net.recovered == 2
    assert [r.flagged for r in results] == [False, True, False, False, True, False]
    fixed = results[1]
    assert (fixed.depth[:, :8] == 8000).all()  # 2 m at 4000 units/m
    # do no harm: of the masked half, only the pixel that was off is reported (and written) as repaired
    assert fixed.mask[0, 0] and fixed.mask.sum() == 1
    assert np.array_equal(fixed.depth[:, 8:], fixed.capture.frame.depth[:, 8:])  # outside: unchanged
    assert not results[0].mask.any() and results[0].depth is results[0].capture.frame.depth


def test_repairing_every_frame_needs_no_detector():
    class NoDetector(FakeNet):
        def scores(
            self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
        ) -> np.ndarray:
            raise AssertionError("the detector ran")

    ctrl = make_controller("static", 30, 3)
    got = SensorLoop(
        NoDetector(), ctrl, detect=False, settings=RunSettings(repair="all", scene=False)
    ).process(_cap("0", bad=True))
    ref = SensorLoop(FakeNet(), ctrl, settings=RunSettings(repair="all", scene=False)).process(
        _cap("0", bad=True)
    )
    assert np.array_equal(got.depth, ref.depth) and np.array_equal(got.mask, ref.mask) and got.mask.any()
    assert np.isnan(got.score) and not got.flagged
    # Only where no verdict is used: repairing flagged frames, or a temporal model's last clean frame.
    with pytest.raises(ConfigError, match="detect=False"):
        SensorLoop(FakeNet(), ctrl, detect=False, settings=RunSettings(repair="flagged", scene=False))
    with pytest.raises(ConfigError, match="detect=False"):
        SensorLoop(FakeNet(frames=2), ctrl, detect=False, settings=RunSettings(repair="all", scene=False))


def test_temporal_backend_gets_the_last_frame_the_detector_passed():
    net = FakeNet(frames=2)
    loop = SensorLoop(net, make_controller("static", 30, 3), settings=RunSettings(repair="all", scene=False))
    first = _cap("0", bad=True)
    first.frame.depth[3, 3] = 4000  # marks this flagged frame (1 m)
    loop.process(first)
    clean = _cap("1", bad=False)
    clean.frame.depth[2, 2] = 2000
    loop.process(clean)
    loop.process(_cap("2", bad=True))
    loop.process(_cap("3", bad=True))
    # Nothing clean before frames 0 and 1: the model falls back on its fill.
    assert net.previous[0] is None and net.previous[1] is None
    for prev in net.previous[2:]:  # frame 1, not the flagged frames 0 and 2
        assert prev is not None and prev[0, 2, 2] == 0.5 and prev[0, 3, 3] == 2.0
    one = FakeNet()
    loop = SensorLoop(one, make_controller("static", 30, 3), settings=RunSettings(repair="all", scene=False))
    loop.process(clean)
    loop.process(_cap("2", bad=True))
    assert one.previous == [None, None]  # a one-frame model is never handed frames it cannot use


def test_repairing_every_frame_the_detector_runs_only_where_the_last_clean_frame_can_change():
    # With repair="all" and a temporal model the detector only picks the last clean frame: it runs while
    # there is none, where a frame stops lining up with it, and every REFRESH_FRAMES frames.
    from d2sr.contract.repair import REFRESH_FRAMES

    net = FakeNet(frames=2)
    loop = SensorLoop(
        net,
        make_controller("static", 30, 3),
        judge_every=False,
        settings=RunSettings(repair="all", scene=False),
    )
    results = [loop.process(_cap("0", bad=True)), loop.process(_cap("1", bad=False))]
    assert len(net.before) == 2  # judged: no last clean frame yet, then frame 1 passes
    for i in range(2, 2 + 2 * REFRESH_FRAMES):
        results.append(loop.process(_cap(str(i), bad=i % 2 == 0)))
    judged = [i for i, r in enumerate(results) if not np.isnan(r.score)]
    assert judged == [0, 1, 1 + REFRESH_FRAMES, 1 + 2 * REFRESH_FRAMES]
    assert len(net.before) == len(judged)
    assert net.recovered == len(results)  # every frame repaired, judged or not
    # An unjudged frame never becomes the last clean frame, even one the detector would pass.
    assert all(p is not None and p[0, 0, 0] * 4000 == 8000 for p in net.previous[2:])
    moved = _cap("moved", bad=False)
    moved.frame.depth[:] = 16000  # no longer lines up with the last clean frame (2 m against 4 m)
    assert not np.isnan(loop.process(moved).score)
    with pytest.raises(ConfigError):
        SensorLoop(
            FakeNet(),
            make_controller("static", 30, 3),
            judge_every=False,
            settings=RunSettings(repair="all", scene=False),
        )
    with pytest.raises(ConfigError):
        SensorLoop(
            net,
            make_controller("static", 30, 3),
            judge_every=False,
            settings=RunSettings(repair="flagged", scene=False),
        )


def test_auto_takes_the_temporal_model_only_where_the_last_clean_frame_lines_up():
    single, temporal = FakeNet(1), FakeNet(2)
    net = Gated(single, temporal)
    assert net.frames == 2 and net.name == "fake"
    x = np.full((3, 8, 16), 2.0, np.float32)
    moved = x.copy()
    moved[1, :5] = 3.0  # frame 1: 5 of 8 rows no longer line up (a moving sensor)
    moved[2, :3] = 3.0  # frame 2: 3 of 8 rows moved, the rest lines up
    pred, mask = net.recover(x, moved)
    assert pred.shape == mask.shape == x.shape
    assert single.recovered == 1 and temporal.recovered == 2  # frames 0 and 2 temporal, frame 1 not
    assert single.previous == [None]  # the single-frame model never gets the frame it cannot use
    assert np.array_equal(temporal.previous[0], moved[0:1])
    assert np.array_equal(temporal.previous[1], moved[2:3])
    net.recover(x[:1], None)  # no last clean frame at all
    assert single.recovered == 2 and temporal.recovered == 2
    assert net.scores(x[:1]).shape == (1,)  # the detector is the single-frame side's
    with pytest.raises(InputError):
        Gated(temporal, single)


def test_triggered_loop_reads_flags_in_window_order_and_tells_the_trigger():
    ctrl = make_controller("d2sr", 30, 4, seed=0, offset=28)  # window 28, 29, 0, 1 (wraps)
    trig = Recorder()
    seen = []
    ctrl.update = lambda flags: seen.append(list(flags)) or 7  # type: ignore[method-assign]
    loop = SensorLoop(FakeNet(), ctrl, trig, settings=RunSettings(repair="none", scene=False))
    assert trig.calls == [(0, 28)]
    for slot, bad in ((0, True), (1, False), (28, False)):  # slot 29's frame was dropped
        loop.step(_cap(f"s{slot}", bad, slot))
    loop.step(PeriodEnd(0))
    assert seen == [[False, False, True, False]]  # 28, 29 (missing: clean), 0, 1
    assert trig.calls[-1] == (1, 7)


def test_loop_pads_frames_the_model_strides_do_not_divide(net):
    d = np.full((240, 320), 8000, np.uint16)  # 240 is not a multiple of 32
    d[:, 100:140] = 0
    res = SensorLoop(
        net, make_controller("static", 30, 3), settings=RunSettings(repair="all", scene=False)
    ).process(Capture(Frame("f", d), 4000))
    assert res.depth.shape == res.mask.shape == (240, 320) and res.depth.dtype == np.uint16
    assert np.array_equal(res.depth[~res.mask], d[~res.mask])


def test_loop_takes_float_metres_only_at_scale_1_and_refuses_a_bad_repair_mode():
    loop = SensorLoop(FakeNet(), make_controller("static", 30, 3))
    with pytest.raises(InputError, match="metres"):
        loop.process(Capture(Frame("f", np.ones((8, 16), np.float32)), 1000.0))
    with pytest.raises(InputError, match="uint16"):
        loop.process(Capture(Frame("f", np.ones((8, 16), np.int32)), 1000.0))
    res = loop.process(Capture(Frame("f", np.ones((8, 16), np.float32)), 1.0))
    assert res.depth.dtype == np.float32
    with pytest.raises(ConfigError, match="repair"):
        SensorLoop(
            FakeNet(), make_controller("static", 30, 3), settings=RunSettings(repair="some", scene=False)
        )


def test_room_interference_follows_the_windows_the_triggers_set():
    rig = make_rig(0, sensors=2)
    cfg = TimingSettings(active_frames=6, drift_ppm=0, hit_prob=1.0, setup=2)
    graph = OverlapGraph.complete(2)

    def overlapped(offsets: list[int]) -> float:
        room = SimRoom(rig, cfg, seed=1, start=Start(graph, offsets, [0.0, 0.05]), render=False)
        evs = [e for e in room.slots(4.0) if e.frame is not None]
        assert len(evs) == 2 * 4 * 6  # every window slot delivers a frame
        return float(np.mean([e.frame.interfered for e in evs]))  # type: ignore[union-attr]

    # phases 1.5 slots apart: all frames overlap but sensor 1's last of each window (sensor 0's laser is
    # off by then) and sensor 0's very first (no start-up slots before the run): 1 - 5/48
    assert overlapped([0, 0]) == pytest.approx(1 - 5 / 48)
    assert overlapped([0, 15]) == 0.0  # 8 laser slots each, far apart
    room = SimRoom(rig, cfg, seed=1, start=Start(graph, [0, 0], [0.0, 0.05]), render=False)
    room.set_offset(1, 2, 15)  # from period 2 on, sensor 1 moves away
    late = [e for e in room.slots(4.0) if e.frame is not None and e.slot >= 3 * 30]
    assert not any(e.frame.interfered for e in late)  # type: ignore[union-attr]


@pytest.fixture(scope="module")
def net():
    return open_backend(RunSettings(model="unet8", backend="onnx", threads=1))


@pytest.mark.slow  # a long simulation: not in make test-fast
def test_closed_loop_in_a_room_desynchronizes_and_repairs(net):
    static = run_sim(net, None, RunSettings(), LoopSettings(controller="static", sensors=3, seconds=8.0))
    ours = run_sim(net, None, RunSettings(), LoopSettings(sensors=3, seconds=8.0))
    s, o = static["all"], ours["all"]
    assert s["frames"] == o["frames"] == 3 * 8 * 6
    assert s["interfered_ratio"] > 0.15  # the seed-0 room: two sensors start on the same slots
    assert o["interfered_ratio"] < 0.5 * s["interfered_ratio"]
    assert s["precision"] >= 0.9 and s["recall"] >= 0.8
    assert s["rmse_after_cm"] < s["rmse_before_cm"]
    # each sensor's window moved only through its own trigger: the offsets the world used are logged
    assert all(len(o_) == 8 for o_ in ours["offsets"])


def test_run_sim_fill_writes_every_slot_and_leaves_the_real_frames_as_they_were(net, tmp_path):
    # --fill: each slot a sensor's laser skipped gets a synthesized frame (logged as such, no verdict, its
    # confidence beside it); the real frames and their log lines are those of the same run without it.
    kw = {"sensors": 2, "seconds": 2.0, "seed": 3, "moving": True}
    plain = run_sim(net, tmp_path / "plain", RunSettings(), LoopSettings(**kw))
    filled = run_sim(net, tmp_path / "filled", RunSettings(), LoopSettings(fill=True, **kw))
    slots = 2 * 30
    # report.html covers every sensor's real frames, each named by its sensor and slot
    page = (tmp_path / "plain" / "report.html").read_text()
    assert "d2sr run sim (2 sensors)" in page and f"{plain['all']['frames']} frames;" in page
    assert all(
        r.startswith(("sensor 0, slot", "sensor 1, slot")) for r in re.findall(r"<tr><td>([^<]*)<", page)
    )
    for i in range(2):
        real = sorted(p.name for p in (tmp_path / "plain" / f"sensor{i}" / "depth").glob("*.png"))
        out = tmp_path / "filled" / f"sensor{i}"
        every = sorted(p.name for p in (out / "depth").glob("*.png"))
        assert len(every) == slots and set(real) < set(every)
        assert sorted(p.name for p in (out / "confidence").glob("*.png")) == every
        for name in real:
            assert (out / "depth" / name).read_bytes() == (
                tmp_path / "plain" / f"sensor{i}" / "depth" / name
            ).read_bytes()
        assert filled["synthesized"][i] == slots - len(real) == slots - plain["sensors"][i]["frames"]
    rows = list(csv.DictReader((tmp_path / "filled" / "log.csv").open()))
    made = [r for r in rows if r["synthesized"] == "1"]
    assert len(made) == sum(filled["synthesized"]) and all(r["flagged"] == "n/a" for r in made)
    before = [
        {k: v for k, v in r.items() if k not in ("ms", "synthesized")}
        for r in rows
        if r["synthesized"] == "0"
    ]
    plain_rows = list(csv.DictReader((tmp_path / "plain" / "log.csv").open()))
    assert before == [{k: v for k, v in r.items() if k not in ("ms", "synthesized")} for r in plain_rows]
    # The moving sensor's synthesized frames follow its odometry: not its last real frame held.
    moving = tmp_path / "filled" / "sensor1"
    seq = sorted((r["frame"], r["synthesized"]) for r in rows if r["sensor"] == "1")
    pairs = [(a, b) for (a, ra), (b, rb) in pairwise(seq) if (ra, rb) == ("0", "1")]
    assert pairs  # a real frame followed by a skipped slot

    def read(name: str) -> np.ndarray:
        return cv2.imread(str(moving / "depth" / f"{name}.png"), cv2.IMREAD_UNCHANGED)

    assert all(read(b).any() and not np.array_equal(read(a), read(b)) for a, b in pairs)
    with pytest.raises(ConfigError, match="fill"):
        run_sim(net, None, RunSettings(), LoopSettings(fill=True, **kw))


def _recording(tmp_path: Path, n: int = 12) -> Path:
    rng = np.random.default_rng(0)
    frames = []
    for i in range(n):
        d = rng.integers(6000, 12000, (96, 128)).astype(np.uint16)
        if i % 3 == 1:
            d[:, 40:60] = (d[:, 40:60] * 0.4).astype(np.uint16)  # a too-short band
            d[::2, 40:60] = 0
        frames.append(Frame(f"f{i:03d}", d))
    root = tmp_path / "rec"
    with PngWriter(root, 4000.0) as w:
        for f in frames:
            w.write(f)
    return root


def _digest(out: Path) -> dict[str, str]:
    files = sorted(p for p in out.rglob("*.png"))
    digest = {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}
    with (out / "log.csv").open() as fh:  # every column but the timing
        rows = [{k: v for k, v in r.items() if k != "ms"} for r in csv.DictReader(fh)]
    digest["log"] = hashlib.sha256(repr(rows).encode()).hexdigest()
    return digest


class Killed(Exception):
    pass


def test_recording_replays_identically_and_a_killed_run_resumes(tmp_path, net):
    from d2sr.frames import open_frames

    rec = _recording(tmp_path)
    reader = open_frames(rec)
    s, plan = RunSettings(repair="all"), LoopSettings(controller="damped", active_frames=3)

    def run(frames, out: Path) -> dict:
        return run_recording(net, Recording(frames, 4000.0, "rec"), out, s, plan)

    a = run(reader, tmp_path / "a")
    run(reader, tmp_path / "b")
    assert a["all"]["frames"] == 12 and _digest(tmp_path / "a") == _digest(tmp_path / "b")

    class Dies:
        """The recording, killed at its eighth frame of the run (after the scene's look-ahead read it)."""

        passes = 0

        def __len__(self) -> int:
            return len(reader)

        def __iter__(self):
            self.passes += 1
            for i, f in enumerate(reader):
                if i == 7 and self.passes == 2:
                    raise Killed
                yield f

    with pytest.raises(Killed):
        run(Dies(), tmp_path / "c")
    assert not (tmp_path / "c").exists()  # nothing half-written where the output goes
    (partial,) = tmp_path.glob(".c.d2sr-*.partial")  # the working folder, with d2sr's marker
    assert len(list((partial / "sensor0" / "depth").glob("*.png"))) == 7
    with (partial / "log.csv").open("a") as fh:
        fh.write("0,f007,0.0,2")  # a torn last line, as a kill mid-write leaves it
    c = run(reader, tmp_path / "c")
    assert c["resumed_frames"] == 7 and c["all"]["frames"] == 5
    assert _digest(tmp_path / "c") == _digest(tmp_path / "a") and not partial.exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_run_cli_on_a_recording_and_bad_inputs(tmp_path):
    rec = _recording(tmp_path, 6)
    out = tmp_path / "out"
    res = d2sr("run", str(rec), "--out", str(out), "--depth-scale", "4000", "--backend", "onnx")
    assert res.returncode == 0, res.stderr
    assert len(list((out / "sensor0" / "depth").glob("*.png"))) == 6 and (out / "summary.json").is_file()
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [
        ([str(empty)], "empty"),
        ([str(tmp_path / "nope")], "no such recording"),
        ([str(rec), "--controller", "best"], "unknown 'best'"),
        ([str(rec), "--repair", "some"], "--repair"),
        ([str(rec), "--depth-scale", "1"], "scale"),
        (["sim", "--seconds", "0"], "--seconds"),
        (["sim", "--scene"], "--scene"),
        (["realsense"], "RealSense"),
    ]
    for args, words in cases:
        bad = tmp_path / "bad"
        res = d2sr("run", *args, "--out", str(bad))
        assert res.returncode == 2, (args, res.stderr)
        assert words in res.stderr and len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert not bad.exists() and not list(tmp_path.glob(".bad.*"))


def test_int8_models_quantize_and_run_in_the_loop(tmp_path):
    import torch

    from d2sr.models import build
    from d2sr.models.onnx.export import export
    from d2sr.models.onnx.quantize import int8_path, quantize
    from d2sr.models.store import save_model

    torch.manual_seed(0)
    for name in ("detector", "unet8", "unet8-temporal"):
        save_model(build(name).eval(), name, tmp_path / f"{name}.safetensors")
        export(tmp_path / f"{name}.safetensors", tmp_path / f"{name}.onnx")
        q = quantize(tmp_path / f"{name}.onnx", frames=2)
        assert (
            q == int8_path(tmp_path / f"{name}.onnx")
            and q.stat().st_size < (tmp_path / f"{name}.onnx").stat().st_size
        )
    net = open_backend(RunSettings(model="unet8", models=tmp_path, int8=True))
    assert net.name == "onnxruntime"
    d = np.full((96, 128), 8000, np.uint16)
    res = SensorLoop(
        net, make_controller("static", 30, 3), settings=RunSettings(repair="all", scene=False)
    ).process(Capture(Frame("f", d), 4000))
    assert res.depth.shape == (96, 128) and 0 <= res.score <= 1
    with pytest.raises(ConfigError, match="onnxruntime"):
        open_backend(RunSettings(model="unet8", backend="torch", models=tmp_path, int8=True))
    # A streaming temporal UNet: calibrated on the inputs the runtime feeds it, its encoder kept beside it.
    assert (tmp_path / "unet8-temporal.int8.code.onnx").is_file()
    temporal = open_backend(
        RunSettings(model="unet8-temporal", backend="onnx", models=tmp_path, int8=True), detector=False
    )
    x = np.full((1, 96, 128), 2.0, np.float32)
    assert temporal.raw(x, x)[1].shape == (1, 96, 128)


def test_detector_gets_the_previous_frame_whatever_its_flag():
    net = FakeNet()
    loop = SensorLoop(net, make_controller("static", 30, 3), settings=RunSettings(repair="none", scene=False))
    first = _cap("0", bad=True)
    first.frame.depth[3, 3] = 4000
    loop.process(first)
    loop.process(_cap("1", bad=False))
    loop.process(Capture(Frame("2", np.full((8, 8), 8000, np.uint16)), 4000.0))
    assert net.before[0] is None  # a stream's first frame has none: the detector's single-frame case
    assert net.before[1] is not None and net.before[1][0, 3, 3] == 1.0  # the flagged frame, as delivered
    assert net.before[2] is None  # a frame of another size is not a previous frame
    # Every score is asked for against the loop's threshold (contract.gate), its own or the caller's;
    # exact_scores (d2sr detect) asks for every score exact.
    assert net.cuts == [THRESHOLD] * 3
    SensorLoop(
        net, make_controller("static", 30, 3), settings=RunSettings(threshold=0.8, repair="none", scene=False)
    ).process(first)
    assert net.cuts[-1] == 0.8
    SensorLoop(
        net,
        make_controller("static", 30, 3),
        exact_scores=True,
        settings=RunSettings(repair="none", scene=False),
    ).process(first)
    assert net.cuts[-1] is None


def test_detect_writes_every_score_exact_with_the_shipped_temporal_detector(tmp_path):
    # The live loop may report a frame's score alone below the threshold; d2sr detect's CSV, which a user
    # thresholds later, holds the exact score: the lower of alone and with the frame before.
    from d2sr.jobs.recordings import detect_recording
    from d2sr.sim.dataset import synth_sequence_frame

    frames = []
    for i in range(6):
        s = synth_sequence_frame(1_000_400 + i, bool(i % 2), previous=True)
        frames.append(
            np.clip(np.rint(s.frame.astype(np.float64) * (4000 / s.scale)), 0, 65535).astype(np.uint16)
        )
    root = tmp_path / "rec"
    with PngWriter(root, 4000.0) as w:
        for i, f in enumerate(frames):
            w.write(Frame(f"f{i:03d}", f))
    detect_recording(root, tmp_path / "d.csv", RunSettings(depth_scale=4000.0))
    got = [float(r["score"]) for r in csv.DictReader((tmp_path / "d.csv").open())]
    net, prev, want, gated = open_backend(recovery=False), None, [], []
    for f in frames:
        m = (f.astype(np.float32) / np.float32(4000))[None]
        want.append(float(net.scores(m, prev)[0]))
        gated.append(float(net.scores(m, prev, THRESHOLD)[0]))
        prev = m
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert max(abs(g - w) for g, w in zip(gated, want, strict=True)) > 1e-3  # the loop's would differ


_FAULTS = """
import resource, sys
import cv2
import numpy as np
from d2sr.jobs.memory import reuse_freed_memory
print(reuse_freed_memory() if sys.argv[1] == "1" else False)
np.ones((480, 640), np.float32)  # the heap grows once
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    a = np.ones((480, 640), np.float32) * 2
    del a
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.slow  # a subprocess: not in make test-fast
def test_frame_buffers_freed_in_a_loop_are_reused_not_faulted_in_again():
    # recover, detect and run: a frame-size buffer freed at one frame serves the next, instead of being
    # unmapped and faulted in again page by page (about 5 ms of system time per worst-case frame).
    import platform
    import subprocess
    import sys

    if platform.libc_ver()[0] != "glibc":
        pytest.skip("mallopt is glibc's")
    runs = {}
    for on in ("0", "1"):
        out = subprocess.run([sys.executable, "-c", _FAULTS, on], capture_output=True, text=True, check=True)
        said, faults = out.stdout.split()
        runs[on] = (said, int(faults))
    assert runs["1"][0] == "True"
    assert runs["0"][1] > 20 * 100  # glibc's defaults: each 1.2 MB buffer is mapped afresh (~300 pages)
    assert runs["1"][1] < runs["0"][1] / 20


def test_auto_runs_the_temporal_model_at_its_own_operating_point():
    # auto: unet8-temporal at AUTO_TEMPORAL_LOGIT, unet8 at its own logit; a given --mask-logit sets both.
    from d2sr.contract.catalog import AUTO_TEMPORAL_LOGIT

    net = open_backend(RunSettings(backend="onnx"))
    assert isinstance(net, Gated)
    assert (
        net.temporal.mask_logit
        == AUTO_TEMPORAL_LOGIT
        != open_backend(RunSettings(model="unet8-temporal", backend="onnx")).mask_logit
    )
    assert net.single.mask_logit == open_backend(RunSettings(model="unet8", backend="onnx")).mask_logit
    given = open_backend(RunSettings(backend="onnx", mask_logit=0.25))
    assert given.temporal.mask_logit == given.single.mask_logit == 0.25


def test_frames_finished_on_threads_while_later_ones_are_judged_come_out_as_one_at_a_time(net):
    """The node and ``recover`` judge frames in order and repair them on workers while the next are judged;
    the scene's repair of a frame is worked out there too. With the scene learning from the clean frames
    in between, every frame comes out bit for bit as ``process`` gives it one at a time."""
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(3)
    z = 2.0 + np.linspace(0, 1, 128, dtype=np.float32)[None].repeat(96, 0)

    def frame(k: int) -> np.ndarray:
        f = z + rng.normal(0, 0.005, z.shape).astype(np.float32)
        if k >= 12 and k % 3:  # interfered: a patch read 4 cm near, elsewhere each time
            r, c = 10 + 5 * (k % 7), 10 + 8 * (k % 5)
            f[r : r + 30, c : c + 40] -= 0.04
        return np.rint(f * 4000).astype(np.uint16)

    frames = [frame(k) for k in range(60)]
    settings = RunSettings(repair="flagged", scene=True)
    one = SensorLoop(net, make_controller("static", 30, 30), settings=settings)
    alone = [one.process(Capture(Frame(str(k), f), 4000.0)) for k, f in enumerate(frames)]
    many = SensorLoop(net, make_controller("static", 30, 30), settings=settings)
    with ThreadPoolExecutor(2) as pool:
        decided = [many.decide(Capture(Frame(str(k), f), 4000.0)) for k, f in enumerate(frames)]
        together = list(pool.map(many.finish, decided))  # every frame judged before any is repaired
    assert sum(r.reason.endswith("scene") for r in alone) >= 5
    for a, b in zip(alone, together, strict=True):
        assert np.array_equal(a.depth, b.depth) and np.array_equal(a.mask, b.mask) and a.flagged == b.flagged
