"""Benchmark (issue 42): the scene's repair where frames are judged. ``d2sr.Pipeline`` as shipped (the scene
on, flagged frames repaired) with the scene's repair off and on (``SensorLoop.scene_repair``: where a
flagged frame deviates freshly from a still scene that is trusted there, the scene's own depth), per set of
``bench.outside``:

* both L515 views of the outside set, each a cold sequence of 60 frames, the 120 frames corrupted as one
  sequence (seeds 0-119, as ``lab/scene_reference.py`` does): RMSE change over the corrupted frames,
  frames made worse, RMSE change per view over all its frames (clean ones too), pixels moved by more than
  2 cm put back within 1 cm, clean pixels changed (the pixels the corruption left alone, every frame);
* the hand-held D435 whole with every other frame corrupted (a moving sensor: the scene should stay out);
* the clean sequences (L515 dev0 and dev1, the D435, whole): valid pixels moved by more than 5 cm.

``--what returns``: the scene's repair on, trusting a return where the scene returned in ``TRUST_RATE`` of
its clean frames (as shipped until 2026-11-27) or in ``RANGE_RATE`` (``SceneReference(return_rate=...)``).

``--what rare``: the scene's repair keeping any return where the scene seldom returns (as shipped until
2026-11-27) or only one near the depth it returned at (``SceneReference(rare_near=True)``).

``--what reliable``: the scene's repair taking its depth for fresh deviations amid half of their 9x9
neighbours (as shipped until 2026-11-27), or also amid a quarter where the scene nearly always returns
(``SceneReference(reliable_fill=True)``).

``--what subtle``: the scene's repair with a subtle shift explained by the frame before as a moving object's
surface is (``SceneReference(subtle_shifts=False)``) or only within ``SHIFT_M`` of its depth (``True``),
each sequence primed as a recording.

``--what shiftrate``: the scene's repair with shifted windows worked out over pixels that return in 90%
(``SceneReference(shift_rate=0.9)``, as shipped) or 70% (``0.7``) of the clean frames, each sequence primed.

``--what prime``: the scene's repair as shipped, each sequence cold (a live sensor) or primed on its first
``PRIME_FRAMES`` frames, as ``d2sr recover`` repairs a recording (``Pipeline.prime``).

``--what farfill``: the scene's repair taking its depth for fresh far-off returns only among the deviations in
patches (as shipped until 2026-11-27), or for each of them where they alone flag the frame
(``SceneReference(far_fill=True)``), each on a live sensor (cold) and on a recording (primed, as shipped).

``--what rarefill``: the same, with far-off returns filled where the scene returns half the time or more (as
shipped) or also in patches where it seldom returns (``SceneReference(rare_fill=True)``).

``--what offset``: the scene's repair with the returns of a surface shifted as a whole filled with the scene's
median where it trusts it and kept elsewhere (as shipped), or each given its own depth less its window's mean
offset (``SceneReference(offset_fill=True)``), on a live sensor and on a recording.

``--what recording``: ``d2sr recover`` on a recording as shipped today (flagged frames repaired, the scene
primed and kept only if the sensor held still, every setting as it is), with the scene's repair off (the
model alone repairs) and on (as shipped): what the README's results table quotes.

With ``--set n`` (sealed set N), ``--what returns --set o`` (sealed set O), ``--what rare --set r`` (sealed
set R), ``--what reliable --set s`` (sealed set S), ``--what subtle --set u`` (sealed set U), ``--what
shiftrate --set v`` (sealed set V), ``--what farfill --set aa`` (sealed set AA), ``--what rarefill --set
ab`` (sealed set AB) or ``--what offset --set ac`` (sealed set AC), also whether the rule written for it held
(lab/notes/decisions.md, 2026-11-27).

Run:  python -m lab.scene_repair --data ../shared/data [--what returns] [--set X ...] \\
          --json docs/results/scene_repair.json
      python -m lab.scene_repair --data ../shared/data --what recording --set a b c d e f g h i \\
          --json docs/results/recover_recording.json
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from bench.harness import check_output, output_args
from bench.outside.draw import KINDS
from bench.outside.sets import (
    BEFORE_Z,
    JUDGED,
    SEALED,
    SETS,
    clean_sequences,
    every_other,
    outside_set,
    pinned,
    set_data,
    used_models,
)

from d2sr.atomic import write_result
from d2sr.contract.catalog import AUTO_RECOVERY
from d2sr.errors import D2SRError
from d2sr.runtime.pipeline import Pipeline, Repaired
from d2sr.runtime.settings import PRIME_FRAMES

# The scene's rates the modes below name (SceneSettings.range_rate and trust_rate since issue 64).
RANGE_RATE, TRUST_RATE = 0.5, 0.9

Mode = tuple[bool, dict[str, Any]]  # the scene's repair on, and the scene reference's settings
# What came after set O was judged (far-off flags, the seldom-returns keep, the sparser fill), off as it was
# then, so that ``--what returns`` reproduces O's result. ``--what default``: the repair as shipped today.
BEFORE_FAR: dict[str, Any] = {
    "far_area": None,
    "rare_near": False,
    "reliable_fill": False,
    "shift_rate": TRUST_RATE,
}
# What came after set R was judged (the sparser fill), off as it was then: ``--what rare`` reproduces R's.
BEFORE_S: dict[str, Any] = {"reliable_fill": False, "shift_rate": TRUST_RATE}
# What came after set U was judged (shifted windows over pixels returning 70% of the time), as it was then.
BEFORE_V: dict[str, Any] = {"shift_rate": TRUST_RATE}
# The repair's defaults since sets AA, AB and AC (decisions.md, 2026-11-27), off where judged before them.
BEFORE_AA: dict[str, Any] = {"far_fill": False}
BEFORE_AB: dict[str, Any] = {"rare_fill": False}
BEFORE_AC: dict[str, Any] = {"offset_fill": False}
# ``--what farfill`` and ``rarefill`` run each setting on a live sensor and on a recording.
FAR_WHEN = ("cold (a live sensor)", "primed (d2sr recover on a recording)")


def _cold_and_primed(settings: dict[str, dict[str, Any]]) -> dict[str, Mode]:
    """Each of ``settings`` (name -> SceneReference settings), the scene's repair on, per ``FAR_WHEN``."""
    return {f"{m}, {when}": (True, st) for m, st in settings.items() for when in FAR_WHEN}


# Per --what: each mode's name and settings.
WHAT: dict[str, dict[str, Mode]] = {
    "default": {"scene repair off": (False, {}), "scene repair on": (True, {})},
    "returns": {
        f"returns trusted from {TRUST_RATE}": (True, {"return_rate": TRUST_RATE, **BEFORE_FAR}),
        f"returns trusted from {RANGE_RATE}": (True, {"return_rate": RANGE_RATE, **BEFORE_FAR}),
    },
    "rare": {
        "any return kept where the scene seldom returns": (True, {"rare_near": False, **BEFORE_S}),
        "only a return near its depth kept there": (True, {"rare_near": True, **BEFORE_S}),
    },
    "reliable": {
        "fresh deviations amid half their neighbours filled": (True, {"reliable_fill": False, **BEFORE_V}),
        "amid a quarter where the scene nearly always returns": (True, {"reliable_fill": True, **BEFORE_V}),
    },
    "prime": {
        "cold (a live sensor)": (True, {**BEFORE_V}),
        "primed (d2sr recover on a recording)": (True, {**BEFORE_V}),
    },
    "recording": {"the model's repair alone, primed": (False, {}), "as shipped, primed": (True, {})},
    "subtle": {m: (True, {**st, **BEFORE_V}) for m, st in JUDGED["subtle"].items()},
    "shiftrate": {m: (True, st) for m, st in JUDGED["shiftrate"].items()},
    "farfill": _cold_and_primed(
        {
            "far-off returns filled in patches only": {"far_fill": False},
            "each fresh far-off return filled": {"far_fill": True},
        }
    ),
    "rarefill": _cold_and_primed(
        {
            "far-off returns filled where the scene returns half the time": {"rare_fill": False},
            "and in patches where it seldom returns": {"rare_fill": True},
        }
    ),
    "offset": _cold_and_primed(
        {
            "shifted surfaces filled with the scene's median": {"offset_fill": False},
            "with their own depth less their window's offset": {"offset_fill": True},
        }
    ),
}
# The fills judged cold and primed (``_cold_and_primed``), in the order their sets judged them.
FILLS = ("farfill", "rarefill", "offset")
# Each --what runs with the defaults of the time it was judged (``recording``: as shipped today): off windows
# and the far-off fills off before sets Z and AA, the fill where the scene seldom returns before AB, and the
# shifted surfaces' own depths before AC.
for _i, _pins in enumerate((BEFORE_Z | BEFORE_AA, BEFORE_AB, BEFORE_AC)):
    WHAT = pinned(WHAT, _pins, keep={"recording", *FILLS[_i:]})
# Modes whose Pipeline first primes the scene on each sequence's first PRIME_FRAMES frames.
PRIMED = {
    "primed (d2sr recover on a recording)",
    *WHAT["subtle"],
    *WHAT["shiftrate"],
    *WHAT["recording"],
    *(m for w in FILLS for m in WHAT[w] if m.endswith(FAR_WHEN[1])),
}
# Primed modes run as shipped today; the others pin ``prime_still`` off, as they were judged before set X.
AS_SHIPPED = set(WHAT["recording"]).union(*(WHAT[w] for w in FILLS))


def pipeline(scale: float, mode: Mode) -> Pipeline:
    """``d2sr.Pipeline`` as shipped, the scene's repair and reference set as asked."""
    on, settings = mode
    if settings:  # a switch decided since and folded into the code (issue 64)
        raise SystemExit(
            f"{', '.join(settings)}: decided and folded into d2sr; run this mode at 8577bfa (lab/README.md)"
        )
    return Pipeline(scale, scene_repair=on)


def repaired(
    views: list[list[np.ndarray]], scale: float, mode: Mode, primed: bool = False, shipped: bool = False
) -> list[Repaired]:
    """Each view through a fresh Pipeline, in order (``primed``: its scene first learns from the view's
    first ``PRIME_FRAMES``; ``shipped``: keeping it only if the sensor held still, as shipped since set X):
    the repaired frames, views joined."""
    out = []
    for frames in views:
        p = pipeline(scale, mode)
        if primed:
            if not shipped:  # as the primed modes before set X were judged: no longer in d2sr
                raise SystemExit(
                    "priming without the stillness check: run this mode at 8577bfa (lab/README.md)"
                )
            p.prime(frames[:PRIME_FRAMES])
        out += [p.process(f) for f in frames]
    return out


def _primed(mode: str) -> tuple[bool, bool]:
    """How a mode's Pipeline starts: (primed, keeping the primed scene only if the sensor held still)."""
    return mode in PRIMED, mode in AS_SHIPPED


def scored(
    bad: list[np.ndarray], clean: list[np.ndarray], out: list[Repaired], scale: float, views: int
) -> dict:
    """The figures of one mode on a set (``views``: equal parts of the sequence, each a view). The mask's F1
    (pixels repaired against pixels the corruption changed, over the corrupted frames) is reported since set
    AA; the results before it lack it."""
    e_in = e_out = 0.0
    worse = hits = moved = back = changed = pixels = tp = fp = fn = 0
    per = len(bad) // views
    view = np.zeros((views, 2))
    for i, (b, c, r) in enumerate(zip(bad, clean, out, strict=True)):
        o = r.depth
        c64, o64 = c.astype(np.float64), o.astype(np.float64)
        ok = c > 0
        a = float((((b - c64) / scale)[ok] ** 2).sum())
        z = float((((o64 - c64) / scale)[ok] ** 2).sum())
        view[i // per] += (a, z)
        true = b != c
        if true.any():
            hits += 1
            e_in, e_out, worse = e_in + a, e_out + z, worse + int(z > a)
            far = ok & (b > 0) & (np.abs(b - c64) > 0.02 * scale)
            moved += int(far.sum())
            back += int((far & (np.abs(o64 - c64) <= 0.01 * scale)).sum())
            tp, fp, fn = (
                tp + int((r.mask & true).sum()),
                fp + int((r.mask & ~true).sum()),
                fn + int((~r.mask & true).sum()),
            )
        changed += int(((o != b) & ~true).sum())
        pixels += int((~true).sum())
    return {
        "rmse_change": round(float(np.sqrt(e_out / max(e_in, 1e-12)) - 1), 4),
        "frames_worse": worse,
        "interfered": hits,
        "rmse_change_per_view": [round(float(np.sqrt(z / max(a, 1e-12)) - 1), 4) for a, z in view],
        "moved_2cm_put_back": round(back / max(moved, 1), 4),
        "clean_changed": round(changed / max(pixels, 1), 5),
        "mask_f1": round(2 * tp / max(2 * tp + fp + fn, 1), 4),
    }


def mean_worst(sets: dict) -> dict[str, dict[str, float]]:
    """Per mode, over the sets' L515 parts: the RMSE change's mean and worst, and the most frames made worse
    and clean pixels changed on any set."""
    out = {}
    for m in WHAT["recording"]:
        rows = [s["l515"][m] for s in sets.values()]
        change = [r["rmse_change"] for r in rows]
        out[m] = {
            "sets": len(rows),
            "rmse_change_mean": round(float(np.mean(change)), 4),
            "rmse_change_worst": max(change),
            "frames_worse_most": max(r["frames_worse"] for r in rows),
            "clean_changed_most": max(r["clean_changed"] for r in rows),
        }
    return out


def moved_5cm(
    frames: list[np.ndarray], scale: float, mode: Mode, primed: bool = False, shipped: bool = False
) -> float:
    """The share of a clean sequence's valid pixels the Pipeline moves by more than 5 cm."""
    out = repaired([frames], scale, mode, primed, shipped)
    moved = sum(
        int(((f > 0) & (np.abs(o.depth.astype(np.float64) - f) > 0.05 * scale)).sum())
        for f, o in zip(frames, out, strict=True)
    )
    return round(moved / max(sum(int((f > 0).sum()) for f in frames), 1), 6)


def _rmse_held(new: dict, old: dict) -> bool:
    """``new``'s RMSE change over the corrupted frames, and each view's, at most ``old``'s + half a point."""
    views = zip(new["rmse_change_per_view"], old["rmse_change_per_view"], strict=True)
    return bool(new["rmse_change"] <= old["rmse_change"] + 0.005 and all(a <= b + 0.005 for a, b in views))


def n_rule(parts: dict, clean: dict) -> dict[str, bool]:
    still, moving = parts["l515"], parts["d435"]
    off, on = (still[m] for m in WHAT["default"])
    d_off, d_on = (moving[m] for m in WHAT["default"])
    return {
        "1 l515: RMSE change, corrupted frames and each view, at most off's + 0.005": _rmse_held(on, off),
        "2 l515: frames made worse no more than off's": on["frames_worse"] <= off["frames_worse"],
        "3 l515: more of the pixels moved > 2 cm put back than off's": on["moved_2cm_put_back"]
        > off["moved_2cm_put_back"],
        "4 l515: clean pixels changed at most 2%": on["clean_changed"] <= 0.02,
        "5 d435: RMSE change at most off's + 0.005": d_on["rmse_change"] <= d_off["rmse_change"] + 0.005,
        "6 clean sequences: valid pixels moved > 5 cm no more than off's": all(
            c["scene repair on"] <= c["scene repair off"] for c in clean.values()
        ),
    }


def o_rule(parts: dict, clean: dict, what: str = "returns") -> dict[str, bool]:
    """Set O's rule (``--what returns``); set R's (``--what rare``), S's (``--what reliable``) and U's repair
    (``--what subtle``) are the same items."""
    still = parts["l515"]
    old_name, new_name = WHAT[what]
    old, new = still[old_name], still[new_name]
    return {
        "1 l515: RMSE change, corrupted frames and each view, at most the old setting's + 0.005": _rmse_held(
            new, old
        ),
        "2 l515: frames made worse no more than the old setting's": new["frames_worse"]
        <= old["frames_worse"],
        "3 l515: at least as many pixels moved > 2 cm put back": new["moved_2cm_put_back"]
        >= old["moved_2cm_put_back"],
        "4 l515: clean pixels changed at most the old setting's + 0.0005": new["clean_changed"]
        <= old["clean_changed"] + 0.0005,
        "5 clean sequences: valid pixels moved > 5 cm no more than the old setting's": all(
            c[new_name] <= c[old_name] for c in clean.values()
        ),
    }


def v_rule(parts: dict, clean: dict) -> dict[str, bool]:
    """Set V's repair items (``--what shiftrate``, decisions.md, 2026-11-27): frames the wider shifted
    windows newly flag get repaired, so up to 2 more may come out worse; the rest as sets O-S."""
    still = parts["l515"]
    old_name, new_name = WHAT["shiftrate"]
    old, new = still[old_name], still[new_name]
    return {
        "4a l515: RMSE change, corrupted frames and each view, at most the old setting's + 0.005": _rmse_held(
            new, old
        ),
        "4b l515: clean pixels changed at most the old setting's + 0.0005": new["clean_changed"]
        <= old["clean_changed"] + 0.0005,
        "4c l515: frames made worse at most the old setting's + 2": new["frames_worse"]
        <= old["frames_worse"] + 2,
        "4d clean sequences: valid pixels moved > 5 cm no more than the old setting's": all(
            c[new_name] <= c[old_name] for c in clean.values()
        ),
    }


def fill_rule(parts: dict, clean: dict, what: str = "farfill") -> dict[str, bool]:
    """Set AA's rule (``--what farfill``, decisions.md, 2026-11-27): with every fresh far-off return of a
    frame they flag filled, cold and primed alike, nothing is worse than with the fill in patches only; and
    primed, more of the pixels moved by more than 2 cm are put back. Set AB's (``--what rarefill``) and AC's
    (``--what offset``) are the same, for the fill where the scene seldom returns and for shifted surfaces."""
    out = {}
    for when in FAR_WHEN:
        old_name, new_name = (m for m in WHAT[what] if m.endswith(when))
        old, new = parts["l515"][old_name], parts["l515"][new_name]
        d_old, d_new = parts["d435"][old_name], parts["d435"][new_name]
        tag = when.split(" ")[0]
        out |= {
            f"1 {tag} l515: RMSE change, corrupted frames and each view, at most the old setting's + 0.005": (
                _rmse_held(new, old)
            ),
            f"2 {tag} l515: frames made worse no more than the old setting's": new["frames_worse"]
            <= old["frames_worse"],
            f"3 {tag} l515: pixels moved > 2 cm put back, "
            + ("more than" if tag == "primed" else "at least as many as")
            + " the old setting's": (
                new["moved_2cm_put_back"] > old["moved_2cm_put_back"]
                if tag == "primed"
                else new["moved_2cm_put_back"] >= old["moved_2cm_put_back"]
            ),
            f"4 {tag} l515: clean pixels changed at most the old setting's + 0.0005": new["clean_changed"]
            <= old["clean_changed"] + 0.0005,
            f"5 {tag} d435: RMSE change at most the old setting's + 0.005": d_new["rmse_change"]
            <= d_old["rmse_change"] + 0.005,
            f"6 {tag} clean sequences: valid pixels moved > 5 cm no more than the old setting's": all(
                c[new_name] <= c[old_name] for c in clean.values()
            ),
        }
    return out


# Per --what, the sealed set it was written to judge and that set's rule (decisions.md, 2026-11-27).
RULES: dict[str, tuple[str, Callable[[dict, dict], dict[str, bool]]]] = {
    "default": ("n", n_rule),
    "returns": ("o", o_rule),
    "rare": ("r", functools.partial(o_rule, what="rare")),
    "reliable": ("s", functools.partial(o_rule, what="reliable")),
    "subtle": ("u", functools.partial(o_rule, what="subtle")),
    "shiftrate": ("v", v_rule),
    "farfill": ("aa", fill_rule),
    "rarefill": ("ab", functools.partial(fill_rule, what="rarefill")),
    "offset": ("ac", functools.partial(fill_rule, what="offset")),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--what", default="default", choices=sorted(WHAT))
    ap.add_argument("--set", dest="sets", nargs="*", default=None, choices=sorted(SETS),
                    help="sets to run [every set but the sealed ones]")  # fmt: skip
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    sets = args.sets or sorted(set(SETS) - SEALED)
    try:
        whole = clean_sequences(args.data)
        l515 = outside_set(args.data)
    except D2SRError as exc:
        ap.error(str(exc))
    d435 = whole["d435"][0]
    modes = WHAT[args.what]
    result: dict = {
        "benchmark": f"issue 42: the scene's repair where frames are judged ({', '.join(modes)})",
        "sets": {},
    }
    for w in sets:
        bad = every_other(l515, 4000.0, w)
        bad_d435 = every_other(d435, 1000.0, w)
        result["sets"][w] = {
            "kinds": list(KINDS[w]),
            "status": set_data(w)["status"],
            "l515": {
                m: scored(bad, l515, repaired([bad[:60], bad[60:]], 4000.0, r, *_primed(m)), 4000.0, 2)
                for m, r in modes.items()
            },
            "d435": {
                m: scored(bad_d435, d435, repaired([bad_d435], 1000.0, r, *_primed(m)), 1000.0, 1)
                for m, r in modes.items()
            },
        }
        print(
            w,
            {
                p: {m: v["rmse_change"] for m, v in x.items()}
                for p, x in result["sets"][w].items()
                if p in ("l515", "d435")
            },
            flush=True,
        )
    clean = {
        n: {m: moved_5cm(fr, s, r, *_primed(m)) for m, r in modes.items()} for n, (fr, s) in whole.items()
    }
    result["clean_moved_5cm"] = clean
    if args.what in RULES and RULES[args.what][0] in sets:
        judged, rule = RULES[args.what]
        result["rule"] = rule(result["sets"][judged], clean)
    if args.what == "recording":
        result["l515_mean_worst"] = mean_worst(result["sets"])
    data = {
        "sets": f"sets {', '.join(w.upper() for w in sets)} of bench/outside, every other frame",
        "frames": "120 real L515 frames (dev0 after the person has left, dev1) and the hand-held D435 (193)",
    }
    print(write_result(result, args.json, models=used_models(AUTO_RECOVERY), data=data))


if __name__ == "__main__":
    main()
