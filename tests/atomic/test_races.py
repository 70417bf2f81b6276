"""What appears at an output while a command writes it is never replaced (issue 79): a user's file placed
at --out mid-run, or a second run writing the same output."""

from __future__ import annotations

import pytest

from d2sr.atomic import atomic_dir, atomic_file, atomic_write
from d2sr.atomic.naming import journal
from d2sr.errors import OutputError


def test_a_file_that_appears_at_a_single_file_output_mid_run_is_kept(tmp_path):
    """The check ran at the start and the final rename replaced whatever was there (scene learn, detect)."""
    out = tmp_path / "race.npz"
    with pytest.raises(OutputError, match="appeared"), atomic_file(out) as tmp:
        tmp.write_bytes(b"d2sr's")
        out.write_bytes(b"the user's")  # appears while the run writes
    assert out.read_bytes() == b"the user's"
    assert [p.name for p in tmp_path.iterdir()] == ["race.npz"]  # nothing of the run left beside it


def test_a_file_changed_under_an_output_being_replaced_is_kept(tmp_path):
    out = tmp_path / "det.csv"
    atomic_write(out, "frame,score,interfered,reason\n")
    with pytest.raises(OutputError, match="changed"), atomic_file(out) as tmp:
        tmp.write_text("new")
        out.unlink()
        out.write_text("the user's, under the same name")
    assert out.read_text() == "the user's, under the same name"


def test_two_runs_to_one_new_folder_the_second_is_refused(tmp_path):
    out = tmp_path / "repaired"
    with pytest.raises(OutputError, match="appeared"), atomic_dir(out) as first:
        (first / "a.png").write_bytes(b"first")
        with atomic_dir(out) as second:  # the other run finishes first
            (second / "a.png").write_bytes(b"second")
    assert (out / "a.png").read_bytes() == b"second"


def test_two_runs_replacing_one_folder_the_second_is_refused_and_journals_are_apart(tmp_path):
    out = tmp_path / "repaired"
    with atomic_dir(out) as tmp:
        (tmp / "a.png").write_bytes(b"old")
    assert journal(out) != journal(out) and journal(out).name.startswith(".repaired.d2sr-")
    with pytest.raises(OutputError, match="changed"), atomic_dir(out) as first:
        (first / "a.png").write_bytes(b"first")
        with atomic_dir(out) as second:
            (second / "a.png").write_bytes(b"second")
    assert (out / "a.png").read_bytes() == b"second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["repaired"]
