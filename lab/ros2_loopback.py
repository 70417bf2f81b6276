"""Benchmark: ``d2sr ros2`` in a process of its own against a separate Cyclone DDS participant with its own
IDL (tools/ros2_peer.py), on one ROS_DOMAIN_ID picked at random.

* ``bar``: the peer publishes ``--frames`` (40) real L515 dev1 frames at 10 Hz on
  /camera/depth/image_rect_raw, every other one corrupted by the outside interference (``bench.outside``), the
  project's generator never made; counts what comes back on /repaired and /mask with the stamps kept, the
  RMSE of the corrupted frames before and after (against the frame before corruption, over its returns),
  and the node's exit code on SIGINT.
* ``rate``: ``--seconds`` (10) of 640x480 L515 frames at 30 Hz, every other one corrupted (``--every``:
  every one, each its own draw, issue 66's worst case): frames back, the
  time each spent in the node (from taken off its reader to its last message written) and the time from
  the peer's write to the repaired frame reaching the peer, median and p99.
* ``--cameras N``: instead of the rate, N cameras in one node (``--topic`` N times) at 15 Hz each, the same
  frames every other one corrupted, ``--seconds`` long: per camera, frames back, dropped by the node, the
  time in it.

Run:  python -m lab.ros2_loopback --data ../shared/data --json docs/results/ros2_loopback.json
"""

from __future__ import annotations

import argparse
import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.sets_a_i import outside_interference
from tools import ros2_peer

from d2sr.atomic import write_result
from d2sr.jobs.stats import median_p99_ms

TOPIC = "/camera/depth/image_rect_raw"
EXTRA: list[str] = []  # the node's own options (--passes, --model, --models)


def frames(data: Path, n: int) -> list[tuple[np.ndarray, np.ndarray, bool]]:
    """(sent, clean, corrupted) for the first ``n`` dev1 frames, every other one corrupted."""
    import cv2

    files = sorted((data / "l515" / "dev1").glob("*.png"))[:n]
    if len(files) < n:
        raise SystemExit(f"{data}/l515/dev1: needs {n} frames, found {len(files)}")
    out = []
    for i, f in enumerate(files):
        clean = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
        bad = i % 2 == 1
        out.append((outside_interference(clean, 4000.0, 7 + i) if bad else clean, clean, bad))
    return out


def exchange(domain: int, sent: list[np.ndarray], hz: float) -> tuple[dict, dict[int, float], str, int]:
    """Start the node, publish ``sent`` at ``hz``, SIGINT it: (replies by kind, write time by stamp,
    the node's stdout, its exit code)."""
    got, lags, out, code = exchange_many(domain, sent, hz, [TOPIC])
    return got[0], lags[0], out, code


def exchange_many(
    domain: int, sent: list[np.ndarray], hz: float, topics: list[str]
) -> tuple[list[dict], list[dict[int, float]], str, int]:
    """One node for ``topics``; a peer per topic publishes ``sent`` at ``hz``: (replies by kind and write to
    arrival by stamp, per topic; the node's stdout, its exit code)."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    cmd = [sys.executable, "-m", "d2sr", "ros2", *(a for t in topics for a in ("--topic", t))]
    cmd += ["--depth-scale", "4000", *EXTRA]
    node = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peers = [ros2_peer.Peer(domain, t) for t in topics]
    msgs = [ros2_peer.image(f, 1000 + k) for k, f in enumerate(sent)]  # serialized ahead of time
    written: dict[int, float] = {}
    try:
        end = time.monotonic() + 60
        while not all(p.matched() for p in peers):
            if time.monotonic() > end:
                raise SystemExit("the node never matched the peers")
            time.sleep(0.05)
        time.sleep(0.5)
        for p in peers:
            p.listen()
        t0 = time.monotonic()
        for k, m in enumerate(msgs):
            time.sleep(max(0.0, t0 + k / hz - time.monotonic()))
            written[1000 + k] = time.monotonic()
            for p in peers:
                p.writer.write(m)
        end = time.monotonic() + 10
        while time.monotonic() < end and min(len(p.got["repaired"]) for p in peers) < len(msgs):
            time.sleep(0.05)
        for p in peers:
            p.stop()
    finally:
        node.send_signal(signal.SIGINT)
        out, err = node.communicate(timeout=60)
    if node.returncode:
        print(err, file=sys.stderr)
    lags = [{s: p.arrived[s] - written[s] for s in p.arrived if s in written} for p in peers]
    return [p.got for p in peers], lags, out, node.returncode


def ms(values: list[float]) -> dict[str, float]:
    median, p99 = median_p99_ms(values)
    return {"median_ms": round(median, 2), "p99_ms": round(p99, 2)}


def node_counts(stdout: str, topic: str = "") -> dict[str, int]:
    """What the node's exit line (for ``topic``, with several cameras) says it took, published and dropped
    while behind."""
    text = " ".join(stdout.split())
    head = re.escape(f"{topic}: ") if topic else ""
    m = re.search(head + r"(\d+) frames in, (\d+) out \((\d+) flagged, (\d+) skipped, (\d+) dropped", text)
    keys = ("taken", "published", "flagged", "skipped", "dropped_while_behind")
    return dict(zip(keys, map(int, m.groups()), strict=True)) if m else {}


def node_latency(stdout: str, topic: str = "") -> dict[str, float]:
    head = re.escape(f"{topic}: ") + r"[^;]*; " if topic else ""
    m = re.search(head + r"in the node ([\d.]+) ms median, ([\d.]+) ms\s+p99", " ".join(stdout.split()))
    return {"median_ms": float(m.group(1)), "p99_ms": float(m.group(2))} if m else {}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--seconds", type=float, default=10.0, help="length of the 30 Hz run")
    ap.add_argument("--every", action="store_true", help="the 30 Hz run: every frame interfered (worst case)")
    ap.add_argument("--cameras", type=int, default=0, help="N cameras at 15 Hz each instead of the rate run")
    ap.add_argument("--passes", type=int, default=None, help="the node's --passes (default: its own)")
    ap.add_argument("--model", default=None, help="the node's --model (default: its own)")
    ap.add_argument("--models", type=Path, default=None, help="the node's --models (default: the shipped)")
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    if args.passes is not None:
        EXTRA.extend(["--passes", str(args.passes)])
    if args.model is not None:
        EXTRA.extend(["--model", args.model])
    if args.models is not None:
        EXTRA.extend(["--models", str(args.models)])
    result: dict = {
        "data": "L515 dev1 (real captures), every other frame with outside interference (bench/outside)",
    }
    rng = random.Random()
    # The bar: 40 real frames at 10 Hz.
    items = frames(args.data, args.frames)
    domain = rng.randint(100, 232)
    got, lag, out, code = exchange(domain, [s for s, _, _ in items], 10.0)
    stamps = {m.header.stamp.sec for m in got["repaired"]}
    mask_stamps = {m.header.stamp.sec for m in got["mask"]}
    repaired = {m.header.stamp.sec: ros2_peer.pixels(m) for m in got["repaired"]}
    se_in = se_out = n = 0.0
    for k, (sent, clean, bad) in enumerate(items):
        if not bad or 1000 + k not in repaired:
            continue
        ok = clean > 0
        se_in += float((((sent.astype(np.float64) - clean) / 4000)[ok] ** 2).sum())
        se_out += float((((repaired[1000 + k].astype(np.float64) - clean) / 4000)[ok] ** 2).sum())
        n += float(ok.sum())
    rmse_in, rmse_out = 100 * np.sqrt(se_in / n), 100 * np.sqrt(se_out / n)
    result["bar"] = {
        "domain": domain,
        "published": len(items),
        "repaired_received": len(got["repaired"]),
        "mask_received": len(got["mask"]),
        "status_received": len(got["status"]),
        "stamps_kept": stamps <= set(range(1000, 1000 + len(items))) and stamps == mask_stamps,
        "rmse_corrupted_in_cm": round(rmse_in, 2),
        "rmse_corrupted_out_cm": round(rmse_out, 2),
        "rmse_change_pct": round(100 * (rmse_out / rmse_in - 1), 1),
        "exit_code_on_sigint": code,
        "node_latency": node_latency(out),
        "write_to_repaired": ms(list(lag.values())) if lag else {},
    }
    if args.cameras:  # several cameras in one node, 15 Hz each, every other frame corrupted
        sent = [s for s, _, _ in items]
        sent = [sent[k % len(sent)] for k in range(round(15 * args.seconds))]
        topics = [f"/cam{i}/depth/image_rect_raw" for i in range(args.cameras)]
        domain = rng.randint(100, 232)
        gots, lags, out, code = exchange_many(domain, sent, 15.0, topics)
        result["cameras_15hz"] = {
            "domain": domain,
            "published_per_camera": len(sent),
            "exit_code_on_sigint": code,
            "cameras": {
                t: {
                    "repaired_received": len(g["repaired"]),
                    "node_counts": node_counts(out, t),
                    "node_latency": node_latency(out, t),
                    "write_to_repaired": ms(list(lag.values())) if lag else {},
                }
                for t, g, lag in zip(topics, gots, lags, strict=True)
            },
        }
        print(write_result(result, args.json))
        return
    # The rate: 640x480 at 30 Hz.
    if args.every:  # issue 66's worst case: every frame with interference, each its own draw
        clean = [c for _, c, _ in items]
        n = round(30 * args.seconds)
        sent = [outside_interference(clean[k % len(clean)], 4000.0, 7 + k) for k in range(n)]
    else:
        pool = [s for s, _, _ in items[:10]]
        sent = [pool[k % len(pool)] for k in range(round(30 * args.seconds))]
    domain = rng.randint(100, 232)
    got, lag, out, code = exchange(domain, sent, 30.0)
    result["rate_30hz"] = {
        "every_frame_interfered": args.every,
        "domain": domain,
        "published": len(sent),
        "repaired_received": len(got["repaired"]),
        "mask_received": len(got["mask"]),
        "exit_code_on_sigint": code,
        "node_latency": node_latency(out),
        "node_counts": node_counts(out),
        "write_to_repaired": ms(list(lag.values())) if lag else {},
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
