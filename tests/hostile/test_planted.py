"""Files planted in an output's place are data: a manifest that names anything outside its folder, a
checkpoint that would run code, a folder that looks like d2sr's working folder. None of them makes d2sr
delete, overwrite or run anything; each gives one line and exit 2 or is left alone."""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path

import cv2
import numpy as np
import pytest

from d2sr.atomic import MANIFEST, check_out, commit, temp_for, tidy
from d2sr.errors import InputError, OutputError
from helpers import d2sr_inprocess, room


def _frames(root: Path, n: int = 4) -> Path:
    root.mkdir()
    for i in range(n):
        cv2.imwrite(str(root / f"{i:06d}.png"), room(i, (96, 128)))
    return root


def _recover(src: Path, out: Path, weights: Path, *extra: str) -> tuple[int, str]:
    code, _, err = d2sr_inprocess(
        "recover", str(src), "--out", str(out), "--depth-scale", "4000", "--models", str(weights),
        "--model", "unet8", "--no-scene", *extra,
    )  # fmt: skip
    return code, err


def test_a_manifest_naming_files_outside_its_folder_deletes_nothing(tmp_path, weights):
    src = _frames(tmp_path / "in")
    out = tmp_path / "out"
    assert _recover(src, out, weights)[0] == 0
    victim, absolute = tmp_path / "victim.txt", tmp_path / "elsewhere" / "abs.txt"
    victim.write_text("mine")
    absolute.parent.mkdir()
    absolute.write_text("mine too")
    (tmp_path / "sub").mkdir()
    os.symlink(tmp_path / "sub", out / "link")  # an entry reached through a link is outside as well
    (tmp_path / "sub" / "x.png").write_text("mine")
    for planted in ("../victim.txt", str(absolute), "link/x.png", "masks/../../victim.txt", ""):
        manifest = json.loads((out / MANIFEST).read_text())
        manifest["files"] = [*manifest["files"], planted]
        (out / MANIFEST).write_text(json.dumps(manifest))
        before = sorted(p.name for p in out.rglob("*"))
        code, err = _recover(src, out, weights, "--overwrite")
        assert code == 2 and "not a file inside" in err and len(err.strip().splitlines()) == 1, err
        assert victim.read_text() == "mine" and absolute.read_text() == "mine too"
        assert (tmp_path / "sub" / "x.png").read_text() == "mine"
        assert sorted(p.name for p in out.rglob("*")) == before
        manifest["files"].remove(planted)
        (out / MANIFEST).write_text(json.dumps(manifest))


def test_a_manifest_that_is_not_a_list_refuses_the_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    for files in ({"a": 1}, "../x", [1, 2], None):
        (out / MANIFEST).write_text(json.dumps({"files": files}))
        with pytest.raises(OutputError):
            check_out(out, is_dir=True, overwrite=True)
    assert (out / "keep.txt").read_text() == "mine"


class _Runs:
    """Unpickling this runs code: what a planted checkpoint would do."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_checkpoint_that_would_run_code_is_refused(tmp_path):
    from d2sr.train.loop import load_checkpoint

    marker = tmp_path / "ran"
    ckpt = tmp_path / "checkpoint.pt"
    with ckpt.open("wb") as fh:
        pickle.dump({"model": _Runs(marker)}, fh)
    with pytest.raises(InputError, match="not a checkpoint d2sr wrote"):
        load_checkpoint(ckpt)
    assert not marker.exists()
    ckpt.write_bytes(b"\x00garbage")
    with pytest.raises(InputError):
        load_checkpoint(ckpt)
    link = tmp_path / "link.pt"
    link.symlink_to(ckpt)
    with pytest.raises(InputError, match="plain file"):
        load_checkpoint(link)


def test_a_checkpoint_of_tensors_loads(tmp_path):
    import torch

    from d2sr.train.loop import load_checkpoint

    state = {"model": {"w": torch.ones(2)}, "rng": np.random.default_rng(0).bit_generator.state, "step": 3}
    torch.save(state, tmp_path / "c.pt")
    back = load_checkpoint(tmp_path / "c.pt")
    assert back["step"] == 3 and torch.equal(back["model"]["w"], torch.ones(2))


@pytest.mark.parametrize("planted", ["folder", "link"])
def test_run_leaves_a_users_folder_named_like_its_working_folder(tmp_path, weights, planted):
    src = _frames(tmp_path / "in", 6)
    user = tmp_path / ".out.partial"
    if planted == "folder":
        user.mkdir()
        (user / "notes.txt").write_text("mine")
    else:
        (tmp_path / "target").mkdir()
        user.symlink_to(tmp_path / "target")
    code, _, err = d2sr_inprocess(
        "run", str(src), "--out", str(tmp_path / "out"), "--depth-scale", "4000", "--models", str(weights),
        "--model", "unet8", "--no-scene",
    )  # fmt: skip
    assert code == 0, err
    assert user.is_symlink() if planted == "link" else (user / "notes.txt").read_text() == "mine"
    assert not list(tmp_path.glob(".out.d2sr-*"))  # its own working folder is gone


def test_overwrite_keeps_a_users_empty_folders(tmp_path, weights):
    src = _frames(tmp_path / "in")
    out = tmp_path / "out"
    assert _recover(src, out, weights)[0] == 0
    (out / "empty").mkdir()
    (out / "masks" / "mine").mkdir()
    assert _recover(src, out, weights, "--overwrite")[0] == 0
    assert (out / "empty").is_dir() and (out / "masks" / "mine").is_dir()


def _dead_pid() -> int:
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    os.waitpid(pid, 0)
    return pid


def test_temporaries_of_ended_runs_are_removed_and_nothing_else(tmp_path):
    out = tmp_path / "out"
    dead, live = _dead_pid(), os.getpid()
    stale_dir = tmp_path / f".out.d2sr-{dead}-0a1b2c3d.tmp"
    stale_dir.mkdir()
    (stale_dir / "000001.png").write_bytes(b"x")
    stale_file = tmp_path / f".out.d2sr-{dead}-0a1b2c3e.tmp.mcap"
    stale_file.write_bytes(b"x" * 100)
    running = tmp_path / f".out.d2sr-{live}-0a1b2c3f.tmp"  # a run still going: not ours to touch
    running.mkdir()
    users = [tmp_path / ".out.partial", tmp_path / ".out.d2sr-notes.txt", tmp_path / f".out.{dead}.tmp"]
    for u in users:
        u.write_text("mine")
    check_out(out, is_dir=True)
    assert not stale_dir.exists() and not stale_file.exists()
    assert running.is_dir() and all(u.read_text() == "mine" for u in users)


def test_a_commit_killed_between_its_renames_is_undone_by_the_next_run(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with_user = {"a.png": b"old", "masks/a.png": b"old mask", "notes.txt": b"mine", "sub/more.txt": b"mine"}
    out.mkdir()
    for name, data in with_user.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(data)
    (out / MANIFEST).write_text(json.dumps({"made_by": "d2sr", "files": ["a.png", "masks/a.png"]}))
    tmp = temp_for(out, is_dir=True)
    (tmp / "a.png").write_bytes(b"new")

    class Killed(BaseException):
        pass

    real = Path.rename
    calls = []

    def dies(self: Path, target: Path) -> Path:  # the process dies after the first rename of the commit
        calls.append(self)
        if len(calls) == 2:
            raise Killed
        return real(self, target)

    monkeypatch.setattr(Path, "rename", dies)
    with pytest.raises(Killed):
        commit(tmp, out)
    monkeypatch.setattr(Path, "rename", real)
    assert not out.exists()  # stranded: the user's files sit in the old folder
    tidy(out)
    for name, data in with_user.items():
        assert (out / name).read_bytes() == data
    assert not list(tmp_path.glob(".out.d2sr-*.old")) and not list(tmp_path.glob(".out.d2sr-*.journal.json"))


def test_a_commit_killed_while_moving_the_users_files_back_is_finished(tmp_path, monkeypatch):
    import d2sr.atomic.placing as atomic

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.png").write_bytes(b"old")
    (out / "notes.txt").write_text("mine")
    (out / MANIFEST).write_text(json.dumps({"made_by": "d2sr", "files": ["a.png"]}))
    tmp = temp_for(out, is_dir=True)
    (tmp / "a.png").write_bytes(b"new")

    class Killed(BaseException):
        pass

    def dies(path: Path, old: Path) -> None:
        raise Killed

    monkeypatch.setattr(atomic, "_settle", dies)
    with pytest.raises(Killed):
        commit(tmp, out)
    monkeypatch.undo()
    assert (out / "a.png").read_bytes() == b"new" and not (out / "notes.txt").exists()
    check_out(out, is_dir=True, overwrite=True)
    assert (out / "notes.txt").read_text() == "mine" and (out / "a.png").read_bytes() == b"new"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.")]


@pytest.fixture
def small_disk(tmp_path):
    """A 300 kB file system (tmpfs; root only): skipped where it cannot be mounted."""
    import subprocess

    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(disk)], capture_output=True
    ).returncode:
        pytest.skip("cannot mount a small tmpfs here (not root)")
    yield disk
    subprocess.run(["umount", str(disk)], check=False)


def test_a_full_disk_and_a_read_only_folder_are_one_line_and_leave_nothing(tmp_path, weights, small_disk):
    import subprocess

    src = _frames(tmp_path / "in", 6)
    big = tmp_path / "big"
    big.mkdir()
    for i in range(6):
        cv2.imwrite(str(big / f"{i:06d}.png"), room(i))  # 640x480: more than the disk holds
    code, err = _recover(big, small_disk / "out", weights)
    assert code == 2 and "disk is full" in err and len(err.strip().splitlines()) == 1, err
    assert list(small_disk.iterdir()) == []
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    code, err = _recover(src, small_disk / "out", weights)
    assert code == 2 and "cannot write in" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize(
    "args",
    [
        ["recover", "in", "--prime", "-1", "--out", "o"],
        ["recover", "in"],
        ["recover", "in", "--out", "o", "--bogus"],
        ["detect", "in", "--out", "x.csv", "--threshold", "abc"],
        ["nosuch"],
    ],
)
def test_a_usage_error_is_one_line(args):
    code, _, err = d2sr_inprocess(*args)
    assert code == 2 and err.startswith("d2sr: error: ") and len(err.strip().splitlines()) == 1, err
    assert "--help" in err


def test_a_pipe_is_no_recording(tmp_path):
    for name in ("rec.npz", "rec.bag"):
        os.mkfifo(tmp_path / name)
        code, _, err = d2sr_inprocess("detect", str(tmp_path / name), "--out", str(tmp_path / "x.csv"))
        assert code == 2 and "not a regular file" in err, err  # refused at once, not read forever
    bag = tmp_path / "bag2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    os.mkfifo(bag / "bag2_0.mcap")
    code, _, err = d2sr_inprocess("detect", str(bag), "--out", str(tmp_path / "y.csv"))
    assert code == 2 and "not a regular file" in err, err


def test_an_npz_whose_header_claims_a_huge_frame_is_refused_before_reading(tmp_path):
    import io
    import zipfile

    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<u2", "fortran_order": False, "shape": (1, 60000, 60000)}
    )
    with zipfile.ZipFile(tmp_path / "bomb.npz", "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("depth.npy", header.getvalue() + bytes(1000))
    from d2sr.frames import open_frames

    with pytest.raises(InputError, match="60000x60000"):
        open_frames(tmp_path / "bomb.npz")
