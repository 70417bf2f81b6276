"""A ROS 2 publisher and subscriber for ``d2sr ros2``, in Python with Cyclone DDS and no ROS install.

Start the node in one terminal, this script in another (same ROS_DOMAIN_ID):

    d2sr ros2 --topic /camera/depth/image_raw --depth-scale 1000
    python docs/examples/ros2_depth.py --topic /camera/depth/image_raw --frames 30

It publishes depth frames (sensor_msgs/Image, 16UC1 millimetres) at 10 Hz, every other one with a band of
interference, and prints each repaired frame that comes back on TOPIC/repaired and its mask on TOPIC/mask.
A real camera driver (realsense-ros, orbbec_camera) publishes the same messages; ``ros2 topic echo`` sees
these. The message types are d2sr's (``d2sr.ros2.msgs``: ROS 2's layouts as Cyclone DDS IDL).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from d2sr.ros2 import dds_topic
from d2sr.ros2.msgs import Header, Image, Time


def depth_frame(k: int) -> np.ndarray:
    """A wall at 2-3 m in millimetres; every other frame, rows 200-240 read 40 cm too near (interference)."""
    z = np.tile(np.linspace(2000, 3000, 640, dtype=np.float32), (480, 1))
    if k % 2:
        z[200:240] -= 400
    return z.astype(np.uint16)


def message(depth: np.ndarray, k: int) -> Image:
    stamp = Time(1_000 + k, 0)
    data = list(np.ascontiguousarray(depth).view(np.uint8).reshape(-1))
    return Image(Header(stamp, "camera_depth_optical_frame"), 480, 640, "16UC1", 0, 1280, data)


def pixels(msg: Image) -> np.ndarray:
    dtype = {"16UC1": np.uint16, "32FC1": np.float32, "mono8": np.uint8}[msg.encoding]
    return np.asarray(msg.data, np.uint8).view(dtype).reshape(msg.height, msg.width)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--topic", default="/camera/depth/image_raw")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--domain", type=int, default=None, help="the ROS_DOMAIN_ID [the environment's, else 0]")
    ap.add_argument("--wait", type=float, default=20.0, help="seconds to wait for the repaired frames")
    args = ap.parse_args()
    domain = args.domain if args.domain is not None else int(os.environ.get("ROS_DOMAIN_ID", "0"))
    participant = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(args.frames))
    writer = DataWriter(participant, Topic(participant, dds_topic(args.topic), Image), qos=qos)
    readers = {
        part: DataReader(participant, Topic(participant, dds_topic(f"{args.topic}/{part}"), Image), qos=qos)
        for part in ("repaired", "mask")
    }
    end = time.monotonic() + args.wait
    while not (
        writer.get_matched_subscriptions() and all(r.get_matched_publications() for r in readers.values())
    ):
        if time.monotonic() > end:  # discovery: the node subscribes to our topic, we to its outputs
            print(f"no d2sr ros2 node on {args.topic} (ROS_DOMAIN_ID {domain})")
            return 1
        time.sleep(0.05)
    for k in range(args.frames):
        writer.write(message(depth_frame(k), k))
        time.sleep(0.1)
    got: dict[str, dict[int, np.ndarray]] = {"repaired": {}, "mask": {}}
    end = time.monotonic() + args.wait
    while time.monotonic() < end and len(got["repaired"]) < args.frames:
        for part, reader in readers.items():
            for msg in reader.take(N=64):
                got[part][msg.header.stamp.sec - 1_000] = pixels(msg)
        time.sleep(0.05)
    for k in sorted(got["repaired"]):
        mask = got["mask"].get(k)
        repaired = int(np.count_nonzero(mask)) if mask is not None else 0
        band = got["repaired"][k][200:240]
        print(f"frame {k}: {repaired} pixels repaired, band median {np.median(band) / 1000:.2f} m")
    print(f"{len(got['repaired'])} of {args.frames} frames came back on {args.topic}/repaired")
    return 0 if len(got["repaired"]) == args.frames else 1


if __name__ == "__main__":
    raise SystemExit(main())
