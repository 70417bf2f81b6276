"""One corpus of broken inputs through every command that reads recordings (and training on
users' own folders): each case must give exit code
2, one line on stderr naming the problem, no traceback, and nothing at the output path (no partial files
either). Run in-process (the same ``main`` as the console script) to keep 70 runs fast; test_cli_models
covers the subprocess path."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from helpers import good_folder, run_cli


def _then(root: Path, name: str, data: bytes) -> Path:
    (root / name).write_bytes(data)
    return root


def _npz(path: Path, depth: np.ndarray) -> Path:
    np.savez(path, depth=depth, depth_scale=1000.0)
    return path


# case -> (make the input under a tmp path, what the one line must say)
CORPUS: dict[str, tuple[Callable[[Path], Path], str]] = {
    "missing path": (lambda p: p / "nothing", r"no such|does not exist|not found"),
    "empty folder": (lambda p: (p / "in").mkdir() or p / "in", r"no PNG depth frames|empty|no frames"),
    "corrupt png": (
        lambda p: _then(good_folder(p / "in"), "f001.png", b"\x89PNG\r\n\x1a\nxxxxIEND"),
        r"f001",
    ),
    "truncated png": (
        lambda p: _then(
            good_folder(p / "in"), "f001.png", (good_folder(p / "t", 1) / "f000.png").read_bytes()[:200]
        ),
        r"f001",
    ),
    "text named png": (lambda p: _then(good_folder(p / "in"), "f001.png", b"depth: 1.5 m\n"), r"f001"),
    "8-bit png": (
        lambda p: (
            (p / "in").mkdir()
            or (cv2.imwrite(str(p / "in" / "a.png"), np.ones((96, 128), np.uint8)) and p / "in")
        ),
        r"8-bit",
    ),
    "wrong scale": (lambda p: good_folder(p / "in", scale=10), r"scale"),
    "nan npz": (lambda p: _npz(p / "in.npz", np.full((2, 96, 128), np.nan, np.float32)), r"NaN"),
    "float npz": (
        lambda p: _npz(p / "in.npz", np.full((2, 96, 128), 1.5, np.float64)),
        r"float|dtype|uint16",
    ),
    "truncated npz": (
        lambda p: (
            _then(p, "in.npz", _npz(p / "ok.npz", np.ones((2, 96, 128), np.uint16)).read_bytes()[:300])
            / "in.npz"
        ),
        r"in\.npz",
    ),
    "corrupt bag": (lambda p: _then(p, "in.bag", b"#ROSBAG V2.0\n" + b"\x00" * 64) / "in.bag", r"in\.bag"),
}


def _commands(src: Path, out: Path, weights: Path) -> dict[str, list[str]]:
    w = ["--models", str(weights)]
    cfg = src.parent / "train.toml"  # users' own labelled folders (fine-tuning)
    cfg.write_text(
        f'model = "unet8"\nsynthetic = 0\nsteps = 1\nbatch = 1\ncrop = [64, 96]\n'
        f'folders = [{{ input = "{src}", target = "{src}" }}]\n'
    )
    return {
        "train": ["train", "recovery", "--config", str(cfg), "--out", str(out)],
        "detect": ["detect", str(src), "--out", str(out), *w],
        "recover": ["recover", str(src), "--out", str(out), "--repair", "all", *w],
        "run": ["run", str(src), "--out", str(out), *w],
        "label": [
            "label",
            "--clean",
            str(src),
            "--interfered",
            str(src),
            "--out",
            str(out),
            "--depth-scale",
            "1000",
        ],
        "calibrate": [
            *("calibrate", "--real", str(src), "--out", str(out), "--depth-scale", "1000"),
            *("--skip", "0", "--rooms", "1", "--frames", "2"),
        ],
    }


@pytest.mark.parametrize("command", ["detect", "recover", "run", "label", "calibrate", "train"])
@pytest.mark.parametrize("case", list(CORPUS))
def test_every_command_turns_every_broken_input_into_one_line(tmp_path, weights, case, command):
    make, says = CORPUS[case]
    src = make(tmp_path)
    out = tmp_path / "result"
    args = _commands(src, out, weights)[command]
    before = set(tmp_path.rglob("*"))
    code, err = run_cli(args)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("d2sr: error:"), err
    assert re.search(says, lines[0]), lines[0]
    assert set(tmp_path.rglob("*")) == before  # nothing written, not even a partial folder
