"""Rerun logging: d2sr run --rerun writes a recording Rerun's own verifier accepts, with every sensor's
input and repaired depth, the predicted mask and the figures over time; d2sr view replays a run folder;
a run that fails leaves no recording behind."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from helpers import d2sr

RERUN = Path(sys.executable).parent / "rerun"


def _entities(rrd: Path) -> set[str]:
    verify = subprocess.run(
        [str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, check=False
    )
    assert verify.returncode == 0, verify.stderr[-2000:]
    stats = subprocess.run(
        [str(RERUN), "rrd", "stats", str(rrd)], capture_output=True, text=True, check=False
    )
    assert stats.returncode == 0, stats.stderr[-2000:]
    return set(re.findall(r"^(/\S+): \d+", stats.stdout, flags=re.M))


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_run_logs_depth_masks_and_series_to_a_verified_recording(tmp_path):
    rrd = tmp_path / "run.rrd"
    res = d2sr(
        "run", "sim", "--sensors", "2", "--seconds", "3", "--out", str(tmp_path / "run"), "--rerun", str(rrd)
    )
    assert res.returncode == 0, res.stderr
    got = _entities(rrd)
    depth = {f"/sensor{i}/{k}" for i in (0, 1) for k in ("input", "repaired")}
    assert depth <= got, got  # >= 4 depth entities: input and repaired per sensor
    assert {"/sensor0/repaired/mask", "/sensor0/input/true_mask"} <= got
    assert {"/series/sensor0/score", "/series/sensor1/window_offset", "/series/sensor0/flagged"} <= got
    view = tmp_path / "view.rrd"
    res = d2sr("view", str(tmp_path / "run"), "--save", str(view))
    assert res.returncode == 0, res.stderr
    assert {"/sensor0/repaired", "/sensor1/repaired/mask", "/series/sensor1/score"} <= _entities(view)


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_a_failed_run_leaves_no_recording_and_view_needs_a_run_folder(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    (src / "f000.png").write_bytes(b"not a png")
    rrd = tmp_path / "bad.rrd"
    res = d2sr("run", str(src), "--out", str(tmp_path / "o"), "--rerun", str(rrd))
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert not rrd.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".bad")]
    res = d2sr("view", str(src), "--save", str(tmp_path / "v.rrd"))
    assert res.returncode == 2 and "not a finished d2sr run folder" in res.stderr
