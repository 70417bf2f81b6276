"""The outside sets by name (``SETS``), what each has been used for (``STATUS``), and the real frames they
corrupt."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
from bench.outside.draw import KINDS, SALTS, SEED
from bench.outside.sets_a_i import (
    beat_interference,
    bloom_interference,
    crosstalk_interference,
    echo_interference,
    outside_interference,
    projector_interference,
    sparse_interference,
    tof_bias_interference,
    tof_interference,
)
from bench.outside.sets_k_s import (
    blotch_interference,
    dark_interference,
    flood_interference,
    rain_interference,
    skew_interference,
    spark_interference,
    veil_interference,
    walk_interference,
    window_interference,
)
from bench.outside.sets_t_ac import (
    block_interference,
    cwtof_interference,
    echo_grain_interference,
    flare_interference,
    fold_interference,
    halo_interference,
    haze_interference,
    ripple_interference,
    shifted_surface_interference,
    stair_interference,
)

from d2sr.contract.catalog import AUTO_RECOVERY, DEFAULT_RECOVERY, DETECTOR, TEMPORAL_RECOVERY

SETS = {
    "a": outside_interference,
    "b": crosstalk_interference,
    "c": echo_interference,
    "d": bloom_interference,
    "e": beat_interference,
    "f": projector_interference,
    "g": tof_interference,
    "h": tof_bias_interference,
    "i": sparse_interference,
    "k": flood_interference,
    "l": skew_interference,
    "m": walk_interference,
    "n": window_interference,
    "o": blotch_interference,
    "p": spark_interference,
    "q": rain_interference,
    "r": dark_interference,
    "s": veil_interference,
    "t": stair_interference,
    "u": cwtof_interference,
    "v": halo_interference,
    "w": flare_interference,
    "x": block_interference,
    "y": haze_interference,
    "z": ripple_interference,
    "aa": echo_grain_interference,
    "ab": fold_interference,
    "ac": shifted_surface_interference,
}
# Sets only an explicit --set runs (D-I were, each until the decision it was written for;
# lab/notes/decisions.md).
SEALED: set[str] = set()
# Sets written for one measurement of their own (K-S: settings of the scene, on the D435 too), which the
# scripts that go over every set leave out: their results would be new files no summary reads.
OWN: set[str] = {
    *("k", "l", "m", "n", "o", "p", "q", "r", "s", "t", "u", "v", "w", "x", "y", "z"),
    *("aa", "ab", "ac"),
}
# What each set has been used for (lab/notes/decisions.md). A set that chose or judged anything is a
# development set; a set is held out only while sealed, until the one measurement it was written for.
STATUS = {
    "a": "development: chose the default's mask logit and REPAIR_PASSES = 2; judged about eight trials",
    "b": "development: written to check a threshold read off set A; judged trials since",
    "c": "development: written to judge what sets A and B chose; judged trials since",
    "d": "development: sealed until 2026-11-26, when it confirmed unet8-shell (chosen on A, B); open since",
    "e": "development: sealed until 2026-11-26, when it decided unet32 (decisions.md); open since",
    "f": "development: sealed until 2026-11-26, when it decided recover's default auto (decisions.md); "
    "open since",
    "g": "development: sealed until 2026-11-26, when it judged the scene's repair (it failed; "
    "decisions.md); open since",
    "h": "development: sealed until 2026-11-26, when it judged the scene's shifted windows (they failed; "
    "decisions.md); open since",
    "i": "development: sealed until 2026-11-26, when it judged the guard's lone-return rule (it held; "
    "decisions.md); open since",
    "k": "development: sealed until 2026-11-27, when it judged the scene's stillness gate (it held; "
    "decisions.md); open since",
    "l": "development: sealed until 2026-11-27, when it judged the scene's 16-stripe upkeep (it held; "
    "decisions.md); open since",
    "m": "development: sealed until 2026-11-27, when it judged the scene's shifted windows as flags (they "
    "held; decisions.md); open since",
    "n": "development: sealed until 2026-11-27, when it judged the scene's repair as a default (it held; "
    "decisions.md); open since",
    "o": "development: sealed until 2026-11-27, when it judged the scene's repair trusting returns from "
    "RANGE_RATE (it held; decisions.md); open since",
    "p": "development: sealed until 2026-11-27, when it judged far-off returns as flags (they held; "
    "decisions.md); open since",
    "q": "development: sealed until 2026-11-27, when it judged far-off returns over every return (they "
    "held; decisions.md); open since",
    "r": "development: sealed until 2026-11-27, when it judged the scene's repair keeping seldom-seen "
    "returns only near their depth (it held; decisions.md); open since",
    "s": "development: sealed until 2026-11-27, when it judged the scene's repair filling sparser patches "
    "where the scene nearly always returns (it held; decisions.md); open since",
    "t": "development: sealed until 2026-11-27, when it judged priming a recording's scene on the frames "
    "ahead (it held; decisions.md); open since",
    "u": "development: sealed until 2026-11-27, when it judged subtle shifts explained only within SHIFT_M "
    "(it failed; decisions.md); open since",
    "v": "development: sealed until 2026-11-27, when it judged shifted windows over pixels returning 70% of "
    "the time (it held; decisions.md); open since",
    "w": "development: sealed until 2026-11-27, when it judged those windows waiting for a full ring (it "
    "held; decisions.md); open since",
    "x": "development: sealed until 2026-11-27, when it judged keeping a primed scene only where the sensor "
    "held still (it held; decisions.md); open since",
    "y": "development: sealed until 2026-11-27, when it judged keeping a detector's flag the scene cannot "
    "vouch against (it failed; decisions.md); open since",
    "z": "development: sealed until 2026-11-27, when it judged off windows flagging frames (it held; "
    "decisions.md); open since",
    "aa": "development: sealed until 2026-11-27, when it judged the scene's repair filling every fresh "
    "far-off return of a frame they flag (it held; decisions.md); open since",
    "ab": "development: sealed until 2026-11-27, when it judged the scene's repair filling far-off returns "
    "in patches where it seldom returns (it held; decisions.md); open since",
    "ac": "development: sealed until 2026-11-27, when it judged the scene's repair giving a shifted "
    "surface's returns their own depth less their window's offset (it held; decisions.md); open since",
}
# The scene settings sets U and V judged, per mode name (lab/scene_gate.py's flags, lab/scene_repair.py's
# repair): one place, so both benches run the same modes.
JUDGED: dict[str, dict[str, dict[str, Any]]] = {
    "subtle": {
        "subtle shifts explained as motion": {"subtle_shifts": False},
        "subtle shifts explained within SHIFT_M": {"subtle_shifts": True},
    },
    "shiftrate": {
        "shifted windows over pixels returning 90% of the time": {"shift_rate": 0.9},
        "shifted windows over pixels returning 70% of the time": {"shift_rate": 0.7},
    },
}
# Off windows flag frames since set Z (decisions.md, 2026-11-27): what the measurements before it ran without.
BEFORE_Z: dict[str, Any] = {"off_area": None}


def pinned(
    table: dict[str, dict[str, tuple[bool, dict[str, Any]]]], pins: dict[str, Any], keep: set[str]
) -> dict[str, dict[str, tuple[bool, dict[str, Any]]]]:
    """A benchmark's modes (--what -> mode -> (switch, SceneReference settings)) with ``pins`` under every
    mode's own settings but those of ``keep``: the measurements made before a default changed run as they
    were made."""
    return {
        what: modes if what in keep else {m: (on, {**pins, **st}) for m, (on, st) in modes.items()}
        for what, modes in table.items()
    }


# Said on every result that uses the real L515 frames (issue 45).
CALIBRATION = (
    "the simulator's L515 noise model, which generated the models' training data, was fitted to the same "
    "dev0 and dev1 captures"
)


def set_data(which: str) -> dict[str, str]:
    """The ``data`` a result on set ``which`` records: its name, frames, status and the calibration
    overlap."""
    return {
        "set": f"outside set {which.upper()} ({', '.join(KINDS[which])}), bench/outside",
        "frames": "120 real L515 frames (dev0 after the person has left, dev1), every other one corrupted",
        "status": "sealed" if which in SEALED else STATUS[which],
        "calibration": CALIBRATION,
    }


def used_models(model: str | None) -> list[str]:
    """The models a ``d2sr recover --model MODEL`` run (with its detector) reads, to hash them."""
    if model in (None, AUTO_RECOVERY):  # auto: the temporal model, and the single-frame one it falls back on
        return [DETECTOR, DEFAULT_RECOVERY, TEMPORAL_RECOVERY]
    return [DETECTOR, model]


def open_sets() -> list[str]:
    """The sets the scripts that go over every set take: all but the sealed ones."""
    return sorted(set(SETS) - SEALED - OWN)


def kind(which: str, seed: int) -> str:
    """The model of set ``which`` that corrupts the frame of ``seed``: the set's function's first draw."""
    return KINDS[which][0 if np.random.default_rng([seed, SALTS[which]]).random() < 0.5 else 1]


def every_other(clean: list[np.ndarray], scale: float, which: str = "a") -> list[np.ndarray]:
    """The sequence with every other frame (the odd ones) corrupted by set ``which``'s interference
    (``SETS``)."""
    corrupt = SETS[which]
    return [corrupt(f, scale, SEED + i) if i % 2 else f for i, f in enumerate(clean)]


#: The cameras of the outside set's frames, in order (``outside_set``).
OUTSIDE_CAMERAS = ["dev0"] * 60 + ["dev1"] * 60


#: The clean real sequences, whole: name, folder under the data, units per metre.
CLEAN_SEQUENCES = (("dev0", "l515/dev0", 4000.0), ("dev1", "l515/dev1", 4000.0), ("d435", "d435", 1000.0))


def clean_sequences(data: Path) -> dict[str, tuple[list[np.ndarray], float]]:
    """``CLEAN_SEQUENCES``' frames in order, each with its scale: L515 dev0 (a person walks through its first
    frames) and dev1, and the hand-held D435."""
    from d2sr.frames import open_frames

    return {n: ([f.depth for f in open_frames(data / p)], s) for n, p, s in CLEAN_SEQUENCES}


def outside_set(data: Path) -> list[np.ndarray]:
    """The 120 clean L515 frames of the outside set: dev0 after the person has left, and dev1
    (``OUTSIDE_CAMERAS``)."""
    frames = []
    for cap, skip in (("dev0", 60), ("dev1", 0)):
        files = sorted((data / "l515" / cap).glob("*.png"))[skip : skip + 60]
        frames += [cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files]
    return frames


def worst_case(data: Path, n: int = 60) -> list[tuple[str, np.ndarray]]:
    """The speed benchmarks' frames: the first ``n`` L515 dev1 frames (file name, frame), every one
    corrupted by ``outside_interference`` (so recover's every pass runs on each)."""
    files = sorted((data / "l515" / "dev1").glob("*.png"))[:n]
    if len(files) < n:
        raise SystemExit(f"{data}/l515/dev1: needs {n} frames, found {len(files)}")
    return [
        (f.name, outside_interference(cv2.imread(str(f), cv2.IMREAD_UNCHANGED), 4000.0, 7 + i))
        for i, f in enumerate(files)
    ]
