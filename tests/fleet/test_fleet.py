"""d2sr fleet (d2sr.fleet): many recordings on a local Ray cluster of 2 CPUs started here, each written
exactly as d2sr recover writes it; a broken one among them, a rerun, a wrong address, a killed worker."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.errors import ConfigError, OutputError
from d2sr.fleet import LEDGER, Cluster, FleetProgress, recover_fleet
from d2sr.jobs.recordings import recover_recording
from d2sr.runtime.settings import RunSettings
from helpers import BAG_TOPIC, d2sr_inprocess, write_bag

ray = pytest.importorskip("ray")  # the fleet extra: installed by make test

SETTINGS = RunSettings(depth_scale=4000.0, repair="all", scene=False)


@pytest.fixture(scope="module")
def cluster():
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    yield
    ray.shutdown()


def _recording(folder: Path, frames: int, seed: int, size: tuple[int, int] = (96, 128)) -> Path:
    """A still room at 4000 units per metre, a patch read too near on every other frame."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    h, w = size
    room = 2.0 + 0.5 * np.linspace(0, 1, w)[None, :] + 0.2 * np.linspace(0, 1, h)[:, None]
    for i in range(frames):
        d = room + rng.normal(0, 0.003, room.shape)
        if i % 2:
            d[20:50, 30:70] *= np.where(rng.random((30, 40)) < 0.4, 0.6, 1.0)  # speckle read too near
        cv2.imwrite(str(folder / f"{i:04d}.png"), np.rint(d * 4000).astype(np.uint16))
    return folder


def _files(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` but the manifest (its command names the command that wrote it)."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != ".d2sr-manifest.json"
    }


def test_a_fleet_writes_what_recover_writes_names_a_broken_recording_and_a_rerun_redoes_nothing(
    cluster, tmp_path
):
    recs = [_recording(tmp_path / "robot1" / "cam0", 12, 1), _recording(tmp_path / "robot2" / "cam0", 9, 2)]
    broken = _recording(tmp_path / "broken", 4, 3)
    (broken / "0002.png").write_bytes((broken / "0002.png").read_bytes()[:200])  # a truncated PNG
    out = tmp_path / "out"
    seen: list[FleetProgress] = []
    s = recover_fleet([*recs, broken], out, SETTINGS, cluster=Cluster(workers=2), progress=seen.append)
    assert [o.name for o in s.outcomes] == ["robot1__cam0", "robot2__cam0", "broken"]
    assert [o.status for o in s.outcomes] == ["done", "done", "failed"]
    assert "truncated" in s.failed[0].reason and "\n" not in s.failed[0].reason
    assert s.frames == 21 and [o.frames for o in s.outcomes[:2]] == [12, 9]
    assert seen and seen[-1].remaining == 0 and seen[-1].failed == 1
    for rec, name in zip(recs, ("robot1__cam0", "robot2__cam0"), strict=True):
        for f in sorted(rec.glob("*.png")):  # what any repair must do, known without running d2sr's code
            before, after = (cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in (f, out / name / f.name))
            changed = before != after
            assert not changed[:20].any() and not changed[50:].any() and not changed[:, :30].any()
            assert not changed[:, 70:].any()  # nothing outside the speckled patch
            # clean frames untouched; in interfered ones most of the too-near returns moved
            assert changed.mean() == 0 if int(f.stem) % 2 == 0 else changed[20:50, 30:70].mean() > 0.25
        alone = tmp_path / f"alone_{name}"
        recover_recording(rec, alone, SETTINGS)
        assert _files(out / name) == _files(alone)  # byte for byte, report.html and meta.json included
        manifest = json.loads((out / name / ".d2sr-manifest.json").read_text())
        assert "default_worker" not in manifest["command"]  # the driver's command, not a Ray worker's argv
    ledger = json.loads((out / LEDGER).read_text())
    assert ledger["totals"]["done"] == 2 and ledger["commit"] and ledger["command"]
    assert not (out / "broken").exists()  # nothing half-written
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    again = recover_fleet([*recs, broken], out, SETTINGS, cluster=Cluster(workers=2))
    assert again.skipped == 3 and again.frames == 0 and len(again.failed) == 1
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.name != LEDGER} == {
        p: t for p, t in before.items() if p.name != LEDGER
    }
    # a recording done under other settings is not silently mixed with new ones
    with pytest.raises(ConfigError, match="other settings"):
        recover_fleet(recs, out, SETTINGS.model_copy(update={"repair": "flagged"}))
    # a removed output is redone; the broken recording, mended, is redone too
    import shutil

    shutil.rmtree(out / "robot2__cam0")
    (broken / "0002.png").unlink()
    third = recover_fleet([*recs, broken], out, SETTINGS, cluster=Cluster(workers=2))
    assert third.skipped == 1 and [o.status for o in third.outcomes] == ["done"] * 3
    assert _files(out / "robot2__cam0") == _files(tmp_path / "alone_robot2__cam0")


def test_bags_give_the_bags_recover_gives(cluster, tmp_path):
    bags = tmp_path / "bags"
    bags.mkdir()
    write_bag(bags / "run1.bag", "ros1")
    write_bag(bags / "run2", "mcap")
    settings = RunSettings(depth_scale=1000.0, repair="all", scene=False, topic=BAG_TOPIC)
    s = recover_fleet([bags / "run1.bag", bags / "run2"], tmp_path / "out", settings)
    assert [o.name for o in s.outcomes] == ["run1.bag", "run2"] and not s.failed
    alone = tmp_path / "alone"  # d2sr recover REC --out alone/<name>: a ROS 2 bag's files take its name
    recover_recording(bags / "run1.bag", alone / "run1.bag", settings)
    recover_recording(bags / "run2", alone / "run2", settings)
    for name in ("run1.bag", "run1.bag.report.html"):  # the report beside a bag out, as recover puts it
        assert (tmp_path / "out" / name).read_bytes() == (alone / name).read_bytes()
    assert _files(tmp_path / "out" / "run2") == _files(alone / "run2")


def test_a_killed_worker_is_retried_and_its_output_is_whole_and_the_same(cluster, tmp_path):
    rec = _recording(tmp_path / "long", 80, 7, size=(240, 320))
    killed: list[int] = []

    def kill_once(p: FleetProgress) -> None:
        if not killed and p.frames >= 2 and p.running:  # early: a loaded machine leaves no late chance
            pid = next(iter(p.running.values()))
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    s = recover_fleet([rec], tmp_path / "out", SETTINGS, cluster=Cluster(workers=1), progress=kill_once)
    assert killed and s.outcomes[0].status == "done" and s.outcomes[0].frames == 80
    recover_recording(rec, tmp_path / "alone", SETTINGS)
    assert _files(tmp_path / "out" / "long") == _files(tmp_path / "alone")
    leftovers = [p.name for p in (tmp_path / "out").iterdir() if p.name.startswith(".long.")]
    assert leftovers == []  # the killed attempt's temporary went when the retry began


def test_the_command_line_names_each_failure_and_refuses_a_wrong_address_in_one_line(cluster, tmp_path):
    rec = _recording(tmp_path / "rec", 4, 1)
    bad = tmp_path / "empty"
    bad.mkdir()
    code, out, err = d2sr_inprocess(
        "fleet", str(rec), str(bad), "--out", str(tmp_path / "out"), "--depth-scale", "4000", "--no-scene"
    )
    assert code == 1 and "1 of 2 recordings done" in out
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"d2sr: error: {bad}:")
    code, _, err = d2sr_inprocess(
        "fleet", str(rec), "--out", str(tmp_path / "o2"), "--address", "127.0.0.1:1"
    )
    assert code == 2 and len(err.strip().splitlines()) == 1 and "no Ray cluster answers" in err
    code, _, err = d2sr_inprocess("fleet", str(rec), "--out", str(tmp_path / "o3"), "--address", "nonsense")
    assert code == 2 and "HOST:PORT" in err
    assert not (tmp_path / "o2").exists() and not (tmp_path / "o3").exists()  # refused before any write


def test_an_output_folder_that_is_not_a_fleet_s_is_refused_and_nothing_is_written(tmp_path):
    rec = _recording(tmp_path / "rec", 2, 1)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="did not make"):
        recover_fleet([rec], mine, SETTINGS)
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
    with pytest.raises(OutputError, match="input"):
        recover_fleet([rec], rec / "out", SETTINGS)
    with pytest.raises(ConfigError, match="no recordings"):
        recover_fleet([], tmp_path / "o", SETTINGS)


def test_without_ray_the_command_says_how_to_install_it(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)
    rec = _recording(tmp_path / "rec", 2, 1)
    code, _, err = d2sr_inprocess("fleet", str(rec), "--out", str(tmp_path / "out"), "--depth-scale", "4000")
    assert code == 2 and "pip install '.[fleet]'" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_an_address_that_speaks_http2_but_is_not_ray_is_refused_in_one_line(tmp_path):
    """Something that accepts TCP and answers HTTP/2's preface as Ray's head does, but is not Ray (another
    gRPC server): Ray retried it for minutes or ended the process (exit 15) with no d2sr line."""
    import socket
    import threading

    srv = socket.create_server(("127.0.0.1", 0))
    port = srv.getsockname()[1]
    stop = threading.Event()

    def serve() -> None:
        srv.settimeout(0.2)
        held = []
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except OSError:
                continue
            with contextlib.suppress(OSError):
                conn.recv(1024)
                conn.sendall(b"\x00\x00\x00\x04\x00\x00\x00\x00\x00")  # an empty SETTINGS frame
            held.append(conn)
        for c in held:
            c.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    rec = _recording(tmp_path / "rec", 2, 1)
    try:
        code, _, err = d2sr_inprocess(
            "fleet", str(rec), "--out", str(tmp_path / "o"), "--address", f"127.0.0.1:{port}"
        )
    finally:
        stop.set()
        thread.join(5)
        srv.close()
    assert code == 2 and "not a Ray cluster" in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_sigterm_ends_a_fleet_as_ctrl_c_does(tmp_path):
    """Ray took SIGTERM for its own: d2sr fleet then ended with exit 1 and no line."""
    import subprocess
    import sys

    recs = [str(_recording(tmp_path / f"rec{i}", 40, i)) for i in range(4)]
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "d2sr", "fleet", *recs, "--out", str(out), "--depth-scale", "4000"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while not out.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)  # the fleet's folder appears once Ray runs and the first task started
    assert proc.poll() is None, "the fleet ended before it could be stopped"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "d2sr: interrupted; nothing half-written was left at the output"
