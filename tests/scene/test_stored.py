"""A stored scene (d2sr.scene.stored, ``d2sr scene learn``, ``--scene-from``): one file of data, never code;
refused with one line when it is not one or does not fit the recording; a reference started from it is warm
at once and still takes lasting change in."""

from __future__ import annotations

import json
import pickle

import cv2
import numpy as np
import pytest

from d2sr.errors import InputError
from d2sr.scene import SceneReference
from d2sr.scene.stored import StoredScene, learn_scene
from helpers import d2sr_inprocess

SCALE = 4000.0


def _wall(rng: np.random.Generator, shape: tuple[int, int] = (96, 128)) -> np.ndarray:
    z = 2.0 + np.linspace(0, 1, shape[1])[None].repeat(shape[0], 0) + rng.normal(0, 0.005, shape)
    z[:8] = 0
    return np.rint(z * SCALE).astype(np.uint16)


def _truth(shape: tuple[int, int] = (96, 128)) -> np.ndarray:
    """The wall ``_wall`` reads with noise (metres; 0 where it has no return)."""
    z = 2.0 + np.linspace(0, 1, shape[1])[None].repeat(shape[0], 0)
    z[:8] = 0
    return z


def _learned(n: int = 6) -> StoredScene:
    rng = np.random.default_rng(0)
    frames = [_wall(rng) for _ in range(n)]
    return learn_scene(lambda: iter(frames), SCALE, "walls", n)


def test_a_stored_scene_round_trips_and_starts_a_reference_warm(tmp_path):
    stored = _learned()
    stored.save(tmp_path / "s.npz")
    back = StoredScene.load(tmp_path / "s.npz")
    assert (
        back.shape == (96, 128) and back.frames == 6 and back.depth_scale == SCALE and back.source == "walls"
    )
    assert np.array_equal(back.stats.nz_median, stored.stats.nz_median)
    ref = SceneReference.from_stored(back)
    rng = np.random.default_rng(1)
    first = ref.evidence(f := _wall(rng))
    assert first.ready and first.usable  # warm, and the first frame that matches it shows the sensor still
    ref.add(f)
    hit = _wall(rng)
    hit[40:70, 30:80] -= int(0.04 * SCALE)  # a patch 4 cm near
    ev = ref.evidence(hit)
    assert ev.usable and ev.evident and ev.mask[40:70, 30:80].mean() > 0.8


def test_a_stored_scene_s_gate_stays_shut_on_a_first_frame_that_does_not_match_it():
    """The gate opens on a stored scene's first frame only when that frame matches it (the sensor where it
    was learned); a first frame from elsewhere leaves the detector to decide alone."""
    rng = np.random.default_rng(4)
    ref = SceneReference.from_stored(_learned())
    moved = _wall(rng)
    moved[20:80, 10:120] -= int(0.5 * SCALE)  # most of the view half a metre nearer: not where it was learned
    assert ref.evidence(moved).ready and not ref.evidence(moved).usable


def test_a_stored_scene_takes_lasting_change_in_and_is_not_re_summarized(tmp_path):
    ref = SceneReference.from_stored(_learned())
    rng = np.random.default_rng(2)
    chair = np.s_[20:40, 20:60]  # a chair put 30 cm in front of the wall, to stay
    dense = []
    for _ in range(40):
        f = _wall(rng)
        f[chair] -= int(0.3 * SCALE)
        ev = ref.evidence(f)
        dense.append(ev.dense)
        if not ev.evident:
            ref.add(f)
    assert dense[1] > 0.05 and dense[-1] < 0.0005  # deviated, then it is the scene (``persist`` frames)


def test_what_is_not_a_stored_scene_is_one_line_and_runs_nothing(tmp_path):
    ran = tmp_path / "ran"

    class Evil:
        def __reduce__(self):
            return (open, (str(ran), "w"))

    bad = {
        "garbage.npz": b"not a zip at all",
        "pickle.npz": pickle.dumps(Evil()),
    }
    for name, data in bad.items():
        (tmp_path / name).write_bytes(data)
    arrays = {
        k: np.zeros((4, 4), np.float32) for k in ("median", "nz_median", "lo", "hi", "rate", "mean_err")
    }
    np.savez(tmp_path / "nometa.npz", **arrays)
    np.savez(tmp_path / "objects.npz", meta=np.array([{"format": "d2sr scene 1"}], dtype=object), **arrays)

    def meta(**over: object) -> np.ndarray:
        m = {"format": "d2sr scene 1", "depth_scale": 4000.0, "frames": 6, "shape": [4, 4], "source": "x"}
        return np.frombuffer(json.dumps(m | over).encode(), np.uint8)

    np.savez(tmp_path / "hugeint.npz", meta=meta(depth_scale=-(2**63) - 1), **arrays)
    np.savez(tmp_path / "huge.npz", meta=meta(shape=[8192, 8192]), **arrays)
    # an array far larger than the shape it claims (packed small: a zip of zeros)
    np.savez_compressed(
        tmp_path / "bomb.npz", meta=meta(), **(arrays | {"lo": np.zeros((4000, 4000), np.float32)})
    )
    names = ("garbage", "pickle", "nometa", "objects", "missing", "hugeint", "huge", "bomb")
    for name in names:
        with pytest.raises(InputError) as err:
            StoredScene.load(tmp_path / f"{name}.npz")
        assert len(str(err.value).splitlines()) == 1 and err.value.setting == "scene_from"
    assert not ran.exists()


def test_learn_then_recover_from_it_and_a_scene_that_does_not_fit_is_refused(tmp_path, weights):
    rng = np.random.default_rng(3)
    clean, rec = tmp_path / "clean", tmp_path / "rec"
    for folder in (clean, rec):
        folder.mkdir()
        for i in range(6):
            f = _wall(rng)
            if folder == rec:  # a CW-ToF neighbour reads one patch 3-4 cm off, its sign changing each frame
                f[40:60, 30:70] = (
                    f[40:60, 30:70] + int(0.03 * SCALE) if i % 2 else f[40:60, 30:70] - int(0.04 * SCALE)
                )
            cv2.imwrite(str(folder / f"{i:03d}.png"), f)
    code, out, err = d2sr_inprocess("scene", "learn", str(clean), "--depth-scale", "4000", "--out",
                                    str(tmp_path / "room.npz"))  # fmt: skip
    assert code == 0 and "scene of 6 clean frames" in out, err
    args = ["recover", str(rec), "--depth-scale", "4000", "--models", str(weights), "--no-report"]
    for given, out_dir in ((["--scene-from", str(tmp_path / "room.npz")], "o"), ([], "n")):
        code, _, err = d2sr_inprocess(*args, *given, "--out", str(tmp_path / out_dir))
        assert code == 0, err
    truth = _truth()[40:60, 30:70]
    for i in range(6):
        stored, alone = (
            cv2.imread(str(tmp_path / d / f"{i:03d}.png"), cv2.IMREAD_UNCHANGED)[40:60, 30:70] / SCALE
            for d in "on"
        )
        assert np.median(np.abs(stored - truth)) < 0.01  # the stored scene puts the wall back ...
        assert np.median(np.abs(alone - truth)) > 0.025  # ... which the recording alone cannot tell
    code, _, err = d2sr_inprocess(*args[:3], "5000", *args[4:], "--scene-from", str(tmp_path / "room.npz"),
                                  "--out", str(tmp_path / "p"))  # fmt: skip
    assert code == 2 and "a scene at depth scale 4000" in err and not (tmp_path / "p").exists()
    code, _, err = d2sr_inprocess("scene", "learn", str(clean), "--depth-scale", "4000", "--out",
                                  str(tmp_path / "room.npz"))  # fmt: skip
    assert code == 2 and "--overwrite" in err  # d2sr's own file: replaced only when asked


def _reference_after_a_clean_frame(stored: StoredScene, rng: np.random.Generator) -> SceneReference:
    ref = SceneReference.from_stored(stored)
    ref.evidence(f := _wall(rng))
    ref.add(f)
    return ref


def test_a_surface_read_a_few_centimetres_off_frame_after_frame_stays_fresh_against_a_stored_scene():
    """A CW-ToF neighbour reads the same surface 2-5 cm off in frame after frame, varying in sign: nothing
    that moved explains it against a stored scene, so every such frame is evident and the scene's own
    depth goes back. Something far off the scene (a person 1 m nearer) that stays is still explained by
    motion after its first frame, as it is against a scene learned on the fly."""
    rng = np.random.default_rng(2)
    stored = _learned()
    ref = _reference_after_a_clean_frame(stored, rng)
    for k in range(4):
        hit = _wall(rng)
        if k % 2:
            hit[40:60, 30:70] += int(0.03 * SCALE)
        else:
            hit[40:60, 30:70] -= int(0.04 * SCALE)
        ev = ref.evidence(hit)
        assert ev.evident and ev.fresh[40:60, 30:70].mean() > 0.8, k
        fill = ref.repair(ev)
        back = fill.depth[40:60, 30:70][fill.fill[40:60, 30:70]]
        truth = _truth()[40:60, 30:70][fill.fill[40:60, 30:70]]  # the wall itself, not a statistic of it
        # the scene's depth, or the reading less the surface's offset (a surface shifted as a whole)
        assert fill.fill[40:60, 30:70].mean() > 0.8 and np.median(np.abs(back - truth)) < 0.005
    ref = _reference_after_a_clean_frame(stored, rng)
    fresh = []
    for _ in range(3):
        person = _wall(rng)
        person[40:60, 30:70] -= int(1.0 * SCALE)
        fresh.append(ref.evidence(person).fresh[40:60, 30:70].mean())
    assert fresh[0] > 0.8 and max(fresh[1:]) < 0.05  # explained by motion once it was there a frame before


def test_a_scene_learned_on_the_fly_still_lets_the_frame_before_explain_a_small_offset():
    """Without a stored scene the scene may have absorbed what it judges, so a persistent small offset is
    left to the frame before's deviations to explain, as before."""
    rng = np.random.default_rng(3)
    ref = SceneReference(SCALE)
    for _ in range(6):
        ref.evidence(f := _wall(rng))
        ref.add(f)
    fresh = []
    for _ in range(3):
        hit = _wall(rng)
        hit[40:70, 30:80] -= int(0.04 * SCALE)
        fresh.append(ref.evidence(hit).fresh[40:70, 30:80].mean())
    assert fresh[0] > 0.8 and max(fresh[1:]) < 0.05


def test_a_scene_that_does_not_fit_says_what_it_is_and_what_the_frames_are():
    stored = _learned(3)
    stored.check_fits((96, 128), SCALE * (1 + 1e-7), "room.npz")  # within the scale's tolerance: fits
    with pytest.raises(InputError) as size:
        stored.check_fits((60, 80), SCALE, "room.npz")
    assert str(size.value) == "room.npz: a scene of 128x96 frames; these frames are 80x60"
    with pytest.raises(InputError) as scale:
        stored.check_fits((96, 128), 1000.0, "room.npz")
    assert str(scale.value) == "room.npz: a scene at depth scale 4000; these frames are at 1000"
    assert size.value.setting == scale.value.setting == "scene_from"  # the CLI names --scene-from


def test_a_scene_whose_statistics_no_clean_sequence_has_is_refused_and_float_slack_is_not(tmp_path):
    good = tmp_path / "good.npz"
    _learned(4).save(good)
    with np.load(good) as z:
        arrays = {k: z[k].copy() for k in z.files}
    seen = np.argwhere(arrays["rate"] > 0)[0]
    at = (int(seen[0]), int(seen[1]))
    med = float(arrays["nz_median"][at])

    def with_(name: str, **changed: float) -> object:
        out = {k: a.copy() for k, a in arrays.items()}
        for k, v in changed.items():
            out[k][at] = v
        path = tmp_path / f"{name}.npz"
        with open(path, "wb") as fh:
            np.savez(fh, **out)
        return StoredScene.load(path)

    with_("slack", lo=med + 5e-5, hi=med - 5e-5)  # float32 rounding between percentiles: taken
    never = np.argwhere(arrays["rate"] == 0)[0]
    path = tmp_path / "unseen.npz"
    unseen = {k: a.copy() for k, a in arrays.items()}
    unseen["lo"][int(never[0]), int(never[1])] = (
        1.0  # a pixel that never returned: its percentiles say nothing
    )
    with open(path, "wb") as fh:
        np.savez(fh, **unseen)
    StoredScene.load(path)
    for name, change in {
        "rate": {"rate": 1.5},
        "negative": {"median": -0.1},
        "lo": {"lo": med + 0.01},  # its 2nd percentile a centimetre past its median
        "hi": {"hi": med - 0.01},
    }.items():
        with pytest.raises(InputError) as err:
            with_(name, **change)
        assert str(err.value) == f"{tmp_path / name}.npz: its statistics are none a clean sequence has", name


def _scene_file(path, meta: object, shape: tuple[int, int] = (1, 1), raw: np.ndarray | None = None):
    arrays = {k: np.zeros(shape, np.float32) for k in ("median", "nz_median", "lo", "hi", "rate", "mean_err")}
    body = raw if raw is not None else np.frombuffer(json.dumps(meta).encode(), np.uint8)
    with open(path, "wb") as fh:
        np.savez(fh, meta=body, **arrays)
    return path


def test_a_scene_s_description_is_checked_field_by_field():
    import tempfile
    from pathlib import Path

    good = {"format": "d2sr scene 1", "depth_scale": 4000.0, "frames": 3, "shape": [1, 1], "source": "x"}
    with tempfile.TemporaryDirectory() as tmp:
        one = StoredScene.load(_scene_file(Path(tmp) / "one.npz", good))  # a 1x1 scene is a scene
        assert one.shape == (1, 1) and one.frames == 3
        nodesc = "not a scene file d2sr wrote (no description of it)"
        for name, meta, raw, why in (
            ("list", [good], None, nodesc),
            ("format", good | {"format": "other 1"}, None, nodesc),
            ("floats", None, np.zeros(8, np.float32), nodesc),
            ("twod", None, np.zeros((2, 4), np.uint8), nodesc),
            ("zero", good | {"shape": [0, 1]}, None, "its description has the wrong types"),
            ("text", good | {"shape": ["1", 1]}, None, "its description has the wrong types"),
        ):
            path = _scene_file(Path(tmp) / f"{name}.npz", meta, raw=raw)
            with pytest.raises(InputError) as err:
                StoredScene.load(path)
            assert str(err.value) == f"{path}: {why}", name
