"""The ROS 2 node's memory over many messages (issue 63): 100,000 messages, malformed of every kind with a
real 640x480 frame every 100th, through ``Ros2Node.handle``; resident memory sampled after every 10,000.

    python -m lab.node_memory [--messages 100000]
"""

from __future__ import annotations

import argparse
import resource
import time
from types import SimpleNamespace as NS

import numpy as np


def room(seed: int) -> np.ndarray:
    """A wall at 3.2 m and a floor, in millimetres, with a third of the returns missing."""
    rng = np.random.default_rng(seed)
    rows = np.arange(480, dtype=np.float32)[:, None]
    metres = np.broadcast_to(np.where(rows > 288, 1.2 + 2.0 * (480 - rows) / 480, 3.2), (480, 640)).copy()
    metres[rng.random((480, 640)) < 0.3] = 0
    return (metres * 1000).astype(np.uint16)


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2**20


def _msg(i: int) -> NS:
    head = NS(stamp=NS(sec=i, nanosec=0), frame_id="cam")
    if i % 100 == 0:
        d = room(i)
        return NS(
            height=480, width=640, encoding="16UC1", step=1280, data=d.tobytes(), is_bigendian=0, header=head
        )
    bad = [(480, 0, "16UC1", 0, b""), (2, 2, f"enc{i}", 4, b"\0" * 8), (480, 640, "16UC1", 1280, b"\0" * 64),
           (7240, 7240, "16UC1", 14480, b""), (1, 1, "16UC1", 2, b"\0\0")][i % 5]  # fmt: skip
    return NS(
        height=bad[0], width=bad[1], encoding=bad[2], step=bad[3], data=bad[4], is_bigendian=0, header=head
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=int, default=100_000)
    args = ap.parse_args()
    from d2sr.ros2 import Ros2Node, Wire

    ros = Ros2Node("/memory/depth", 1000.0, Wire(domain=179))
    lines: list[str] = []
    ros.say = lines.append
    node = ros.cameras[0]
    samples = []
    for i in range(args.messages):
        node.handle(_msg(i), time.monotonic())
        node.publish_done()
        if (i + 1) % 10_000 == 0:
            while node.running:
                node.publish_done(wait=True)
            samples.append(round(_rss_mb(), 1))
    ros.close()
    s = node.stats
    print(f"{s.received} in, {s.published} out, {s.refused} refused; {len(lines)} warning lines")
    print(f"resident MB after each 10,000: {samples}")
    grew = samples[-1] - samples[0]
    print(f"growth after the first 10,000: {grew:+.1f} MB ({grew / samples[0]:+.1%})")


if __name__ == "__main__":
    main()
