"""Shared test helpers (pytest puts this folder on sys.path)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from d2sr.frames import Intrinsics
from d2sr.frames.png import encode_png

ROOT = Path(__file__).resolve().parents[1]  # the repository


def markdown_table(text: str, first: str) -> list[list[str]]:
    """The markdown table whose header row starts with ``| first |``: header and rows, cells stripped."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first} |"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        if not set(line) <= set("|-: "):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def d2sr(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the real console entry point in a fresh interpreter, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "d2sr", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        timeout=300,
    )


def d2sr_inprocess(*args: str) -> tuple[int, str, str]:
    """The console entry point in this process (fast, for many runs): (exit code, stdout with rich's line
    wrapping undone, stderr)."""
    import io
    from contextlib import redirect_stderr, redirect_stdout

    from d2sr.cli import main
    from d2sr.ui import take_warnings

    take_warnings()  # what library calls earlier in this process left waiting is not this command's

    out, err = io.StringIO(), io.StringIO()
    argv, sys.argv = sys.argv, ["d2sr", *args]
    try:
        with redirect_stderr(err), redirect_stdout(out):
            main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    finally:
        sys.argv = argv
    return code, " ".join(out.getvalue().split()), err.getvalue()


def room(seed: int = 0, shape: tuple[int, int] = (480, 640), scale: float = 4000.0):
    """A wall, a floor and a box in L515 units (``scale`` per metre), with the sensor's missing returns."""
    import numpy as np

    h, w = shape
    rng = np.random.default_rng(seed)
    rows = np.arange(h, dtype=np.float32)[:, None]
    metres = np.broadcast_to(np.where(rows > h * 0.6, 1.2 + 2.0 * (h - rows) / h, 3.2), shape).copy()
    metres[h // 3 : h // 2, w // 4 : w // 2] = 1.8
    metres += rng.normal(0, 0.003, shape).astype(np.float32)
    metres[rng.random(shape) < 0.3] = 0
    return (metres * scale).astype(np.uint16)


class FakeNet:
    """Flags frames whose top-left pixel is 1; repairs by writing 2 m into the left half."""

    name = "fake"
    threshold = 0.5
    passes = 1

    def __init__(self, frames: int = 1) -> None:
        self.recovered = 0
        self.frames = frames
        self.previous: list[np.ndarray | None] = []
        self.before: list[np.ndarray | None] = []  # what the detector was given as the previous frame
        self.cuts: list[float | None] = []  # the threshold it was told its scores are held to

    def scores(
        self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
    ) -> np.ndarray:
        self.before.append(previous)
        self.cuts.append(cut)
        return (metres[:, 0, 0] * 4000 == 1).astype(np.float32)

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        self.recovered += 1
        self.previous.append(previous)
        mask = np.zeros(metres.shape, bool)
        mask[..., : metres.shape[-1] // 2] = True
        return np.full(metres.shape, 2.0, np.float32), mask


# A camera and a textured wall the fill tests and the ROS 2 node's colour tests share.
K = Intrinsics(320, 240, 300.0, 300.0, 159.5, 119.5)


def texture(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 255, (60, 80), dtype=np.uint8)
    return cv2.GaussianBlur(
        cv2.resize(small, (K.width * 2, K.height * 2), interpolation=cv2.INTER_NEAREST), (3, 3), 0
    )


def colour_of_wall(t: np.ndarray, tex: np.ndarray) -> np.ndarray:
    """A textured wall at z = 3 seen by a camera translated by ``t``: the texture mapped through the plane's
    homography (the texture spans 2x the first view, centred)."""
    z = 3.0 - t[2]
    # pixel -> wall point -> texture pixel
    v, u = np.mgrid[0 : K.height, 0 : K.width].astype(np.float32)
    x = (u - K.px) / K.fx * z + t[0]
    y = (v - K.py) / K.fy * z + t[1]
    tu = (x / 3.0 * K.fx + K.px) + K.width / 2
    tv = (y / 3.0 * K.fy + K.py) + K.height / 2
    return cv2.remap(tex, tu.astype(np.float32), tv.astype(np.float32), cv2.INTER_LINEAR)


def good_folder(root: Path, n: int = 4, shape: tuple[int, int] = (96, 128), scale: float = 1000) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(n):
        d = (rng.uniform(1.0, 4.0, shape) * scale).astype(np.uint16)
        (root / f"f{i:03d}.png").write_bytes(encode_png(d, "x"))
    return root


def run_cli(args: list[str]) -> tuple[int, str]:
    code, _, err = d2sr_inprocess(*args)
    return code, err


BAG_TOPIC = "/camera/depth/image_raw"
BAG_FRAMES = 5


def bag_frames() -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    out = []
    for _ in range(BAG_FRAMES):
        d = (rng.uniform(1.0, 4.0, (96, 128)) * 1000).astype(np.uint16)
        d[rng.random(d.shape) < 0.3] = 0
        out.append(d)
    return out


def write_bag(path: Path, kind: str, encoding: str = "16UC1") -> list[np.ndarray]:
    """A bag as a robot records it: depth (16UC1 mm or 32FC1 m) at 30 Hz, an IMU at 200 Hz."""
    ros1 = kind == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    T = ts.types
    if ros1:
        bag: Writer1 | Writer2 = Writer1(path)
    else:
        bag = Writer2(
            path, version=9, storage_plugin=StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        )
    frames = bag_frames()
    with bag:
        depth = bag.add_connection(BAG_TOPIC, "sensor_msgs/msg/Image", typestore=ts)
        imu = bag.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr

        def header(ns: int, frame: str) -> object:
            t = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            return T["std_msgs/msg/Header"](stamp=t, frame_id=frame, **({"seq": 0} if ros1 else {}))

        v3 = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=9.8)
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        cov = np.zeros(9)
        for k in range(BAG_FRAMES * 7):
            ns = 10**9 + k * 5_000_000
            m = T["sensor_msgs/msg/Imu"](header(ns, "imu"), q, cov, v3, cov, v3, cov)
            bag.write(imu, ns, ser(m, "sensor_msgs/msg/Imu"))
        for i, d in enumerate(frames):
            ns = 10**9 + i * 33_333_333
            data = d if encoding == "16UC1" else np.where(d > 0, d / 1000.0, np.nan).astype(np.float32)
            msg = T["sensor_msgs/msg/Image"](
                header(ns, "depth"),
                96,
                128,
                encoding,
                0,
                128 * data.itemsize,
                np.frombuffer(data.tobytes(), np.uint8),
            )
            bag.write(depth, ns + 1000, ser(msg, "sensor_msgs/msg/Image"))
    return frames
