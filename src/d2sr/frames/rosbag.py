"""ROS 1 ``.bag`` and ROS 2 bags (sqlite3 ``.db3`` or ``.mcap``) through rosbags.

Depth topics are ``sensor_msgs/Image`` (16UC1 millimetres, 32FC1 metres; REP 118) or
``sensor_msgs/CompressedImage`` in compressed_depth_image_transport's format (a 12-byte header, then a
PNG). ``--topic`` picks one; without it the single depth-looking topic is used.
"""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from d2sr.atomic import CALLER
from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics, Reader, Writer
from d2sr.frames.colour import decode_colour
from d2sr.frames.encoded import check_pixels
from d2sr.frames.png import decode_png, encode_png

__all__ = ["BagColours", "BagReader", "Ros1Writer", "Ros2Writer", "bag_root", "bag_topics", "is_ros2_bag"]

IMAGE = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
INFO = "sensor_msgs/msg/CameraInfo"
_TS2 = get_typestore(Stores.ROS2_HUMBLE)
_TS1 = get_typestore(Stores.ROS1_NOETIC)
#: compressed_depth_image_transport's ConfigHeader: int32 format, float32 depthParam[2].
_HEADER = struct.Struct("<iff")


def is_ros2_bag(path: Path) -> bool:
    return path.is_dir() and (path / "metadata.yaml").is_file()


def bag_root(path: Path) -> Path:
    """ROS 2 bags are folders; accept the .db3/.mcap file inside one as well."""
    if path.suffix in (".db3", ".mcap") and path.is_file() and (path.parent / "metadata.yaml").is_file():
        return path.parent
    return path


def _open(path: Path) -> AnyReader:
    try:
        reader = AnyReader([bag_root(path)], default_typestore=_TS2)
        reader.open()
    except (AnyReaderError, OSError, ValueError, KeyError, struct.error) as exc:
        raise InputError(
            f"{path}: cannot read bag: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
        ) from None
    return reader


def bag_topics(path: Path) -> dict[str, str]:
    """topic -> message type."""
    reader = _open(path)
    try:
        return {c.topic: c.msgtype for c in reader.connections}
    finally:
        reader.close()


def decode_image(msg: Any, msgtype: str, where: str) -> tuple[np.ndarray, float]:
    """(depth array, depth scale) of one Image or CompressedImage message."""
    if msgtype.endswith("CompressedImage"):
        fmt = str(msg.format)
        raw = bytes(msg.data)
        if "compressedDepth" not in fmt:
            raise InputError(f"{where}: CompressedImage format {fmt!r} is not compressedDepth")
        if len(raw) < _HEADER.size:
            raise InputError(f"{where}: compressedDepth message too short")
        _, qa, qb = _HEADER.unpack_from(raw)
        img = decode_png(raw[_HEADER.size :], where)
        if fmt.startswith("32FC1"):
            with np.errstate(divide="ignore"):
                depth = np.where(img > 0, qa / (img.astype(np.float32) - qb), 0).astype(np.float32)
            return depth, 1.0
        return img, 1000.0
    enc = str(msg.encoding)
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    big = bool(msg.is_bigendian)
    dt = {"16UC1": np.uint16, "mono16": np.uint16, "32FC1": np.float32}.get(enc)
    if dt is None:
        raise InputError(f"{where}: image encoding {enc!r} is not depth (16UC1 or 32FC1)")
    check_pixels(h, w, where)
    data = np.asarray(msg.data, dtype=np.uint8)
    item = np.dtype(dt).itemsize
    if step < w * item or data.size < h * step:
        raise InputError(f"{where}: image data ({data.size} bytes) too short for {w}x{h} {enc}")
    rows = data[: h * step].reshape(h, step)[:, : w * item]
    depth = np.ascontiguousarray(rows).view(np.dtype(dt).newbyteorder(">" if big else "<")).astype(dt)
    if dt == np.float32:
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, 0).astype(
            np.float32
        )  # REP 118: NaN/inf = none
        return depth, 1.0
    return depth, 1000.0


class BagReader(Reader):
    """Depth frames of one topic of a ROS 1 or ROS 2 bag."""

    def __init__(self, path: Path, topic: str | None = None) -> None:
        super().__init__(path)
        topics = bag_topics(self.path)
        images = {t: m for t, m in topics.items() if m in IMAGE}
        if topic is not None:
            if topic not in topics:
                have = ", ".join(sorted(images)) or "none"
                raise InputError(f"{self.path}: no topic {topic!r} (image topics: {have})")
            if topics[topic] not in IMAGE:
                raise InputError(f"{self.path}: topic {topic!r} is {topics[topic]}, not an image")
        else:
            if not images:
                raise InputError(f"{self.path}: no depth topic (no sensor_msgs Image or CompressedImage)")
            depthy = [t for t in images if "depth" in t.lower()] or list(images)
            if len(depthy) > 1:
                raise InputError(
                    f"{self.path}: several image topics ({', '.join(sorted(depthy))}); pick one (topic)",
                    "topic",
                )
            topic = depthy[0]
        self.topic, self.msgtype = topic, topics[topic]
        reader = _open(self.path)
        try:
            self._count = sum(c.msgcount for c in reader.connections if c.topic == topic)
            infos = [c for c in reader.connections if c.topic.rsplit("/", 1)[0] == topic.rsplit("/", 1)[0]]
            self.intrinsics = self._camera_info(
                reader, [c for c in infos if c.msgtype.endswith("CameraInfo")]
            )
            first = next(iter(self), None)
        finally:
            reader.close()
        if first is None:
            raise InputError(f"{self.path}: topic {topic!r} has no messages")
        self.depth_scale = first.meta["depth_scale"]
        self._shape = first.depth.shape

    @staticmethod
    def _camera_info(reader: AnyReader, conns: list[Any]) -> Intrinsics | None:
        if not conns:
            return None
        for conn, _, raw in reader.messages(connections=conns):
            try:
                m: Any = reader.deserialize(raw, conn.msgtype)  # a class rosbags builds at run time
            except Exception as exc:  # rosbags raises several types for damaged messages
                raise InputError(
                    f"{conn.topic}: cannot decode its first camera_info ({type(exc).__name__})"
                ) from None
            k = [float(x) for x in (m.k if hasattr(m, "k") else m.K)]
            try:
                return Intrinsics(int(m.width), int(m.height), k[0], k[4], k[2], k[5])
            except InputError:  # ROS's uncalibrated camera (K all zeros), or values no camera has: none
                return None
        return None

    def __len__(self) -> int:
        return self._count

    @property
    def shape(self) -> tuple[int, int]:
        return self._shape

    def __iter__(self) -> Iterator[Frame]:
        for i, msg, stamp, where in _messages(self.path, self.topic):
            depth, scale = decode_image(msg, self.msgtype, where)
            yield Frame(f"{i:06d}", depth, stamp, {"depth_scale": scale})


class BagColours:
    """The colour frames of one topic of a ROS 1 or ROS 2 bag, as ``(stamp ns, BGR or grey image)`` in bag
    order: what frame synthesis follows the camera with (``d2sr run BAG --fill --colour-topic``)."""

    def __init__(self, path: Path, topic: str) -> None:
        self.path, self.topic = Path(path), topic
        topics = bag_topics(self.path)
        if topic not in topics:
            have = ", ".join(sorted(t for t, m in topics.items() if m in IMAGE)) or "none"
            raise InputError(f"{self.path}: no colour topic {topic!r} (image topics: {have})")
        if topics[topic] not in IMAGE:
            raise InputError(f"{self.path}: colour topic {topic!r} is {topics[topic]}, not an image")
        self.msgtype = topics[topic]

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        compressed = self.msgtype.endswith("CompressedImage")
        for _, msg, stamp, where in _messages(self.path, self.topic):
            yield stamp, decode_colour(msg, where, compressed)


def _messages(path: Path, topic: str) -> Iterator[tuple[int, Any, int, str]]:
    """``topic``'s messages in bag order: (index, message, stamp ns, where for errors)."""
    reader = _open(path)
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        for i, (conn, stamp, raw) in enumerate(reader.messages(connections=conns)):
            where = f"{path}: {topic} message {i}"
            try:
                msg: Any = reader.deserialize(raw, conn.msgtype)
            except Exception as exc:  # rosbags raises several types for damaged messages
                raise InputError(f"{where}: cannot decode ({type(exc).__name__})") from None
            yield i, msg, _stamp(msg, stamp), where
    finally:
        reader.close()


def _stamp(msg: Any, bag_ns: int) -> int:
    """A message's header stamp in ns (ROS 1 or 2), or its bag time when the header has none."""
    st = msg.header.stamp
    ns = int(st.sec) * 1_000_000_000 + int(getattr(st, "nanosec", getattr(st, "nsec", 0)))
    return ns or int(bag_ns)


def _message(ts: Any, frame: Frame, compressed: bool, ros1: bool) -> tuple[Any, str]:
    types = ts.types
    ns = frame.timestamp_ns or 0
    t = types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    hkw = {"seq": 0} if ros1 else {}
    header = types["std_msgs/msg/Header"](stamp=t, frame_id="depth", **hkw)
    d = frame.depth
    if compressed:
        if d.dtype != np.uint16:
            raise InputError(f"frame {frame.name}: compressedDepth is written for uint16 depth only")
        data = _HEADER.pack(0, 0.0, 0.0) + encode_png(d, frame.name)
        msg = types["sensor_msgs/msg/CompressedImage"](
            header=header, format="16UC1; compressedDepth png", data=np.frombuffer(data, np.uint8)
        )
        return msg, "sensor_msgs/msg/CompressedImage"
    enc = "16UC1" if d.dtype == np.uint16 else "32FC1"
    h, w = d.shape
    msg = types["sensor_msgs/msg/Image"](
        header=header,
        height=h,
        width=w,
        encoding=enc,
        is_bigendian=0,
        step=w * d.itemsize,
        data=np.frombuffer(np.ascontiguousarray(d, d.dtype.newbyteorder("<")).tobytes(), np.uint8),
    )
    return msg, "sensor_msgs/msg/Image"


def _camera_info(ts: Any, header: Any, i: Intrinsics, ros1: bool) -> Any:
    k = [i.fx, 0.0, i.px, 0.0, i.fy, i.py, 0.0, 0.0, 1.0]
    p = [i.fx, 0.0, i.px, 0.0, 0.0, i.fy, i.py, 0.0, 0.0, 0.0, 1.0, 0.0]
    types = ts.types
    roi = types["sensor_msgs/msg/RegionOfInterest"](
        x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
    )
    arr = {"D": np.zeros(0), "K": np.array(k), "R": np.eye(3).ravel(), "P": np.array(p)}
    if not ros1:
        arr = {name.lower(): v for name, v in arr.items()}
    return types[INFO](
        header=header,
        height=i.height,
        width=i.width,
        distortion_model="plumb_bob",
        binning_x=0,
        binning_y=0,
        roi=roi,
        **arr,
    )


class _BagWriter(Writer):
    ros1 = False

    def __init__(
        self,
        path: Path,
        depth_scale: float,
        intrinsics: Intrinsics | None = None,
        topic: str = "/camera/depth/image_raw",
        compressed: bool = False,
    ) -> None:
        super().__init__(path, depth_scale, intrinsics)
        self.topic = topic + ("/compressedDepth" if compressed else "")
        self.compressed = compressed
        self._bag: Writer1 | Writer2 | None = None
        self._conn: Any = None  # rosbags connections
        self._info: Any = None
        self.info_topic = topic.rsplit("/", 1)[0] + "/camera_info"

    def _open_bag(self) -> None:
        raise NotImplementedError

    def _write(self, frame: Frame) -> None:
        ts = _TS1 if self.ros1 else _TS2
        want = 1.0 if frame.depth.dtype == np.float32 else 1000.0
        if self.depth_scale != want:
            raise InputError(
                f"{self.path}: ROS depth images are millimetres (16UC1) or metres (32FC1); this recording's "
                f"scale is {self.depth_scale:g} per metre. Convert it first"
            )
        msg, msgtype = _message(ts, frame, self.compressed, self.ros1)
        if self._bag is None:
            self._open_bag()
            assert self._bag is not None
            who: dict[str, Any] = {"callerid": CALLER} if self.ros1 else {}  # how --overwrite knows it
            self._conn = self._bag.add_connection(self.topic, msgtype, typestore=ts, **who)
            if self.intrinsics is not None:
                self._info = self._bag.add_connection(self.info_topic, INFO, typestore=ts, **who)
        serialize = ts.serialize_ros1 if self.ros1 else ts.serialize_cdr
        stamp = frame.timestamp_ns or self.count
        self._bag.write(self._conn, stamp, serialize(msg, msgtype))
        if self._info is not None and self.intrinsics is not None:
            info = _camera_info(ts, msg.header, self.intrinsics, self.ros1)
            self._bag.write(self._info, stamp, serialize(info, INFO))

    def _finish(self) -> None:
        if self._bag is None:
            raise InputError(f"{self.path}: no frames to write")
        self._bag.close()
        if self.is_dir:
            assert self._tmp is not None
            unstage(self._tmp, self.path.name)

    def abort(self) -> None:
        if self._bag is not None:
            with contextlib.suppress(Exception):
                self._bag.close()
        super().abort()


def staged(tmp: Path, bag: str) -> Path:
    """Where rosbags writes a ROS 2 bag that becomes the folder ``tmp`` once finished (``unstage``): a folder
    ``<bag>_0`` inside it, so that rosbags names the data file as rosbag2 does (``<bag>_0.mcap``), in the
    folder, in ``metadata.yaml`` and in the metadata the data file carries: never a temporary name, so the
    same bag is written byte for byte whatever the process."""
    return tmp / f"{bag}_0"


def unstage(tmp: Path, bag: str) -> None:
    """Move a finished bag's files from ``staged(tmp, bag)`` up into ``tmp``."""
    stage = staged(tmp, bag)
    for f in sorted(stage.iterdir()):
        f.rename(tmp / f.name)
    stage.rmdir()


class Ros1Writer(_BagWriter):
    ros1 = True

    def _open_bag(self) -> None:
        assert self._tmp is not None
        self._tmp.unlink()  # rosbags creates the file itself
        self._bag = Writer1(self._tmp)
        self._bag.open()


class Ros2Writer(_BagWriter):
    """A ROS 2 bag folder; ``storage`` is ``sqlite3`` (.db3) or ``mcap``."""

    is_dir = True

    def __init__(
        self,
        path: Path,
        depth_scale: float,
        intrinsics: Intrinsics | None = None,
        storage: str = "sqlite3",
        **kw: Any,
    ) -> None:
        super().__init__(path, depth_scale, intrinsics, **kw)
        if storage not in ("sqlite3", "mcap"):
            raise InputError(f"ROS 2 storage must be sqlite3 or mcap, got {storage!r}")
        self.storage = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3

    def _open_bag(self) -> None:
        assert self._tmp is not None
        self._bag = Writer2(staged(self._tmp, self.path.name), version=9, storage_plugin=self.storage)
        self._bag.open()
