"""A simulated room that runs in step with its sensors' loops (numpy only).

``d2sr.sim.timing.simulate`` runs every controller inside one vectorized loop with a modelled detector;
the closed-loop runtime needs the opposite: the world hands each sensor its frames one slot at a time,
the sensor's own loop detects, repairs and decides its next window, and the world only learns that
window through the sensor's trigger. ``SimRoom`` is that world. Its physics are the timing world's (own
phase and drift per sensor, windows that wrap, laser start-up slots, ``min_overlap``, ``1-(1-p)^k`` hits,
drops, the same counter-based draws per (sensor, frame)), with the laser overlap of each frame computed
exactly from the intervals instead of in sub-steps; the frames are rendered by the scene model and
corrupted by the interference model, only where the overlapping lasers land.
"""

from __future__ import annotations

import functools
import heapq
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from d2sr.errors import ConfigError
from d2sr.sim.counter_rng import uniform
from d2sr.sim.interference import InterferenceSettings, Interferer, interfere
from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.rooms import L515, Renderer, SensorModel, SensorNoise
from d2sr.sim.timing import TimingSettings
from d2sr.sim.world import Rig, direct_view, lit_region, overlap_graph

__all__ = ["Camera", "RoomFrame", "SimRoom", "SlotEnd"]


class Camera:
    """One sensor of a rig: renders its clean frame at a time and corrupts it with given interferers.

    Each (victim, source) pair keeps one interference pattern for the whole sequence, so bands drift
    instead of jumping between frames."""

    def __init__(
        self, rig: Rig, sensor: int, seed: int, model: SensorModel, cfg: InterferenceSettings, noise_seed: int
    ) -> None:
        self.rig, self.sensor, self.seed, self.model, self.cfg = rig, sensor, seed, model, cfg
        self.cam = Renderer(rig.room, rig.intr)
        small = rig.intr.scaled(160, 120)
        self.others = {j: Renderer(rig.room, small) for j in range(rig.n) if j != sensor}
        self.noise = SensorNoise(model, (rig.intr.height, rig.intr.width), noise_seed)

    def frame(self, t: float, g: int, sources: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(depth, clean, mask) at time ``t`` (slot ``g``), interfered by ``sources`` (may be empty)."""
        pose = self.rig.pose(self.sensor, t)
        if self.cam.pose != pose:
            self.cam.move(pose)
        scene = self.cam.render(t)
        clean = self.noise.observe(scene)
        if not sources:
            return clean, clean, np.zeros(clean.shape, bool)
        its = []
        for j in sources:
            o = self.others[j]
            pj = self.rig.pose(j, t)
            if o.pose != pj:
                o.move(pj)
            direct = direct_view(self.cam, scene.depth, o)
            # Direct light bursts where the emitter sits; scattered light stays where j's laser lands.
            lit = (
                None
                if direct is not None
                else lit_region(self.cam, scene.depth, o, o.static().depth, self.model.max_range)
            )
            pair = self.seed * 7919 + self.sensor * 97 + j
            its.append(Interferer.draw(clean.shape, pair, self.cfg, direct_at=direct, region=lit))
        depth, mask = interfere(
            clean, self.model.depth_scale, its, g, self.seed * 31 + self.sensor, None, self.cfg
        )
        return depth, clean, mask


@dataclass
class RoomFrame:
    """A delivered frame with its ground truth (what a real sensor cannot tell you)."""

    sensor: int
    slot: int  # global slot index of this sensor
    time_s: float
    depth: np.ndarray  # uint16 at the sensor model's depth scale
    clean: np.ndarray
    mask: np.ndarray  # bool, True = changed by interference
    interferers: list[int] = field(default_factory=list)
    interfered: bool = False  # any pixel changed (timing-only rooms: hit by an overlapping laser)


@dataclass
class SlotEnd:
    """One slot of one sensor is over: its frame if one was delivered, and whether its period ended."""

    sensor: int
    slot: int
    time_s: float
    frame: RoomFrame | None
    period_end: bool
    overlapped: bool  # the lasers of others were on long enough (the timing world's "interfered" before p)


@functools.lru_cache(maxsize=1024)
def _laser_slots(offset: int, n: int, setup: int, total: int) -> frozenset[int]:
    return frozenset(int(s) for s in (offset - setup + np.arange(min(n + setup, total))) % total)


class Start(NamedTuple):
    """How a room starts, where a caller fixes it (None: as the rig and seed give it): the overlap graph,
    each sensor's first window offset, each sensor's phase (s into the first period)."""

    graph: OverlapGraph | None = None
    offsets: list[int] | None = None
    phases: Sequence[float] | None = None


class SimRoom:
    """Sensors of a rig in one room; ``set_offset`` is each sensor's trigger, ``slots`` the world's clock.

    The world never reads a controller: a sensor's window changes only when its own loop calls
    ``set_offset`` (it takes effect in the sensor's next period). ``render``: all sensors, none (timing
    only: frames carry no pixels), or the listed ones."""

    def __init__(
        self,
        rig: Rig,
        timing: TimingSettings | None = None,
        seed: int = 0,
        model: SensorModel = L515,
        interference: InterferenceSettings | None = None,
        start: Start | None = None,
        seconds: float = 60.0,
        render: bool | Sequence[int] = True,
    ) -> None:
        graph, offsets, phases = start if start is not None else Start()
        self.rig, self.seed, self.model = rig, seed, model
        self.cfg = timing or TimingSettings()
        self.n = rig.n
        self.graph = graph if graph is not None else overlap_graph(rig, seconds)
        if self.graph.n != self.n:
            raise ConfigError(f"overlap graph has {self.graph.n} sensors, the rig {self.n}")
        self._into = [np.flatnonzero(self.graph.dst == d) for d in range(self.n)]  # edges into each sensor
        rng = np.random.default_rng(seed)
        period_s = self.cfg.total_frames / self.cfg.fps
        self.t0 = rng.uniform(0, period_s, self.n) if phases is None else np.asarray(phases, float)
        if self.t0.shape != (self.n,):
            raise ConfigError(f"phases need one value per sensor ({self.n})")
        self.drift = rng.uniform(-1, 1, self.n) * self.cfg.drift_ppm * 1e-6
        self.tau = (1.0 + self.drift) / self.cfg.fps
        first = offsets or [0] * self.n
        if len(first) != self.n:
            raise ConfigError(f"{len(first)} offsets for {self.n} sensors")
        self._offsets: list[dict[int, int]] = [{0: int(o) % self.cfg.total_frames} for o in first]
        icfg = interference or InterferenceSettings()
        shown = set(range(self.n)) if render is True else set() if render is False else set(render)
        self.cameras = [
            Camera(rig, i, seed, model, icfg, seed * 1_000_003 + i * 10_007) if i in shown else None
            for i in range(self.n)
        ]

    @property
    def period_s(self) -> float:
        return self.cfg.total_frames / self.cfg.fps

    def set_offset(self, sensor: int, period: int, offset: int) -> None:
        """The trigger: sensor's window from ``period`` on starts at slot ``offset``."""
        if not 0 <= offset < self.cfg.total_frames:
            raise ConfigError(f"offset must be in 0..{self.cfg.total_frames - 1}, got {offset}")
        hist = self._offsets[sensor]
        hist[period] = int(offset)
        for p in [p for p in hist if p < period - 2]:  # only recent periods are ever looked up
            del hist[p]

    def offset(self, sensor: int, period: int) -> int:
        hist = self._offsets[sensor]
        known = [p for p in hist if p <= period]
        return hist[max(known)] if known else hist[min(hist)]

    def _active(self, sensor: int, g: int) -> bool:
        total, n = self.cfg.total_frames, self.cfg.active_frames
        return (g % total - self.offset(sensor, g // total)) % total < n

    def _laser_on(self, sensor: int, h: int) -> bool:
        total = self.cfg.total_frames
        return h % total in _laser_slots(
            self.offset(sensor, h // total), self.cfg.active_frames, self.cfg.setup, total
        )

    def _present(self, sensor: int, t: float) -> bool:
        pres = self.graph.present
        return True if pres is None else bool(pres[sensor, min(int(t / self.graph.dt), pres.shape[1] - 1)])

    def _on_time(self, s: int, a: float, b: float) -> float:
        """Seconds of [a, b) during which sensor s's laser was on (its slots under its own windows)."""
        if not self._present(s, 0.5 * (a + b)):
            return 0.0
        lo = int(np.floor((a - self.t0[s]) / self.tau[s]))
        hi = int(np.floor((b - self.t0[s]) / self.tau[s]))
        on = 0.0
        for h in range(max(lo, 0), hi + 1):
            if self._laser_on(s, h):
                start = self.t0[s] + h * self.tau[s]
                on += max(0.0, min(b, start + self.tau[s]) - max(a, start))
        return on

    def _overlapping(self, d: int, a: float, b: float) -> list[int]:
        g = self.graph
        edges = self._into[d]
        if g.live is not None:
            col = min(int(0.5 * (a + b) / g.dt), g.live.shape[1] - 1)
            edges = edges[g.live[edges, col]]
        need = self.cfg.min_overlap * (b - a)
        return [int(s) for s in g.src[edges] if self._on_time(int(s), a, b) >= need]

    def slots(self, seconds: float) -> Iterator[SlotEnd]:
        """Every sensor's slots in time order for ``seconds`` of each sensor's time."""
        total = self.cfg.total_frames
        periods = max(1, round(seconds / self.period_s))
        last = periods * total
        heap = [(float(self.t0[i] + self.tau[i]), i, 0) for i in range(self.n)]
        heapq.heapify(heap)
        miss = 1.0 - self.cfg.hit_prob
        while heap:
            b, i, g = heapq.heappop(heap)
            a = b - float(self.tau[i])
            frame, overlapped = None, False
            if self._present(i, a) and self._active(i, g):
                u_drop, u_hit, _ = uniform(self.seed, np.array([i]), np.array([g]), streams=3)[:, 0]
                if u_drop >= self.cfg.drop:
                    srcs = self._overlapping(i, a, b)
                    overlapped = bool(srcs)
                    hit = bool(srcs) and u_hit < 1.0 - miss ** len(srcs)
                    frame = self._frame(i, g, a, srcs if hit else [])
            yield SlotEnd(i, g, b, frame, g % total == total - 1, overlapped)
            if g + 1 < last:
                heapq.heappush(heap, (b + float(self.tau[i]), i, g + 1))

    def _frame(self, i: int, g: int, t: float, srcs: list[int]) -> RoomFrame:
        cam = self.cameras[i]
        if cam is None:  # timing only: no pixels
            empty = np.zeros((0, 0), np.uint16)
            return RoomFrame(i, g, t, empty, empty, np.zeros((0, 0), bool), srcs, bool(srcs))
        depth, clean, mask = cam.frame(t, g, srcs)
        return RoomFrame(i, g, t, depth, clean, mask, srcs, bool(mask.any()))
