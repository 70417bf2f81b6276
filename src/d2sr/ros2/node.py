"""The node: subscribe to one or more cameras' depth topics, run each frame through its camera's
``d2sr.Pipeline`` (closed through a trigger when given one), publish ``<topic>/repaired``, ``<topic>/mask``,
``<topic>/status`` and ``<topic>/camera_info`` per camera, ``/diagnostics`` for all."""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from d2sr.errors import ConfigError
from d2sr.ros2.camera import ENCODINGS, Camera, CameraLoop, Stats, planned
from d2sr.ros2.dds import Dds
from d2sr.ros2.wire import QOS, TRANSPORTS, Wire, dds_topic, domain_id

__all__ = [
    "ENCODINGS",
    "QOS",
    "TRANSPORTS",
    "Camera",
    "Ros2Node",
    "Stats",
    "Wire",
    "cameras_from",
    "dds_topic",
    "domain_id",
]

DIAGNOSTICS_S = 1.0  # how often /diagnostics is written (ROS 2's diagnostic aggregator expects about 1 Hz)
MAX_CAMERAS = 16  # cameras one node takes (each holds a loop and its frames in memory)


def cameras_of(topic: str | Camera | Sequence[str | Camera], colour_topic: str | None) -> list[Camera]:
    """The cameras a node is given: one topic, one ``Camera``, or a list of either; ``colour_topic`` pairs
    with a single camera (several give each ``Camera`` its own)."""
    given = [topic] if isinstance(topic, str | Camera) else list(topic)
    cams = [Camera(c) if isinstance(c, str) else c for c in given]
    if not cams or len(cams) > MAX_CAMERAS or not all(isinstance(c, Camera) for c in cams):
        raise ConfigError(f"give 1 to {MAX_CAMERAS} depth topics, got {len(cams)}", "topic")
    if colour_topic is not None:
        if len(cams) > 1:
            raise ConfigError(
                "with several cameras give one colour topic per topic, in order", "colour_topic"
            )
        cams = [Camera(cams[0].topic, colour_topic, cams[0].trigger, cams[0].scene_from)]
    return cams


def cameras_from(
    topics: Sequence[str],
    colour_topics: Sequence[str] = (),
    triggers: Sequence[str] = (),
    scene_froms: Sequence[str | Path] = (),
) -> list[Camera]:
    """Cameras from what a command line or a parameters file repeats: colour topics, triggers and stored
    scenes are each given once per topic, in order, or not at all."""
    given = {"colour_topic": colour_topics, "trigger": triggers, "scene_from": scene_froms}
    for name, values in given.items():
        if values and len(values) != len(topics):
            raise ConfigError(
                f"{name}: give one per topic ({len(topics)}), in order; got {len(values)}", name
            )
    return [
        Camera(
            topic,
            colour_topics[i] if colour_topics else None,
            triggers[i] if triggers else None,
            Path(scene_froms[i]) if scene_froms else None,
        )
        for i, topic in enumerate(topics)
    ]


class Ros2Node:
    """``topic``: a depth image topic, or several (``Camera``s, each with its own colour topic, trigger and
    stored scene), repaired in one process that shares the models; ``depth_scale``: units per metre of
    16-bit images (default 1000, REP 118's millimetres); ``wire``: QoS, domain, transport, node name,
    namespace and remapping (``Wire``); ``pipeline``: keyword arguments of ``d2sr.Pipeline`` (``settings``,
    ``desync``, ``trigger``, or their fields: ``model``, ``active_frames``, ...), for every camera; ``say``:
    where warnings go (one line each)."""

    def __init__(
        self,
        topic: str | Camera | Sequence[str | Camera],
        depth_scale: float | None = None,
        wire: Wire | None = None,
        say: Callable[[str], None] | None = None,
        colour_topic: str | None = None,
        **pipeline: Any,
    ) -> None:
        w = wire if wire is not None else Wire()
        cams = cameras_of(topic, colour_topic)
        if depth_scale is not None and not (
            isinstance(depth_scale, int | float) and np.isfinite(depth_scale) and depth_scale > 0
        ):
            raise ConfigError(
                f"depth_scale must be a positive number of units per metre, got {depth_scale}", "depth_scale"
            )
        names = [w.resolve(c.topic) for c in cams]  # a bad name or rule fails here, before DDS starts
        if len(set(names)) < len(names):
            raise ConfigError("a camera is named twice", "topic")
        _check_wiring(cams, w)
        from d2sr.runtime.pipeline import Pipeline, settings_of
        from d2sr.runtime.workers import repair_workers
        from d2sr.scene.stored import StoredScene

        base = settings_of(pipeline.pop("settings", None), {})
        # A scene that does not load stops the node before it starts, not each frame after.
        scenes = {c.scene_from or base.scene_from for c in cams}
        for path in (p for p in scenes if p is not None):
            StoredScene.load(path)

        # Frames are judged in order and repaired on several threads (one onnxruntime thread each), as
        # d2sr recover does: on 2 cores that keeps 30 Hz where one frame at a time falls behind.
        workers, threads = repair_workers()
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="d2sr-ros2")
        self._workers = workers
        self.say = say or (lambda line: None)
        self.depth_scale = depth_scale
        self.domain = domain_id() if w.domain is None else w.domain
        self.dds = Dds(w, self.domain)
        self.cameras: list[CameraLoop] = []
        for cam in cams:
            own = dict(pipeline)
            if cam.trigger is not None:
                own["trigger"] = cam.trigger
            update = {"scene_from": cam.scene_from} if cam.scene_from is not None else {}
            pipe = Pipeline(depth_scale, settings=base.model_copy(update=update), threads=threads, **own)
            self.cameras.append(CameraLoop(cam, pipe, self.dds, self._pool, self._say))
        self._warm_up()
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet

        from d2sr.ros2.msgs import DiagnosticArray

        # Per camera, once a second: frames in and out, dropped, the interfered share, latency, the window.
        self.diagnostics = self.dds.writer("/diagnostics", DiagnosticArray, "diagnostics")
        self._next_diagnostics = time.monotonic() + DIAGNOSTICS_S
        self._waitset = WaitSet(self.dds.participant)
        # Wake on data (a reader attached alone wakes only on its status changes).
        any_state = SampleState.Any | ViewState.Any | InstanceState.Any
        self._ready = [ReadCondition(r, any_state) for c in self.cameras for r in c.waking]
        for cond in self._ready:
            self._waitset.attach(cond)
        self._stop = threading.Event()
        self._turn = 0  # the camera whose waiting frame starts next (``start_waiting``)
        self.node_name, self.namespace = w.name, w.space
        self._announce()

    def _say(self, line: str) -> None:
        self.say(line)  # late-bound: a caller may set ``say`` after the node is made

    @property
    def topics(self) -> list[str]:
        """The cameras' depth topics, resolved."""
        return [c.topic for c in self.cameras]

    def _announce(self) -> None:
        """Say on ``ros_discovery_info`` (transient local, as ROS 2's rmw does) that this participant holds
        the node ``<namespace>/<node_name>`` with its readers and writers, so ``ros2 node list`` and
        ``ros2 node info`` show it."""
        from d2sr.ros2.msgs import NodeEntitiesInfo, ParticipantEntitiesInfo

        readers = [r for c in self.cameras for r in c.readers]
        writers = [w for c in self.cameras for w in c.writers] + [self.diagnostics]
        node = NodeEntitiesInfo(
            self.namespace, self.node_name, [_gid(r.guid) for r in readers], [_gid(w.guid) for w in writers]
        )
        self.graph = self.dds.latched("ros_discovery_info", ParticipantEntitiesInfo)
        self.graph.write(ParticipantEntitiesInfo(_gid(self.dds.participant.guid), [node]))

    def stop(self) -> None:
        """Ask ``spin`` to return (safe from a signal handler or another thread)."""
        self._stop.set()

    def spin(self, seconds: float | None = None) -> dict[str, Stats]:
        """Take, repair and publish until ``stop`` (or for ``seconds``); each camera's figures by topic."""
        if seconds is not None and not (np.isfinite(seconds) and seconds > 0):
            raise ConfigError(f"seconds must be a positive number, got {seconds}", "seconds")
        end = None if seconds is None else time.monotonic() + seconds
        while not self._stop.is_set() and (end is None or time.monotonic() < end):
            busy = any(c.running for c in self.cameras)
            self._waitset.wait(self.dds.duration(2 if busy else 100))
            for cam in self.cameras:
                cam.take(time.monotonic)
                cam.publish_done()
            self.start_waiting()
            for cam in self.cameras:
                cam.synthesize_due(time.monotonic())
            if time.monotonic() >= self._next_diagnostics:
                self._next_diagnostics = time.monotonic() + DIAGNOSTICS_S
                self.diagnostics.write(self._diagnostics())
        while any(c.running or c.waiting for c in self.cameras):
            for cam in self.cameras:
                cam.publish_done(wait=bool(cam.running))
            self.start_waiting()
        return {c.topic: c.stats for c in self.cameras}

    def start_waiting(self) -> None:
        """Start waiting frames while a worker is free (at most two frames in flight a worker), the cameras
        taking turns, so none waits behind another when the repair cannot keep up with all of them (oldest
        first starved the cameras whose frames come a moment later in each period)."""
        n = len(self.cameras)
        while sum(len(c.running) for c in self.cameras) < 2 * self._workers:
            turn = next(
                (k % n for k in range(self._turn, self._turn + n) if self.cameras[k % n].waiting), None
            )
            if turn is None:
                return
            self.cameras[turn].start_oldest()
            self._turn = turn + 1

    def close(self) -> None:
        self._pool.shutdown(wait=True)
        for cam in self.cameras:
            cam.pipeline.close()
        for cond in self._ready:
            self._waitset.detach(cond)

    def _warm_up(self) -> None:
        """One frame through the models, the repair and the message codecs before the first message, so it
        pays no start-up cost (the cameras share the models): the detectors on the node's thread, which
        judges, and the recovery model and the repair on each worker, which repairs (a thread's first
        frame-size buffers are its own to fault in)."""
        from d2sr.contract.repair import repair_frame
        from d2sr.ros2.msgs import warm_codecs

        warm_codecs()
        np.median(np.zeros(2))  # its first call imports numpy.ma (14 ms): the first frame's scale check
        net = self.cameras[0].pipeline.backend
        zeros = np.zeros((1, 480, 640), np.float32)
        # Twice: onnxruntime's second run at a size is the first at full speed (with one, the stream's first
        # frames were judged in 14-18 ms against 8).
        for _ in range(2):
            net.scores(zeros, zeros)  # with a frame before: a temporal detector's second model runs too
        together = threading.Barrier(self._workers)

        def repair() -> None:
            together.wait(timeout=60)  # each worker takes one, not one worker two
            for _ in range(2):
                with contextlib.suppress(Exception):  # --repair none: detector only, no recovery model
                    net.recover(zeros, None)
            repair_frame(np.ones((480, 640), np.uint16), zeros[0], np.ones((480, 640), bool), 1000.0)

        for done in [self._pool.submit(repair) for _ in range(self._workers)]:
            with contextlib.suppress(threading.BrokenBarrierError):
                done.result()

    def _diagnostics(self) -> Any:
        """``/diagnostics``: a status per camera (WARN while its frames are being dropped or refused)."""
        from d2sr.ros2.msgs import DiagnosticArray, Header, Time

        now = time.time_ns()
        return DiagnosticArray(
            Header(Time(now // 10**9, now % 10**9), ""), [c.diagnostic() for c in self.cameras]
        )


def _gid(guid: Any) -> Any:
    """A DDS entity's GUID (a uuid.UUID) as ROS 2's graph id."""
    from d2sr.ros2.msgs import GID_BYTES, Gid

    raw = guid.bytes
    return Gid(list(raw) + [0] * (GID_BYTES - len(raw)))


def _check_wiring(cams: list[Camera], wire: Wire) -> None:
    """Refuse, before DDS starts, a node that would read what it writes: an output that resolves (after
    remapping) onto any camera's input repairs its own output for ever. Every name is checked on the way."""
    reads: dict[str, str] = {}
    writes: dict[str, str] = {wire.resolve("/diagnostics"): "/diagnostics"}
    for cam in cams:
        ins, outs = planned(cam, wire)
        reads.update(dict.fromkeys(ins, cam.topic))
        writes.update(dict.fromkeys(outs, cam.topic))
    for name, topic in writes.items():
        if name in reads:
            raise ConfigError(
                f"remap: {name} would be both written (camera {topic}) and read (camera {reads[name]}): "
                "the node would repair its own output",
                "remap",
            )
