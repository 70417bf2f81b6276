"""A ROS 2 publisher and subscriber for ``d2sr ros2``, in Python with Cyclone DDS and no ROS install.

Start the node in one terminal, this script in another (same ROS_DOMAIN_ID):

    d2sr ros2 --topic /camera/depth/image_raw --depth-scale 1000
    python docs/examples/ros2_depth.py --topic /camera/depth/image_raw --frames 30

It publishes depth frames (sensor_msgs/Image, 16UC1 millimetres) at 10 Hz, every other one with a band of
interference (half the band's pixels read a false return 0.3-2 m away, as another scanning sensor's light
gives), and prints each repaired frame that comes back on TOPIC/repaired and its mask on TOPIC/mask. A correct
result: every clean frame comes back with 0 pixels repaired and its band at 2.50 m (the node changes nothing
the sensor delivered clean), every interfered one with thousands of pixels repaired and its band back at
about 2.50 m; the last lines count both.
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

BAND = np.s_[200:240]


def depth_frame(k: int) -> np.ndarray:
    """A wall at 2-3 m in millimetres, 3 mm of noise; every other frame (odd ``k``), half the pixels of rows
    200-240 read a false return 0.3-2 m away (interference)."""
    rng = np.random.default_rng(k)
    z = np.tile(np.linspace(2000, 3000, 640, dtype=np.float32), (480, 1))
    z += rng.normal(0, 3, z.shape).astype(np.float32)
    if k % 2:
        band = z[BAND]
        hit = rng.random(band.shape) < 0.5
        band[hit] = rng.uniform(300, 2000, int(hit.sum()))
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
    while time.monotonic() < end and min(len(v) for v in got.values()) < args.frames:  # frames and masks
        for part, reader in readers.items():
            for msg in reader.take(N=64):
                got[part][msg.header.stamp.sec - 1_000] = pixels(msg)
        time.sleep(0.05)
    kept = fixed = 0
    for k in sorted(got["repaired"]):
        out = got["repaired"][k]
        kind = "interfered" if k % 2 else "clean"
        mask = got["mask"].get(k)
        repaired = int(np.count_nonzero(mask)) if mask is not None else 0
        band = np.median(out[BAND]) / 1000
        print(f"frame {k} ({kind}): {repaired} pixels repaired, band median {band:.2f} m")
        if k % 2:
            fixed += bool(repaired) and abs(band - 2.5) < 0.05
        else:
            kept += np.array_equal(out, depth_frame(k))
    clean, hit = (len([k for k in got["repaired"] if k % 2 == r]) for r in (0, 1))
    print(f"clean frames unchanged: {kept} of {clean}; interfered frames repaired: {fixed} of {hit}")
    print(f"{len(got['repaired'])} of {args.frames} frames came back on {args.topic}/repaired")
    return 0 if len(got["repaired"]) == args.frames else 1


if __name__ == "__main__":
    raise SystemExit(main())
