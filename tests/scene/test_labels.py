"""Ground-truth labelling: streaming statistics, both methods, the CLI and its bad inputs."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.errors import ConfigError, InputError
from d2sr.eval.labels import evaluate, sim_case
from d2sr.scene.labeller import Labeller, f1
from d2sr.scene.reference import READ
from d2sr.scene.stats import STAT_FIELDS, clean_stats, sort_frames, stack_stats
from helpers import d2sr as _cli


def _seq(n=30, shape=(24, 32), seed=0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    base = rng.integers(8000, 16000, shape)
    out = []
    for _ in range(n):
        f = (base + rng.normal(0, 20, shape)).astype(np.uint16)
        f[:, :4] = 0  # never returns
        f[:, 4:8] *= (rng.random((shape[0], 4)) < 0.5).astype(np.uint16)  # flickers
        out.append(f)
    return out


def test_clean_stats_exact_with_any_stripe_size():
    seq = _seq()
    big = clean_stats(lambda: iter(seq), 4000.0, memory_mb=64)
    tiny = clean_stats(lambda: iter(seq), 4000.0, memory_mb=0.001)  # one row per stripe
    stack = np.stack(seq).astype(np.float64) / 4000
    assert np.allclose(big.median, np.median(stack, axis=0), atol=1e-6)
    for a, b in (
        (big.median, tiny.median),
        (big.lo, tiny.lo),
        (big.rate, tiny.rate),
        (big.mean_err, tiny.mean_err),
    ):
        assert np.array_equal(a, b)
    nz = np.where(stack > 0, stack, np.nan)[:, :, 10]
    assert np.allclose(big.nz_median[:, 10], np.nanmedian(nz, axis=0), atol=1e-6)
    assert (big.rate[:, :4] == 0).all() and (big.rate[:, 10] == 1).all()


def test_clean_stats_reads_the_sequence_in_stripes():
    seq = _seq(n=40)
    calls = []

    def frames():
        calls.append(1)
        return iter(seq)

    clean_stats(frames, 4000.0, memory_mb=40 * 32 * 2 * 2 * 6 / 2**20)  # room for 6 rows
    assert len(calls) == 1 + 4  # one count pass, then 24 rows in stripes of 6


def test_stats_method_finds_a_corrupted_block():
    seq = _seq()
    stats = clean_stats(lambda: iter(seq[:25]), 4000.0)
    f = seq[27].copy()
    f[8:16, 12:24] = (f[8:16, 12:24] * 0.5).astype(np.uint16)  # too short
    f[16:20, 12:24] = 0  # dropout on reliable pixels
    true = np.zeros(f.shape, bool)
    true[8:20, 12:24] = True
    lab = Labeller(stats)
    pred = lab.mask(f.astype(np.float32) / 4000)
    assert f1(pred, true)[2] > 0.95
    gt = lab.depth(f.astype(np.float32) / 4000, pred)
    assert np.allclose(gt[10, 15], stats.nz_median[10, 15])
    assert gt[2, 2] == 0  # zero-matched outside the mask


def test_paper_method_and_options():
    seq = _seq()
    stats = clean_stats(lambda: iter(seq[:25]), 4000.0)
    f = seq[27].copy()
    f[8:16, 12:24] = 0
    masks = [Labeller(stats, "paper", t).mask(f / np.float32(4000)) for t in ("mu", "mu+sigma", "mu+2sigma")]
    assert masks[0][10, 15] and not np.array_equal(masks[0], masks[2])
    with pytest.raises(ConfigError, match="threshold"):
        Labeller(stats, "paper", "mu+3sigma")
    with pytest.raises(ConfigError, match="method"):
        Labeller(stats, "magic")
    with pytest.raises(InputError, match="32x24"):
        Labeller(stats).mask(np.zeros((10, 10), np.float32))
    with pytest.raises(InputError, match="at least 3"):
        clean_stats(lambda: iter(seq[:2]), 4000.0)


def test_labelling_beats_the_paper_on_a_simulated_room():
    res = evaluate(sim_case(0, clean=40, interfered=6))
    assert res["stats"]["f1"] > 0.7
    assert res["stats"]["f1"] > max(v["f1"] for k, v in res.items() if k.startswith("paper"))


def _write(folder: Path, frames: list[np.ndarray]) -> Path:
    folder.mkdir(parents=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:04d}.png"), f)
    return folder


def test_label_cli(tmp_path):
    seq = _seq()
    clean = _write(tmp_path / "clean", seq[:25])
    bad = [f.copy() for f in seq[25:]]
    for f in bad:
        f[8:16, 12:24] = 0
    inter = _write(tmp_path / "inter", bad)
    out = tmp_path / "out"
    r = _cli(
        "label", "--clean", str(clean), "--interfered", str(inter), "--depth-scale", "4000", "--out", str(out)
    )
    assert r.returncode == 0, r.stderr
    masks = sorted((out / "masks").glob("*.png"))
    assert [p.name for p in masks] == [f"{i:04d}.png" for i in range(5)]
    m = cv2.imread(str(masks[0]), cv2.IMREAD_UNCHANGED)
    assert m.dtype == np.uint8 and set(np.unique(m)) <= {0, 255} and m[10, 15] == 255
    d = cv2.imread(str(out / "depth" / "0000.png"), cv2.IMREAD_UNCHANGED)
    assert d.dtype == np.uint16 and d[10, 15] > 0
    info = json.loads((out / "label.json").read_text())
    assert info["method"] == "stats" and len(info["frames"]) == 5
    # the frames labelled are kept beside their truth: adapt --labelled reads the folder and nothing else
    from d2sr.train.adapt import labelled_frames

    inter.rename(tmp_path / "moved")  # the path label.json records is provenance, not a path to follow
    pairs = labelled_frames([out])
    assert len(pairs) == 5 and all(np.array_equal(p[0], b) for p, b in zip(pairs, bad, strict=True))
    assert pairs[0][2].dtype == bool and pairs[0][2][10, 15] and pairs[0][1][10, 15] > 0
    (tmp_path / "moved").rename(inter)
    r = _cli(
        "label",
        "--clean",
        str(clean),
        "--interfered",
        str(inter),
        "--depth-scale",
        "4000",
        "--out",
        str(tmp_path / "paper"),
        "--method",
        "paper",
        "--statistic",
        "mu",
    )
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        (lambda c, i: cv2.imwrite(str(i / "0002.png"), np.zeros((10, 10), np.uint16)), "earlier frames"),
        (lambda c, i: [p.unlink() for p in i.glob("*.png")], "no PNG depth frames"),
        (lambda c, i: (c / "0001.png").write_bytes((c / "0001.png").read_bytes()[:100]), "truncated PNG"),
        (
            lambda c, i: [cv2.imwrite(str(p), np.zeros((12, 16), np.uint16)) for p in i.glob("*.png")],
            "interfered frames are 16x12",
        ),
    ],
)
def test_label_cli_bad_input(tmp_path, setup, message):
    seq = _seq()
    clean = _write(tmp_path / "clean", seq[:5])
    inter = _write(tmp_path / "inter", seq[5:8])
    setup(clean, inter)
    out = tmp_path / "out"
    r = _cli(
        "label", "--clean", str(clean), "--interfered", str(inter), "--depth-scale", "4000", "--out", str(out)
    )
    assert r.returncode == 2
    assert message in r.stderr and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clean", "inter"]


def test_label_cli_bad_scale(tmp_path):
    seq = _seq()
    clean = _write(tmp_path / "clean", seq[:5])
    r = _cli(
        "label",
        "--clean",
        str(clean),
        "--interfered",
        str(clean),
        "--depth-scale",
        "0",
        "--out",
        str(tmp_path / "o"),
    )
    assert r.returncode == 2 and "positive" in r.stderr
    r = _cli("label", "--clean", str(clean), "--interfered", str(clean), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "depth scale" in r.stderr


def test_stack_stats_computes_only_the_fields_asked_for_and_the_same_values():
    """A scene reference refreshes only the statistics it reads; they equal the full computation's."""
    rng = np.random.default_rng(0)
    stack = rng.integers(0, 9000, (16, 12, 20)).astype(np.uint16)
    stack[rng.random(stack.shape) < 0.3] = 0
    full, part = stack_stats(stack), stack_stats(stack, READ)
    assert tuple(full) == STAT_FIELDS and tuple(part) == READ
    assert all(np.array_equal(full[k], part[k]) for k in READ if k in STAT_FIELDS)


@pytest.mark.parametrize("part", [0.25, 0.5])
def test_stack_stats_gap_is_the_widest_gap_leaving_a_part_of_the_returns_on_each_side(part):
    """``gap``, against each pixel's returns sorted one by one."""
    rng = np.random.default_rng(1)
    stack = rng.integers(1, 9000, (16, 9, 11)).astype(np.uint16)
    stack[rng.random(stack.shape) < 0.4] = 0
    got = stack_stats(stack, ("gap",), part)["gap"]
    for (y, x), value in np.ndenumerate(got):
        r = np.sort(stack[:, y, x][stack[:, y, x] > 0]).astype(float)
        least = max(int(np.ceil(part * len(r))), 1)
        gaps = [r[i + 1] - r[i] for i in range(len(r) - 1) if i + 1 >= least and len(r) - 1 - i >= least]
        assert value == (max(gaps) if gaps else 0)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 16, 17, 31, 32, 33])
def test_sort_frames_sorts_each_pixel_as_numpy_does(n):
    """The scene reference's frames sorted through a compare-and-swap network: numpy's sort, for any count."""
    rng = np.random.default_rng(n)
    stack = rng.integers(0, 65535, (n, 5, 7)).astype(np.uint16)
    stack[rng.random(stack.shape) < 0.4] = 0
    stack[:, 0, 0] = 7  # ties
    assert np.array_equal(sort_frames(stack), np.sort(stack, axis=0))


@pytest.mark.parametrize("share", [0.15, 0.3, 8 / 49, 15 / 49, 0.01, 1.0, 1.5])
def test_window_counts_decide_as_the_blurred_share_would(share):
    """``Labeller.mask`` counts a 7x7 window's raw pixels in integers; from ``count_from(share, 7)`` on, the
    count reaches ``share`` exactly where ``cv2.blur``'s float share does (borders included)."""
    from d2sr.scene.stats import count_from

    rng = np.random.default_rng(7)
    raw = rng.random((60, 80)) < rng.random((60, 80))  # densities from empty to full
    count = cv2.boxFilter(raw.view(np.uint8), -1, (7, 7), normalize=False)
    share_blurred = cv2.blur(raw.astype(np.float32), (7, 7))
    assert np.array_equal(count >= count_from(share, 7), share_blurred >= share)


def test_blur_shares_are_what_cv2_blur_gives_for_each_count():
    """A window's integer count looked up in ``blur_shares`` is cv2.blur's float share, bit for bit (the
    scene reference's shifted windows divide by it)."""
    from d2sr.scene.stats import blur_shares

    rng = np.random.default_rng(8)
    for side in (7, 15):
        ones = rng.random((50, 70)) < rng.random((50, 70))
        count = cv2.boxFilter(ones.view(np.uint8), -1, (side, side), normalize=False)
        assert np.array_equal(blur_shares(side)[count], cv2.blur(ones.astype(np.float32), (side, side)))


@pytest.mark.parametrize("memory_mb", [0.0, -1.0, float("nan"), float("inf")])
def test_clean_stats_refuse_a_memory_budget_that_is_not_a_positive_number(memory_mb):
    """NaN passed every check and read the whole sequence in one stripe: the budget was not kept."""
    seq = _seq()
    with pytest.raises(ConfigError, match="memory_mb must be a positive number"):
        clean_stats(lambda: iter(seq), 4000.0, memory_mb=memory_mb)
