"""The multi-sensor timing world: who emits when, which frames get interfered, what each detector says.

Time runs in slots of ``1 / fps`` seconds, ``total_frames`` slots to a period (1 s at 30 fps). Each
sensor has its own phase (its periods are not aligned with anyone's) and clock drift (ppm), so slot
boundaries of different sensors never line up exactly. In each period the sensor's laser delivers
``n`` frames in consecutive slots from its controller's offset, wrapping at the period's end; it also
runs for ``setup`` slots before the first frame (the L515's trigger start-up), delivering nothing then
but still lighting up everyone who overlaps it.

A frame of sensor ``d`` is interfered when the laser of ``k >= 1`` sensors that overlap ``d`` (live edges
``s -> d`` of the overlap graph) was on during at least ``min_overlap`` of the frame's time; it then is
hit with probability ``1 - (1 - hit_prob) ** k``. A detector with ``recall`` and ``false_alarm`` turns
truth into the flags the controller sees; frames can drop (never delivered, reported as clean).

Time is stepped in ``substeps`` per slot; each step is a handful of numpy operations over all sensors
and edges, so 1,000 sensors stay cheap. Randomness is drawn per (sensor, frame) from a counter-based
hash, so runs that differ only in their controllers share their luck.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from pydantic import Field, model_validator

from d2sr.config import Settings
from d2sr.desync import TOTAL_FRAMES, Controller, make_controller
from d2sr.desync.oracle import OracleController, OracleScheduler
from d2sr.errors import ConfigError
from d2sr.sim.counter_rng import uniform
from d2sr.sim.overlap import OverlapGraph

__all__ = ["TimingRun", "TimingSettings", "simulate"]


class TimingSettings(Settings):
    """Settings of the timing world (defaults: an L515 at 30 fps running half its frames)."""

    total_frames: int = Field(TOTAL_FRAMES, gt=0, description="slots per observation period")
    active_frames: int = Field(15, gt=0, description="frames per period (n) for controllers built by name")
    fps: float = Field(30.0, gt=0, description="slot rate; a period lasts total_frames / fps seconds")
    setup: int = Field(2, ge=0, description="laser-on slots before the first frame of a window")
    hit_prob: float = Field(0.9, ge=0, le=1, description="chance an overlapped frame is corrupted")
    min_overlap: float = Field(0.25, gt=0, le=1, description="fraction of a frame's time that counts")
    recall: float = Field(0.9, ge=0, le=1, description="detector: P(flag | interfered)")
    false_alarm: float = Field(0.01, ge=0, le=1, description="detector: P(flag | clean)")
    drop: float = Field(0.0, ge=0, le=1, description="chance a frame is never delivered")
    drift_ppm: float = Field(50.0, ge=0, description="clock drift drawn uniformly in +-drift_ppm")
    substeps: int = Field(8, ge=1, le=64, description="time steps per slot")

    @model_validator(mode="after")
    def _window_fits(self) -> TimingSettings:
        if self.active_frames > self.total_frames:
            raise ValueError(f"active_frames ({self.active_frames}) > total_frames ({self.total_frames})")
        if self.setup >= self.total_frames:
            raise ValueError(f"setup ({self.setup}) must be shorter than the period ({self.total_frames})")
        return self


@dataclass
class TimingRun:
    """Per sensor and period: frames captured, truly interfered, flagged; the offset used."""

    config: TimingSettings
    graph: OverlapGraph
    captured: np.ndarray
    interfered: np.ndarray
    detected: np.ndarray
    true_detected: np.ndarray
    offsets: np.ndarray
    active_frames: np.ndarray
    phases: np.ndarray
    drifts: np.ndarray
    #: Optional per-frame record (sensors x slots): 1 = captured clean, 2 = interfered, 0 = no frame.
    frames: np.ndarray | None = None
    #: With ``frames`` and at most 63 sensors: bit i set when sensor i's laser overlapped the frame.
    hits: np.ndarray | None = None

    @property
    def periods(self) -> int:
        return self.captured.shape[1]

    def ratio(self, sensors: np.ndarray | None = None, start: int = 0, stop: int | None = None) -> float:
        """Interfered / captured frames over the chosen sensors and periods (0 when nothing captured)."""
        rows = slice(None) if sensors is None else sensors
        cap = self.captured[rows, start:stop].sum()
        return float(self.interfered[rows, start:stop].sum() / cap) if cap else 0.0


def _controllers(
    controllers: str | Sequence[Controller], n: int, cfg: TimingSettings, seed: int
) -> list[Controller]:
    if isinstance(controllers, str):
        return [
            make_controller(controllers, cfg.total_frames, cfg.active_frames, seed=seed * 1_000_003 + i)
            for i in range(n)
        ]
    ctrls = list(controllers)
    if len(ctrls) != n:
        raise ConfigError(f"{len(ctrls)} controllers for {n} sensors")
    for c in ctrls:
        if c.total_frames != cfg.total_frames:
            raise ConfigError(f"controller period {c.total_frames} != world period {cfg.total_frames}")
    return ctrls


@functools.lru_cache(maxsize=4096)
def _window_slots(offset: int, n: int, total: int) -> np.ndarray:
    """The slots of a window in time order (cached)."""
    return (offset + np.arange(n)) % total


@functools.lru_cache(maxsize=4096)
def _masks(offset: int, n: int, setup: int, total: int) -> tuple[np.ndarray, np.ndarray]:
    """(frame slots, laser-on slots) of one period as boolean rows (cached: read-only, copied on use)."""
    active = np.zeros(total, dtype=bool)
    active[(offset + np.arange(n)) % total] = True
    laser = np.zeros(total, dtype=bool)
    laser[(offset - setup + np.arange(min(n + setup, total))) % total] = True
    return active, laser


class Clocks(NamedTuple):
    """Each sensor's clock: ``phases`` (seconds into the first period when it starts) and ``drifts``
    (fractional clock error); either None: drawn at random from the run's seed."""

    phases: np.ndarray | None = None
    drifts: np.ndarray | None = None


def simulate(
    graph: OverlapGraph,
    controllers: str | Sequence[Controller],
    config: TimingSettings | None = None,
    duration_s: float = 60.0,
    seed: int = 0,
    clocks: Clocks | None = None,
    record_frames: bool = False,
    progress: Callable[[float], None] | None = None,
) -> TimingRun:
    """Run every sensor's controller in closed loop for ``duration_s`` seconds of each sensor's time.

    ``controllers`` is a registry name (one controller per sensor, seeded from ``seed``) or one
    controller per sensor. ``clocks``: each sensor's phase and drift [random draws from ``seed``].
    """
    phases, drifts = clocks if clocks is not None else Clocks()
    cfg = config or TimingSettings()
    if duration_s <= 0 or not np.isfinite(duration_s):
        raise ConfigError(f"duration_s must be positive, got {duration_s}")
    n_sens, total, setup, k_sub = graph.n, cfg.total_frames, cfg.setup, cfg.substeps
    ctrls = _controllers(controllers, n_sens, cfg, seed)
    period_s = total / cfg.fps
    periods = round(duration_s / period_s)
    if periods < 1:
        raise ConfigError(f"duration_s={duration_s} is shorter than one period ({period_s:g} s)")
    rng = np.random.default_rng(seed)
    t0 = rng.uniform(0, period_s, n_sens) if phases is None else np.asarray(phases, dtype=float)
    drift = rng.uniform(-1, 1, n_sens) * cfg.drift_ppm * 1e-6 if drifts is None else np.asarray(drifts, float)
    if t0.shape != (n_sens,) or drift.shape != (n_sens,):
        raise ConfigError(f"phases and drifts need one value per sensor ({n_sens})")
    tau = (1.0 + drift) / cfg.fps
    slots = periods * total

    n_act = np.array([c.active_frames for c in ctrls], dtype=np.int64)
    offset = np.array([c.offset for c in ctrls], dtype=np.int64)
    active = np.zeros((n_sens, total), dtype=bool)
    laser = np.zeros((n_sens, total), dtype=bool)
    for i in range(n_sens):
        active[i], laser[i] = _masks(int(offset[i]), int(n_act[i]), setup, total)
    scheduler = (
        OracleScheduler(
            graph.union_pairs(),
            t0,
            tau,
            n_act,
            setup,
            total,
            cfg.hit_prob,
            seed,
        )
        if any(getattr(c, "global_knowledge", False) for c in ctrls)
        else None
    )

    shape = (n_sens, periods)
    captured = np.zeros(shape, dtype=np.int32)
    interfered = np.zeros(shape, dtype=np.int32)
    detected = np.zeros(shape, dtype=np.int32)
    true_det = np.zeros(shape, dtype=np.int32)
    offsets = np.zeros(shape, dtype=np.int64)
    offsets[:, 0] = offset
    frames = np.zeros((n_sens, slots), dtype=np.int8) if record_frames else None
    hits = np.zeros((n_sens, slots), dtype=np.int64) if record_frames and n_sens <= 63 else None

    # edges sorted by destination (CSR): finishing a frame touches only the edges into that sensor
    by_dst = np.argsort(graph.dst, kind="stable")
    src, dst = graph.src[by_dst], graph.dst[by_dst]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(dst, minlength=n_sens))])
    # schedules as contiguous rows per step: one cheap row view per time step instead of a strided column
    live_rows = None if graph.live is None else np.ascontiguousarray(graph.live[by_dst].T)
    here_rows = None if graph.present is None else np.ascontiguousarray(graph.present.T)
    laser_flat = laser.reshape(-1)  # a view: _end_period edits laser rows in place
    row_base = np.arange(n_sens) * total
    edge_cnt = np.zeros(src.size, dtype=np.int32)
    sub_cnt = np.zeros(n_sens, dtype=np.int32)
    flags = np.zeros((n_sens, total), dtype=bool)
    windows = _Windows(ctrls, flags, offset, n_act, active, laser, offsets, cfg)
    g_prev = np.full(n_sens, -1, dtype=np.int64)
    miss = 1.0 - cfg.hit_prob
    step = period_s / total / k_sub
    n_steps = int(np.ceil(float(np.max(t0 + slots * tau)) / step)) + 1
    report_every = max(1, n_steps // 200)

    inv_tau, t0_slots = 1.0 / tau, t0 / tau
    # live edges, sorted by destination, and their CSR; a static graph has them all, always
    live_step, live_idx, live_src, l_indptr = -1, np.arange(src.size), src, indptr
    was_live = np.zeros(src.size, dtype=bool)
    for s in range(n_steps):
        t = (s + 0.5) * step
        g = np.floor(t * inv_tau - t0_slots).astype(np.int64)
        sched = int(t / graph.dt)
        here = None if here_rows is None else here_rows[min(sched, len(here_rows) - 1)]
        changed = g != g_prev
        done = np.flatnonzero(changed & (g_prev >= 0) & (g_prev < slots))
        if done.size:
            gp = g_prev[done]
            slot, per = gp % total, gp // total
            was_active = active[done, slot] if here is None else active[done, slot] & here[done]
            pos, owner = _edges_into(done, l_indptr)
            e_idx = live_idx[pos]
            need = np.maximum(1.0, cfg.min_overlap * sub_cnt[done])
            hit_e = edge_cnt[e_idx] >= need[owner]
            k_hit = np.bincount(owner, weights=hit_e, minlength=done.size)
            u_drop, u_hit, u_det = uniform(seed, done, gp, streams=3)
            cap = was_active & (u_drop >= cfg.drop)
            bad = cap & (u_hit < 1.0 - miss**k_hit)
            det = cap & np.where(bad, u_det < cfg.recall, u_det < cfg.false_alarm)
            captured[done, per] += cap
            interfered[done, per] += bad
            detected[done, per] += det
            true_det[done, per] += det & bad
            flags[done, slot] = det
            if frames is not None:
                frames[done, gp] = cap.astype(np.int8) + bad
            if hits is not None:
                bits = np.zeros(done.size, dtype=np.int64)
                np.bitwise_or.at(bits, owner[hit_e], np.left_shift(1, live_src[pos][hit_e]).astype(np.int64))
                hits[done, gp] = np.where(cap, bits, 0)
            for i in done[slot == total - 1]:
                _end_period(i, windows, g, scheduler, here, t)
        # a new frame starts counting from zero (also a sensor's very first frame)
        if done.size == np.count_nonzero(changed):  # the usual case: only finished frames restart
            if done.size:
                edge_cnt[e_idx] = 0
                sub_cnt[done] = 0
        else:
            fresh = np.flatnonzero(changed)
            edge_cnt[live_idx[_edges_into(fresh, l_indptr)[0]]] = 0
            sub_cnt[fresh] = 0
        if live_rows is not None and sched != live_step:
            # the schedule moves once per dt: index only the live edges (a robot meets hundreds over a run)
            live_step = sched
            row = live_rows[min(sched, len(live_rows) - 1)]
            edge_cnt[row & ~was_live] = 0  # an edge coming back starts from zero
            was_live = row
            live_idx = np.flatnonzero(row)  # still sorted by destination
            live_src = src[live_idx]
            l_indptr = np.concatenate([[0], np.cumsum(np.bincount(dst[live_idx], minlength=n_sens))])
        # lasers run on after a sensor's last recorded period, so every recorded frame has full company
        on = (g >= 0) & laser_flat.take(row_base + g % total)
        if here is not None:
            on &= here
        if live_rows is None:
            edge_cnt += on.take(src)
        else:
            edge_cnt[live_idx] += on.take(live_src)
        sub_cnt += 1
        g_prev = g
        if progress is not None and s % report_every == 0:
            progress(s / n_steps)
    if progress is not None:
        progress(1.0)
    return TimingRun(
        cfg, graph, captured, interfered, detected, true_det, offsets, n_act, t0, drift, frames, hits
    )


def _edges_into(sensors: np.ndarray, indptr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the edges into each of ``sensors`` (CSR by destination) and the position that owns each."""
    starts = indptr[sensors]
    counts = indptr[sensors + 1] - starts
    owner = np.repeat(np.arange(sensors.size), counts)
    first = np.cumsum(counts) - counts
    return np.arange(owner.size) + np.repeat(starts - first, counts), owner


@dataclass
class _Windows:
    """Every sensor's controller and window as the run keeps them (arrays edited in place): the period's
    flags, window offset and length, active slots and laser slots, and the offsets logged per period."""

    ctrls: list[Controller]
    flags: np.ndarray
    offset: np.ndarray
    n_act: np.ndarray
    active: np.ndarray
    laser: np.ndarray
    offsets: np.ndarray
    cfg: TimingSettings


def _end_period(
    i: int, w: _Windows, g: np.ndarray, scheduler: OracleScheduler | None, here: np.ndarray | None, now: float
) -> None:
    """Sensor i finished a period: hand its flags to its controller and apply the new window."""
    ctrls, flags, offset, n_act, active, laser, offsets, cfg = (
        w.ctrls, w.flags, w.offset, w.n_act, w.active, w.laser, w.offsets, w.cfg
    )  # fmt: skip
    total = cfg.total_frames
    nxt = int(g[i]) // total  # the period that starts now
    window = flags[i].take(_window_slots(int(offset[i]), int(n_act[i]), total))
    flags[i] = False
    ctrl = ctrls[i]
    if here is None or here[i]:
        new = ctrl.update(window)
        if scheduler is not None and isinstance(ctrl, OracleController):
            ctrl.assign(scheduler.offset_for(i, now, offset))
            new = ctrl.offset
        if new != offset[i]:
            offset[i] = new
            active[i], laser[i] = _masks(new, int(n_act[i]), cfg.setup, total)
    if nxt < offsets.shape[1]:
        offsets[i, nxt] = offset[i]
