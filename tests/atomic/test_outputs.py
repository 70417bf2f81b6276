"""The output policy (``d2sr.atomic``): no command deletes or overwrites a file it did not make, writes
over its input, or takes the current folder as its output. Every writing command is run in-process
against an existing folder holding a user file, against ``--out`` = its input, and against ``--out .``;
each must end in one line and exit 2 with every file byte for byte as it was."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from d2sr.atomic import MANIFEST, atomic_dir, check_out, commit, record_manifest, temp_for
from d2sr.errors import OutputError
from helpers import good_folder, run_cli


def _args(src: Path, out: str, weights: Path) -> dict[str, list[str]]:
    w = ["--models", str(weights)]
    s = str(src)
    return {
        "detect": ["detect", s, "--out", out, *w],
        "recover": ["recover", s, "--out", out, *w],
        "run": ["run", s, "--out", out, *w],
        "label": ["label", "--clean", s, "--interfered", s, "--out", out, "--depth-scale", "1000"],
        "calibrate": ["calibrate", "--real", s, "--out", out, "--depth-scale", "1000"],
        "simulate": ["simulate", "--out", out, "--seconds", "1"],
        "train": ["train", "detector", "--out", out, "--steps", "1", "--synthetic", "2"],
        "eval labels": ["eval", "labels", "--out", out, "--sims", "0"],
        "eval detector": ["eval", "detector", "--out", out, *w],
        "eval recovery": ["eval", "recovery", "--out", out, *w],
        "eval paper": ["eval", "paper", "--out", out, *w],
        "eval generalization": ["eval", "generalization", "--data", s, "--out", out, *w],
        "adapt": ["adapt", "--clean", s, "--depth-scale", "1000", "--out", out],
        "gallery": ["gallery", "--out", out],
        "desync run": ["desync", "run", "--out", out],
        "desync sweep": ["desync", "sweep", "--out", out],
        "desync report": ["desync", "report", out],
        "desync grid": ["desync", "grid", "--out", out],
        "view": ["view", s, "--save", out],
        "bench": ["bench", "--json", out],
        "demo": ["demo", "--out", out],
        "export": ["export", str(weights / "unet8.safetensors"), "--out", out],
        "fill": ["fill", s, "--active-frames", "6", "--out", out],
        "trigger firmware": ["trigger", "firmware", "--out", out],
    }


READS_INPUT = ("detect", "recover", "run", "label", "calibrate", "view", "adapt", "fill")
COMMANDS = list(_args(Path("x"), "o", Path("w")))


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _refused(args: list[str], root: Path) -> str:
    before = _snapshot(root)
    code, err = run_cli(args)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("d2sr: error:"), err
    assert _snapshot(root) == before  # byte for byte, and nothing new
    return lines[0]


@pytest.mark.parametrize("command", COMMANDS)
def test_an_existing_output_with_a_user_file_is_refused(tmp_path, weights, command):
    src = good_folder(tmp_path / "in")
    out = tmp_path / "out"
    out.mkdir()
    # export writes <model>.onnx into --out: the user's file has that name
    (out / ("unet8.onnx" if command == "export" else "notes.txt")).write_bytes(b"my notes\n")
    line = _refused(_args(src, str(out), weights)[command], tmp_path)
    assert "--overwrite" in line or "not made" in line or "folder" in line or "exists" in line


@pytest.mark.parametrize("command", READS_INPUT)
def test_out_equal_to_inside_or_around_the_input_is_refused(tmp_path, weights, command):
    src = good_folder(tmp_path / "data" / "in")
    (src / "notes.txt").write_text("beside the frames\n")
    for out in (src, src / "sub", src.parent):
        assert "input" in _refused(_args(src, str(out), weights)[command], tmp_path)


@pytest.mark.parametrize("command", [c for c in COMMANDS if c != "export"])
def test_out_dot_is_refused(tmp_path, weights, command, monkeypatch):
    src = good_folder(tmp_path / "in")
    (tmp_path / "notes.txt").write_text("mine\n")
    monkeypatch.chdir(tmp_path)
    assert "current folder" in _refused(_args(src, ".", weights)[command], tmp_path)


def test_overwrite_replaces_only_what_d2sr_wrote(tmp_path, weights):
    src = good_folder(tmp_path / "in")
    out = tmp_path / "out"
    assert (
        run_cli(["recover", str(src), "--out", str(out), "--repair", "all", "--models", str(weights)])[0] == 0
    )
    made = json.loads((out / MANIFEST).read_text())["files"]
    assert "f000.png" in made and "masks/f000.png" in made
    (out / "notes.txt").write_text("mine\n")
    (out / "masks" / "mine.txt").write_text("also mine\n")
    assert (
        run_cli(["recover", str(src), "--out", str(out), "--models", str(weights)])[0] == 2
    )  # no --overwrite
    code, err = run_cli(["recover", str(src), "--out", str(out), "--overwrite", "--models", str(weights)])
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "mine\n"
    assert (out / "masks" / "mine.txt").read_text() == "also mine\n"
    assert "notes.txt" not in json.loads((out / MANIFEST).read_text())["files"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no leftovers beside it


def test_commit_keeps_user_files_and_refuses_a_folder_it_did_not_make(tmp_path):
    out = tmp_path / "out"
    with atomic_dir(out) as tmp:
        (tmp / "a.txt").write_text("v1")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "b.txt").write_text("v1")
    (out / "user.txt").write_text("user")
    with atomic_dir(out) as tmp:
        (tmp / "a.txt").write_text("v2")  # sub/b.txt is no longer made: it goes
    assert (out / "a.txt").read_text() == "v2" and (out / "user.txt").read_text() == "user"
    assert not (out / "sub").exists()
    with pytest.raises(OutputError, match="not d2sr's"), atomic_dir(out) as tmp:
        (tmp / "user.txt").write_text("clash")
    assert (out / "user.txt").read_text() == "user"
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "x").write_text("x")
    tmp = temp_for(theirs, is_dir=True)
    with pytest.raises(OutputError, match="did not make"):
        commit(tmp, theirs)
    assert (theirs / "x").read_text() == "x"


def test_check_out_rules(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "f.csv").write_text("frame,score,interfered\n")  # detect's header: d2sr's own file
    (tmp_path / "mine.csv").write_text("frame,score\n")
    with pytest.raises(OutputError, match="current folder"):
        check_out(Path("."), is_dir=True)
    with pytest.raises(OutputError, match="current folder"):
        check_out(Path(".."), is_dir=True, overwrite=True)
    with pytest.raises(OutputError, match="allow overwrite") as err:
        check_out(Path("f.csv"), is_dir=False)
    assert err.value.setting == "overwrite"  # the library names its setting; the CLI adds the flag
    assert check_out(Path("f.csv"), is_dir=False, overwrite=True) == tmp_path / "f.csv"
    with pytest.raises(OutputError, match=r"^out mine\.csv exists and d2sr did not write it"):
        check_out(Path("mine.csv"), is_dir=False, overwrite=True)
    with pytest.raises(OutputError, match=r"^json mine\.csv "):  # the library names its output, never a flag
        check_out(Path("mine.csv"), is_dir=False, overwrite=True, name="json")
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputError, match="name a file"):
        check_out(Path("d"), is_dir=False, overwrite=True)
    with pytest.raises(OutputError, match="is a file"):
        check_out(Path("f.csv/x"), is_dir=True)
    run = tmp_path / "run"
    run.mkdir()
    (run / "checkpoint.pt").write_bytes(b"\0")
    record_manifest(run, ["checkpoint.pt"])
    (run / "notes.txt").write_text("mine")
    assert check_out(run, is_dir=True, resume=True) == run  # a run folder of d2sr's resumes
    record_manifest(run, ["loss.json"])
    listed = json.loads((run / MANIFEST).read_text())["files"]
    assert listed == ["checkpoint.pt", "loss.json"]  # the user's notes are never claimed


def test_outputs_get_ordinary_permissions(tmp_path):
    with atomic_dir(tmp_path / "o") as tmp:
        (tmp / "a").write_text("a")
    mask = os.umask(0o022)
    os.umask(mask)
    assert (tmp_path / "o").stat().st_mode & 0o777 == 0o777 & ~mask
    assert np.all([(tmp_path / "o" / "a").is_file()])


def test_benchmark_scripts_refuse_an_existing_json_or_plot_without_overwrite(tmp_path):
    import argparse

    from bench.harness import check_output, output_args

    ap = argparse.ArgumentParser()
    output_args(ap, plot="the plot")
    old = tmp_path / "old.png"
    old.write_bytes(b"a user's file")
    for argv in (["--plot", str(old)], ["--json", str(old)]):
        with pytest.raises(SystemExit) as exc:
            check_output(ap, ap.parse_args(argv))
        assert exc.value.code == 2
    with pytest.raises(SystemExit):  # a user's file: refused even with --overwrite
        check_output(ap, ap.parse_args(["--plot", str(old), "--overwrite"]))
    import matplotlib.pyplot as plt

    from d2sr.eval.plots import save

    ours = save(plt.figure(), tmp_path / "ours.png")  # a plot d2sr wrote says so in its metadata
    check_output(ap, ap.parse_args(["--plot", str(ours), "--overwrite"]))  # asked for: allowed
    check_output(ap, ap.parse_args(["--plot", str(tmp_path / "new.png")]))
    assert old.read_bytes() == b"a user's file"  # checking writes nothing
    plain = argparse.ArgumentParser()
    output_args(plain)
    assert not hasattr(plain.parse_args([]), "plot")  # --plot only where a script makes one


@pytest.mark.slow  # a subprocess per command: not in make test-fast
def test_overwrite_replaces_a_single_file_only_when_d2sr_wrote_it(tmp_path, weights):
    src = good_folder(tmp_path / "in")
    run = tmp_path / "run"
    assert run_cli(["run", str(src), "--out", str(run), "--models", str(weights)])[0] == 0
    w = ["--models", str(weights)]
    cases = {
        "detect": (["detect", str(src), *w, "--out"], tmp_path / "flags.csv"),
        "recover --rerun": (
            ["recover", str(src), *w, "--out", str(tmp_path / "rep"), "--overwrite", "--rerun"],
            tmp_path / "log.rrd",
        ),
        "view --save": (["view", str(run), "--save"], tmp_path / "view.rrd"),
    }
    for name, (args, target) in cases.items():
        target.write_bytes(b"a user's file of that name\n")
        line = _refused([*args, str(target), "--overwrite"], tmp_path)
        assert "did not write" in line, name
        target.unlink()
        code, err = run_cli([*args, str(target)])
        assert code == 0 and target.is_file(), (name, err)
        first = target.read_bytes()
        code, err = run_cli([*args, str(target), "--overwrite"])  # d2sr's own file: replaced
        assert code == 0, (name, err)
        assert target.read_bytes()[:3] == first[:3]


def test_a_result_records_the_run_that_made_it(tmp_path):
    """write_result stamps the command as typed again, the commit, the models' hashes and the data."""
    import hashlib

    from d2sr.atomic import write_result
    from d2sr.contract.catalog import WEIGHTS
    from d2sr.provenance import ROOT, command_line

    assert command_line(["bench/x.py", "--json", "r j.json"]) == "python bench/x.py --json 'r j.json'"
    assert command_line([".venv/bin/d2sr", "eval", "labels"]) == "d2sr eval labels"
    # a module of the lab, run with -m from the checkout: typed again the same way
    lab = [str(ROOT / "lab" / "kinect2_cam0.py"), "--x", "a"]
    assert command_line(lab) == "python -m lab.kinect2_cam0 --x a"
    outside = [str(ROOT / "bench" / "outside" / "__main__.py"), "--set", "a"]
    assert command_line(outside) == "python -m bench.outside --set a"  # a package's __main__: the package
    out = tmp_path / "r.json"
    write_result({"figure": 1.5}, out, models=["unet8", "no-such-model"], data={"set": "x"})
    got = json.loads(out.read_text())
    assert len(got["commit"].split("+")[0]) == 40 and got["cpu"] and len(got["date"]) == 10
    want = hashlib.sha256((WEIGHTS / "unet8.safetensors").read_bytes()).hexdigest()[:16]
    assert got["models"] == {"unet8": want, "no-such-model": None}
    assert got["data"] == {"set": "x"} and got["figure"] == 1.5 and got["made_by"].startswith("d2sr ")
    with pytest.raises(ValueError, match="provenance keys"):  # a result's own "command" would hide the run's
        write_result({"command": "d2sr recover"}, None)
    with pytest.raises(ValueError, match="provenance keys"):  # nor its own words hide the files it read
        write_result({"data": "cam0"}, None, data={"name": "cam0", "files": ["a.png"]})
    assert json.loads(write_result({"data": "cam0"}, None))["data"] == "cam0"  # words alone stay


def test_a_folder_manifest_records_the_run_that_made_it(tmp_path):
    from d2sr.atomic import MANIFEST, atomic_dir

    with atomic_dir(tmp_path / "o") as tmp:
        (tmp / "a.txt").write_text("x")
    got = json.loads((tmp_path / "o" / MANIFEST).read_text())
    assert got["files"] == ["a.txt"] and got["command"] and got["commit"] and got["version"]


def _ended_pid() -> int:
    """The pid of a process that has run and ended (reaped)."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_tidy_removes_only_the_temporaries_of_ended_runs(tmp_path):
    from d2sr.atomic.naming import MARK, alive, ours
    from d2sr.atomic.placing import tidy

    out = tmp_path / "out.csv"
    dead, me = _ended_pid(), os.getpid()
    gone = tmp_path / f".out.csv.{MARK}-{dead}-ab12.tmp"  # a file a killed run was writing
    gone_dir = tmp_path / f".out.csv.{MARK}-{dead}-cd34.tmp"  # a folder it was writing
    live = tmp_path / f".out.csv.{MARK}-{me}-ef56.tmp"  # this run's own, still being written
    other = tmp_path / f".out.csv.{MARK}-{dead}-0a0b.bak"  # not a kind d2sr removes
    theirs = tmp_path / ".out.csv.notes.tmp"  # a user's file of a similar name
    for f in (gone, live, other, theirs):
        f.write_text("x")
    gone_dir.mkdir()
    (gone_dir / "0.png").write_text("x")
    assert ours(gone) == ("tmp", dead) and ours(other) is None and ours(theirs) is None
    assert ours(tmp_path / f".out.csv.{MARK}-{dead}-ab12.old", ("tmp", "old")) == ("old", dead)
    assert alive(me) and not alive(dead) and not alive(2**40)  # a pid no process can have
    tidy(out)
    assert not gone.exists() and not gone_dir.exists()
    assert live.read_text() == other.read_text() == theirs.read_text() == "x"


def test_discarding_a_temporary_never_raises_so_the_first_error_is_the_one_reported(tmp_path, monkeypatch):
    from d2sr.atomic.placing import discard

    discard(tmp_path / "never-made")  # a write that failed before its temporary existed
    folder = tmp_path / ".out.d2sr-1-ab.tmp"
    folder.mkdir()
    (folder / "0.png").write_text("x")

    def refuse(*args: object, **kwargs: object) -> None:
        raise PermissionError("busy")

    monkeypatch.setattr(os, "rmdir", refuse)
    discard(folder)  # what cannot go stays; the caller re-raises its own error, not this one
    assert folder.is_dir()


class _Planted:
    """Unpickling this touches a file: the sign that a reader ran code found in an input."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[Path]]:
        return Path.touch, (self.marker,)


def test_a_stored_scene_is_told_as_d2sr_s_by_a_small_meta_read_as_data(tmp_path):
    from d2sr.atomic.naming import made_by_d2sr

    def npz(name: str, meta: object) -> Path:
        path = tmp_path / name
        with open(path, "wb") as fh:  # np.savez would add .npz to a name without it
            np.savez(fh, meta=meta)
        return path

    def text(n: int) -> np.ndarray:
        head = b'{"format": "d2sr-scene-1", "pad": "'
        return np.frombuffer(head + b"x" * (n - len(head) - 2) + b'"}', np.uint8)

    header = 128  # the .npy header of a 1-D uint8 member: the member's size is this plus its bytes
    assert made_by_d2sr(npz("ours.npz", text(1000)))
    assert made_by_d2sr(npz("largest.npz", text((1 << 16) - header)))  # a member of 64 KiB exactly
    assert not made_by_d2sr(npz("large.npz", text((1 << 16) - header + 64)))  # larger: not read
    marker = tmp_path / "ran"
    planted = np.empty(1, object)
    planted[0] = _Planted(marker)
    assert not made_by_d2sr(npz("pickled.npz", planted)) and not marker.exists()  # never unpickled
