"""A ROS bag repaired into a bag of the same kind (``d2sr recover BAG --topic T``): every input connection
and message copied unchanged, in order, plus ``T/repaired`` (the input's message type and encoding) and
``T/mask`` (``sensor_msgs/Image`` mono8, 255 = interfered), one message each per depth message, with its
header and bag time. A ROS 2 bag keeps its storage (MCAP or sqlite3); a ROS 1 ``.bag`` gives a ``.bag``.

With a colour topic (``--colour-topic C``, a duty-cycled sensor's bag): every colour message that no depth
message of its stamp joins (the laser was off) also gets a ``T/repaired`` frame synthesized from the last
repaired one and the colour (``d2sr.synth``), an empty ``T/mask`` and ``T/confidence`` (mono8, 255 =
measured or warped from a measurement), with the colour message's header and bag time: what ``d2sr ros2
--colour-topic`` publishes.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2

from d2sr.atomic import CALLER, commit, discard, state, temp_for
from d2sr.errors import InputError
from d2sr.frames.base import Frame, Intrinsics
from d2sr.frames.colour import PAIR_NS, decode_colour
from d2sr.frames.png import decode_png, encode_png
from d2sr.frames.rosbag import _HEADER, _TS1, _TS2, _open, _stamp, bag_root, staged, unstage

__all__ = ["CONFIDENCE", "MASK", "REPAIRED", "BagCopy", "Synthesis"]

REPAIRED = "/repaired"  # suffixes of the topics d2sr adds
MASK = "/mask"
CONFIDENCE = "/confidence"
IMAGE = "sensor_msgs/msg/Image"


def _storage(bag: Path) -> StoragePlugin:
    """The input's rosbag2 storage (its files' suffix)."""
    return StoragePlugin.MCAP if any(bag.glob("*.mcap")) else StoragePlugin.SQLITE3


def _header(ts: Any, h: Any, ros1: bool) -> Any:
    """``h`` (any typestore's Header) rebuilt in typestore ``ts``."""
    st = h.stamp
    t = ts.types["builtin_interfaces/msg/Time"](sec=int(st.sec), nanosec=int(getattr(st, "nanosec", 0)))
    extra = {"seq": int(getattr(h, "seq", 0))} if ros1 else {}
    return ts.types["std_msgs/msg/Header"](stamp=t, frame_id=str(h.frame_id), **extra)


def _pixels(msg: Any, dtype: np.dtype[Any]) -> tuple[np.ndarray, np.ndarray]:
    """(the message's row buffer as uint8 rows, a writable view of its pixels in the stored byte order)."""
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    rows = np.array(msg.data, np.uint8)[: h * step].reshape(h, step).copy()
    stored = dtype.newbyteorder(">" if msg.is_bigendian else "<")
    return rows, rows[:, : w * dtype.itemsize].view(stored)


class Synthesis(Protocol):
    """Frames for the moments a duty-cycled sensor's laser skipped (``jobs.recordings`` gives one)."""

    topic: str  # the colour topic

    def real(self, depth: np.ndarray, colour: np.ndarray | None) -> None:
        """A repaired frame (the bag's units) and its colour: what the next are made from."""

    def skipped(self, colour: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(16-bit depth in the bag's units, uint8 confidence) for a colour frame; None before any real."""


class BagCopy:
    """``write(frame, depth, mask, repaired)`` for each depth message in order, then ``finish``; ``close``
    moves the bag into place, ``abort`` removes it."""

    def __init__(self, src: Path, topic: str, out: Path, ros1: bool, colour: Synthesis | None = None) -> None:
        """``colour``: what synthesizes the frames of the colour messages no depth message joins."""
        self.topic, self.out, self.ros1 = topic, Path(out), ros1
        self.colour = colour
        self.synthesized = 0
        self._source: np.ndarray | None = None  # the last repaired frame, not yet synthesis's source
        self._coming: np.ndarray | None = None  # the colour of the depth message being copied up to
        self._last_stamp: int | None = None  # the last depth message's stamp
        self.ts = _TS1 if ros1 else _TS2
        self.reader = _open(src)
        self.tmp: Path | None = temp_for(self.out, is_dir=not ros1)
        self._before = state(self.out)  # what is there as the run begins: nothing else is replaced
        if ros1:
            discard(self.tmp)  # rosbags makes the file itself
        try:
            self._open_writer(src)
        except BaseException:
            self.abort()
            raise

    def _open_writer(self, src: Path) -> None:
        assert self.tmp is not None
        taken = {c.topic for c in self.reader.connections}
        for t in (self.topic + REPAIRED, self.topic + MASK, self.topic + CONFIDENCE):
            if t in taken:
                raise InputError(f"{src}: already has {t} (a bag d2sr repaired); give it the original")
        if self.ros1:
            self.bag: Writer1 | Writer2 = Writer1(self.tmp)
        else:
            stage = staged(self.tmp, self.out.name)
            self.bag = Writer2(stage, version=9, storage_plugin=_storage(bag_root(src)))
        self.bag.open()
        self.conns = {c.id: self._copy_connection(c) for c in self.reader.connections}
        kind = next(c.msgtype for c in self.reader.connections if c.topic == self.topic)
        if self.colour is not None and kind != IMAGE:
            raise InputError(f"{self.topic}: is {kind}; frames are synthesized into sensor_msgs/Image topics")
        who: dict[str, Any] = {"callerid": CALLER} if self.ros1 else {}  # how --overwrite knows the bag
        self.repaired = self.bag.add_connection(self.topic + REPAIRED, kind, typestore=self.ts, **who)
        self.mask = self.bag.add_connection(self.topic + MASK, IMAGE, typestore=self.ts, **who)
        self.confidence = (
            self.bag.add_connection(self.topic + CONFIDENCE, IMAGE, typestore=self.ts, **who)
            if self.colour is not None
            else None
        )
        self.messages: Iterator[tuple[Any, int, bytes]] = self.reader.messages()

    def _copy_connection(self, c: Any) -> Any:
        """The input connection as it was: type, definition, and its bag's own extras."""
        msgdef = c.msgdef.data or None
        typestore = None if msgdef else self.ts
        if isinstance(self.bag, Writer1):
            return self.bag.add_connection(
                c.topic, c.msgtype, typestore=typestore, msgdef=msgdef, md5sum=c.digest if msgdef else None,
                callerid=getattr(c.ext, "callerid", None), latching=getattr(c.ext, "latching", None),
            )  # fmt: skip
        return self.bag.add_connection(
            c.topic, c.msgtype, typestore=typestore, msgdef=msgdef, rihs01=c.digest if msgdef else None,
            serialization_format=getattr(c.ext, "serialization_format", "cdr"),
            offered_qos_profiles=getattr(c.ext, "offered_qos_profiles", ()),
        )  # fmt: skip

    def _serialize(self, msg: Any, msgtype: str) -> bytes:
        data = self.ts.serialize_ros1(msg, msgtype) if self.ros1 else self.ts.serialize_cdr(msg, msgtype)
        return bytes(data)

    def write(self, frame: Frame, depth: np.ndarray, mask: np.ndarray, repaired: bool) -> None:
        """Copy the input up to and including the next depth message, then its repair and mask."""
        for conn, stamp, raw in self.messages:
            self.bag.write(self.conns[conn.id], stamp, raw)
            if conn.topic == self.topic:
                break
            self._colour(conn, stamp, raw, frame.timestamp_ns)
        else:
            raise InputError(f"{frame.name}: the bag has fewer {self.topic} messages than frames read")
        msg: Any = self.reader.deserialize(raw, conn.msgtype)
        header = _header(self.ts, msg.header, self.ros1)
        fixed = self._repaired(msg, conn.msgtype, header, depth, mask)
        self.bag.write(self.repaired, stamp, self._serialize(fixed, conn.msgtype))
        self.bag.write(self.mask, stamp, self._image(header, mask.astype(np.uint8) * 255))
        if self.colour is not None:
            self._feed(None)  # the frame before, if its colour never came
            self._last_stamp = frame.timestamp_ns
            self._source = depth
            if self._coming is not None:  # its colour came first
                self._feed(self._coming)
                self._coming = None

    def _image(self, header: Any, image: np.ndarray) -> Any:
        """A serialized ``sensor_msgs/Image``: mono8 for uint8, 16UC1 (little-endian) for uint16."""
        h, w = image.shape
        encoding = "mono8" if image.dtype == np.uint8 else "16UC1"
        data = np.frombuffer(image.astype(image.dtype.newbyteorder("<")).tobytes(), np.uint8)
        img = self.ts.types[IMAGE](
            header=header, height=h, width=w, encoding=encoding, is_bigendian=0, step=w * image.itemsize,
            data=data,
        )  # fmt: skip
        return self._serialize(img, IMAGE)

    def _colour(self, conn: Any, stamp: int, raw: bytes, coming: int | None) -> None:
        """A colour message before the depth message of stamp ``coming``: its frame's colour, the colour
        of the frame before it, or a moment the laser skipped (synthesized and written now)."""
        if self.colour is None or conn.topic != self.colour.topic:
            return
        msg: Any = self.reader.deserialize(raw, conn.msgtype)
        at = _stamp(msg, stamp)
        image = decode_colour(msg, f"{self.colour.topic} at {at}", conn.msgtype.endswith("CompressedImage"))
        if coming is not None and abs(at - coming) <= PAIR_NS:
            self._coming = image  # the coming frame's own colour, for when that frame is repaired
            return
        if self._last_stamp is not None and abs(at - self._last_stamp) <= PAIR_NS:
            self._feed(image)  # the frame before's colour, come after it
            return
        self._feed(None)
        made = self.colour.skipped(image)
        if made is None:
            return  # nothing real yet to synthesize from
        depth, confidence = made
        header = _header(self.ts, msg.header, self.ros1)
        self.bag.write(self.repaired, stamp, self._image(header, depth.astype(np.uint16)))
        self.bag.write(self.mask, stamp, self._image(header, np.zeros(depth.shape, np.uint8)))
        assert self.confidence is not None
        self.bag.write(self.confidence, stamp, self._image(header, confidence))
        self.synthesized += 1

    def _feed(self, image: np.ndarray | None) -> None:
        """The last repaired frame becomes synthesis's source (once), with its colour if it came."""
        if self._source is not None and self.colour is not None:
            self.colour.real(self._source, image)
            self._source = None

    def _repaired(self, msg: Any, msgtype: str, header: Any, depth: np.ndarray, m: np.ndarray) -> Any:
        """The depth message with the repaired pixels written in, in its own encoding; every other pixel
        (NaN included) and byte as it was."""
        if msgtype.endswith("CompressedImage"):
            raw = bytes(msg.data)
            head, img = raw[: _HEADER.size], decode_png(raw[_HEADER.size :], "compressedDepth")
            if str(msg.format).startswith("32FC1"):  # inverse depth, quantized: img = a / depth + b
                _, a, b = _HEADER.unpack(head)
                d = np.maximum(depth[m].astype(np.float64), 1e-6)
                fixed = np.where(depth[m] > 0, np.clip(np.rint(a / d + b), 1, 65535), 0)
                img[m] = fixed.astype(np.uint16)
            else:
                img[m] = depth[m]
            data = np.frombuffer(head + encode_png(img, "compressedDepth"), np.uint8)
            return self.ts.types[msgtype](header=header, format=str(msg.format), data=data)
        dtype = np.dtype(np.float32 if str(msg.encoding) == "32FC1" else np.uint16)
        rows, pixels = _pixels(msg, dtype)
        pixels[m] = depth[m].astype(dtype)
        return self.ts.types[IMAGE](
            header=header, height=int(msg.height), width=int(msg.width), encoding=str(msg.encoding),
            is_bigendian=int(msg.is_bigendian), step=int(msg.step), data=rows.ravel(),
        )  # fmt: skip

    def finish(self, scale: float, intrinsics: Intrinsics | None) -> None:
        """Copy what follows the last depth message."""
        for conn, stamp, raw in self.messages:
            self.bag.write(self.conns[conn.id], stamp, raw)
            self._colour(conn, stamp, raw, None)

    def close(self) -> None:
        """Close the bag and move it into place (a ROS 2 folder gets d2sr's manifest)."""
        assert self.tmp is not None
        self.bag.close()
        self.reader.close()
        if not self.ros1:
            unstage(self.tmp, self.out.name)
        commit(self.tmp, self.out, self._before)
        self.tmp = None

    def abort(self) -> None:
        for closing in (getattr(self, "bag", None), self.reader):
            if closing is not None:
                with contextlib.suppress(Exception):
                    closing.close()
        if self.tmp is not None:
            discard(self.tmp)
            self.tmp = None
