"""d2sr fleet joining a Ray cluster started apart (``ray start --head``), as a user's cluster is."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from d2sr.errors import ConfigError
from d2sr.fleet.cluster import _probe
from d2sr.jobs.recordings import recover_recording
from helpers import d2sr_inprocess

pytest.importorskip("ray")

from test_fleet import SETTINGS, _files, _recording


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_cluster_started_apart_is_joined_at_its_address(tmp_path):
    port = _free_port()
    ray_cli = Path(sys.executable).parent / "ray"
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # Ray's sockets live there: a short path
    head = subprocess.Popen(
        [str(ray_cli), "start", "--head", "--block", f"--port={port}", "--num-cpus=1",
         "--include-dashboard=false", f"--temp-dir={temp}"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                _probe(f"127.0.0.1:{port}")
                break
            except ConfigError:
                assert time.monotonic() < deadline and head.poll() is None, "ray start --head did not come up"
                time.sleep(0.5)
        rec = _recording(tmp_path / "rec", 6, 4)
        code, _, err = d2sr_inprocess(
            "fleet", str(rec), "--out", str(tmp_path / "out"), "--address", f"127.0.0.1:{port}",
            "--depth-scale", "4000", "--repair", "all", "--no-scene",
        )  # fmt: skip
        assert code == 0, err
        recover_recording(rec, tmp_path / "alone", SETTINGS)
        assert _files(tmp_path / "out" / "rec") == _files(tmp_path / "alone")
    finally:
        head.send_signal(signal.SIGINT)  # ray start --block stops its cluster on Ctrl-C (SIGTERM: ~35 s)
        try:
            head.wait(60)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
        shutil.rmtree(temp, ignore_errors=True)
