import json
import os
import re

import pytest

from d2sr import __version__
from d2sr.desync import DEFAULT_CONTROLLER
from helpers import ROOT, d2sr, d2sr_inprocess, markdown_table


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_version_and_help():
    res = d2sr("--version")
    assert res.returncode == 0 and res.stdout.strip() == f"d2sr {__version__}"
    res = d2sr("--help")
    assert res.returncode == 0
    for cmd in ("demo", "desync", "bench"):
        assert cmd in res.stdout


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["desync", "sweep", "--controllers", "nope", "--replicas", "2"], "unknown nope"),
        (["desync", "sweep", "--active-frames", "0"], "fps in 1..30"),
        (["desync", "sweep", "--active-frames", "six"], "comma-separated integers"),
        (["desync", "run", "--active-frames", "31"], "--active-frames (31)"),
        (["desync", "run", "--sensors", "0"], "--sensors >= 1"),
        (["desync", "run", "--recall", "1.5"], "recall"),
        (["desync", "run", "--false-alarm", "-0.1"], "--false-alarm: "),
        (["desync", "run", "--scenario", "orbit"], "--scenario"),
        (["desync", "run", "--controllers", "d2sr,nope"], "unknown nope"),
        (["desync", "run", "--seconds", "0"], "duration"),
        (["desync", "run", "--config", "/nonexistent.toml"], "no such file"),
        (["bench", "--sensors", "0"], "sensors >= 1"),
        (["bench", "--what", "typical"], "pass --frames"),
        (["bench", "--what", "worst", "--frames", "/nonexistent"], "/nonexistent"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, message, tmp_path):
    res = d2sr(*args, "--out", str(tmp_path / "o")) if args[0] != "bench" else d2sr(*args)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("d2sr: error:") and message in lines[0]
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_bad_toml_and_unknown_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("recall = [")
    res = d2sr("desync", "run", "--config", str(bad), "--out", str(tmp_path / "o"))
    assert (
        res.returncode == 2 and "not valid TOML" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    )
    bad.write_text("recal = 0.5\n")
    res = d2sr("desync", "run", "--config", str(bad), "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and "recal" in res.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_desync_run_with_config_moving(tmp_path):
    cfg = tmp_path / "room.toml"
    cfg.write_text("recall = 0.8\nfalse_alarm = 0.02\nsetup = 1\n")
    res = d2sr(
        "desync", "run", "--scenario", "moving", "--sensors", "3", "--active-frames", "10", "--seconds", "8",
        "--rooms", "2", "--controllers", "d2sr,damped", "--config", str(cfg), "--out", str(tmp_path / "o"),
        "--json", str(tmp_path / "r.json"),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "robot's frames only" in res.stdout
    rows = json.loads((tmp_path / "r.json").read_text())["results"]
    assert [r["controller"] for r in rows] == ["d2sr", "damped"] and all(
        r["scenario"] == "moving" for r in rows
    )
    assert (tmp_path / "o" / "timeline_damped.png").exists() and not (
        tmp_path / "o" / "timeline_static.png"
    ).exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_demo_runs_the_closed_loop_writes_a_report_and_the_readme_quotes_its_table(tmp_path):
    # the demo exactly as `make demo` runs it (20 simulated seconds, three controllers), in this process
    out = tmp_path / "demo"
    code, printed, err = d2sr_inprocess("demo", "--out", str(out))
    assert code == 0, err
    for name in ("static", "d2sr", DEFAULT_CONTROLLER):
        assert name in printed
        assert (out / f"timeline_{name}.png").stat().st_size > 1000
        assert (out / "runs" / name / "log.csv").is_file()
    report = json.loads((out / "results.json").read_text())
    rows = report["controllers"]
    assert rows["static"]["frames"] == rows[DEFAULT_CONTROLLER]["frames"] == 3 * 20 * 6
    assert rows[DEFAULT_CONTROLLER]["interfered_ratio"] < rows["static"]["interfered_ratio"]
    md = (out / "report.md").read_text()
    assert (
        "| static |" in md
        and f"![timeline_{DEFAULT_CONTROLLER}.png](timeline_{DEFAULT_CONTROLLER}.png)" in md
    )
    assert (out / "examples.png").is_file() and (out / "ratio_over_time.png").is_file()
    assert not list(tmp_path.glob(".*"))  # no temporary or partial leftovers
    # the README quotes the table: every column but the machine's frame rate
    written = markdown_table(md, "controller")
    quoted = markdown_table((ROOT / "README.md").read_text(), "controller")
    fps = written[0].index("fps")
    assert [r[:fps] + r[fps + 1 :] for r in quoted] == [r[:fps] + r[fps + 1 :] for r in written]


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_sweep_writes_results_and_checks_bars(tmp_path):
    res = d2sr(
        "desync", "sweep", "--out", str(tmp_path), "--replicas", "2", "--seconds", "12",
        "--active-frames", "6,15", "--sensors", "1,2", "--jobs", "1",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    sweep = json.loads((tmp_path / "sweep.json").read_text())
    assert sweep["command"].startswith("d2sr desync sweep --out") and sweep["commit"]
    rows = sweep["results"]
    # 2 scenarios x 2 fps x 2 N x 4 controllers, plus the harsh profile for d2sr and the default
    assert len(rows) == 2 * 2 * 2 * 4 + 2 * 2 * 2 * 2
    assert {r["controller"] for r in rows} == {"static", "d2sr", DEFAULT_CONTROLLER, "oracle"}
    assert all(0.0 <= r["whole"] <= 1.0 for r in rows)
    one = [r for r in rows if r["sensors"] == 1]
    assert all(r["whole"] == 0.0 for r in one)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["bars"] and DEFAULT_CONTROLLER in summary["headline_reduction_N2_15fps"]
    assert (tmp_path / "sweep.csv").read_text().startswith("scenario,fps,sensors,controller")
    for png in ("fig9_default.png", "fig9_harsh.png", "paired_default.png", "convergence.png"):
        assert (tmp_path / png).stat().st_size > 1000
    report = (tmp_path / "README.md").read_text()
    assert "## stationary" in report and "## Bars" in report and "desync sweep" in report
    # the report is rebuilt from sweep.json alone, identically
    (tmp_path / "README.md").unlink()
    res = d2sr("desync", "report", str(tmp_path))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "README.md").read_text() == report
    (tmp_path / "sweep.json").write_text('[{"scenario": 1}]')
    res = d2sr("desync", "report", str(tmp_path))
    assert res.returncode == 2 and "not a sweep.json" in res.stderr
    res = d2sr("desync", "report", str(tmp_path / "nowhere"))
    assert res.returncode == 2 and "no such file" in res.stderr


def test_bench_worst_runs_again_until_the_long_run_takes_longer(monkeypatch):
    """The worst case's time a frame is the difference between a long and a short recover run; where a busy
    machine makes the short run the slower, it runs both again (up to as many runs more) rather than report a
    negative time, and says so in one line if the difference never comes out positive."""
    import subprocess
    import time

    import numpy as np

    from d2sr.errors import D2SRError
    from d2sr.eval import speed as bench

    clock = [0.0]
    plans: dict[str, list[float]] = {}

    def fake_run(args, **kw):  # each recover "takes" the next planned seconds of its kind; the floor 0.1 s
        if args[1] == "-c":
            return subprocess.CompletedProcess(args, 0, "0.1\n", "")
        clock[0] += plans[args[-1].rsplit("in", 1)[1]].pop(0)
        return subprocess.CompletedProcess(args, 0, "", "")

    monkeypatch.setattr(subprocess, "run", fake_run)
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    frames = [np.full((24, 32), 4000, np.uint16)] * 20
    # run 1: 10 frames 2.0 s, 20 frames 1.5 s (the short one slower); run 2: 1.0 and 2.0 s
    plans.update({"10": [2.0, 1.0], "20": [1.5, 2.0]})
    out = bench.bench_worst(frames, 4000.0, runs=1)
    assert out["runs"] == 2 and out["seconds"]["recover 20"] == [1.5, 2.0]
    assert out["recover_ms_per_frame"] == pytest.approx(1000 * (1.75 - 1.5) / 10)
    assert out["ratio_to_floor"] == pytest.approx(25.0 / 5.0)
    plans.update({"10": [2.0, 2.0], "20": [1.5, 1.5]})  # never longer: refused in one line
    with pytest.raises(D2SRError, match="2 runs of 20 frames took no longer than of 10"):
        bench.bench_worst(frames, 4000.0, runs=1)


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_bench_typical_and_worst_on_a_recording(tmp_path):
    from d2sr.eval.speed import frame_4000
    from d2sr.frames.png import encode_png, write_meta

    rec = tmp_path / "rec"
    rec.mkdir()
    for i in range(40):  # clean frames but a few, so both the detector alone and repairs are timed
        img = frame_4000(7 + i % 12, interfered=i % 12 in (3, 8))[::2, ::2].copy()
        (rec / f"{i:04d}.png").write_bytes(encode_png(img, "test"))
    write_meta(rec, 4000.0, None, [])
    out = tmp_path / "b.json"
    res = d2sr("bench", "--what", "typical,worst", "--frames", str(rec), "--repeats", "1", "--json", str(out))
    assert res.returncode == 0, res.stderr
    data = json.loads(out.read_text())["benchmarks"]
    typical, worst = data["typical"], data["worst"]
    assert typical["frames"] == 40 and typical["size"] == "320x240"
    shipped, alone = typical["as shipped"], typical["no repair"]
    assert shipped["cpu_ms_per_frame"] > 0 and alone["cpu_ms_per_frame"] > 0
    assert alone["flagged"] == shipped["flagged"]  # the same detector decides; only the repair differs
    # one run asked for; the benchmark adds runs (up to as many again) while a busy machine's noise leaves the
    # long run no slower than the short one, and records how many it made
    assert worst["frames"] == 40 and len(worst["seconds"]["recover 40"]) == worst["runs"] in (1, 2)
    ratio = worst["recover_ms_per_frame"] / worst["floor_ms_per_frame"]
    # the reported ratio is the two timings' (which is faster is the benchmark's to say, not a test's: with
    # one repeat on a loaded machine the floor's run was once the slower, 0.80)
    assert ratio > 0 and worst["ratio_to_floor"] == pytest.approx(ratio, rel=0.02)
    # --no-scene: the same frames through Pipeline(scene=False); only the typical case takes it
    res = d2sr("bench", "--what", "typical", "--frames", str(rec), "--repeats", "1", "--no-scene", "--json",
               str(tmp_path / "s.json"))  # fmt: skip
    assert res.returncode == 0, res.stderr
    alone = json.loads((tmp_path / "s.json").read_text())
    assert alone["options"] == {"scene": False} and alone["as shipped"]["cpu_ms_per_frame"] > 0
    assert "options" not in typical
    res = d2sr("bench", "--what", "worst", "--frames", str(rec), "--no-scene")
    assert res.returncode == 2 and res.stderr.strip() == "d2sr: error: --no-scene is for --what typical"


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_bench_json(tmp_path):
    out = tmp_path / "b.json"
    res = d2sr(
        "bench", "--what", "timing", "--sensors", "60", "--seconds", "5", "--repeats", "1", "--json", str(out)
    )
    assert res.returncode == 0, res.stderr
    data = json.loads(out.read_text())
    assert data["sensors"] == 60 and data["run_s_median"] > 0 and 0 <= data["interference_ratio"] <= 1
    assert data["cpu"].startswith(f"{len(os.sched_getaffinity(0))} cores, ")  # which machine measured it


def test_bench_typical_times_only_the_frames_after_settle():
    """``settle``: a sensor that has run a while; its first frames are run untimed and the rest timed."""
    from d2sr.eval.speed import bench_typical, frame_4000

    frames = [frame_4000(7 + i, interfered=i == 2)[::4, ::4].copy() for i in range(8)]
    out = bench_typical(frames, 4000.0, repeats=1, warmup=0, settle=5, scene=False)
    assert out["settle_frames"] == 5 and out["as shipped"]["flagged"].endswith("of 3")
    assert out["as shipped"]["cpu_ms_per_frame"] > 0
    with pytest.raises(ValueError, match="frames to time"):
        bench_typical(frames, 4000.0, repeats=1, settle=8)


def test_run_sim_counts_interfered_frames_as_the_demo_does_and_draws_one_bar(tmp_path):
    """d2sr run sim printed interference as a share (0.0667) where the demo prints 109/360, and each progress
    call added a bar that stayed at 0% (setdefault made a new one every time)."""
    code, printed, err = d2sr_inprocess("run", "sim", "--seconds", "2", "--out", str(tmp_path / "r"))
    assert code == 0, err
    assert re.search(r"│ all\s+│\s+\d+ │\s+\d+/\d+ │", printed), printed
    assert " 0%" not in printed + err and printed.count("3 sensors") == 1, printed + err


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_help_at_80_columns_cuts_nothing_and_keeps_research_commands_apart():
    """At 80 columns detect --help cut its --out text and --models' default path (a "…" in the help column;
    rich still shortens a long option name in its own column); the top-level help mixed research commands
    with the ones users run, each listed with its docstring's whole first paragraph."""
    import subprocess
    import sys

    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}

    def shown(*args: str) -> str:
        run = subprocess.run([sys.executable, "-m", "d2sr", *args, "--help"], env=env, capture_output=True,
                             text=True, timeout=120, check=True)  # fmt: skip
        return run.stdout

    for command in ("detect", "recover"):
        help_column = [line[40:] for line in shown(command).splitlines()]
        assert not any("…" in cell for cell in help_column), help_column
    top = shown()
    users, research = top.split("Research: data, training, evaluations, benchmarks")
    for name in ("detect", "recover", "fleet", "run", "ros2", "demo"):
        assert f"│ {name} " in users
    for name in ("train", "calibrate", "label", "bench", "eval", "export"):
        assert f"│ {name} " in research and f"│ {name} " not in users
