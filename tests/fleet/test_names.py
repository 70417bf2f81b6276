"""Where each recording goes in a fleet's folder (d2sr.fleet.names) and its record (d2sr.fleet.ledger): names
are read from paths and made safe; the record is data."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from d2sr.errors import InputError, OutputError
from d2sr.fleet.ledger import LEDGER, Ledger
from d2sr.fleet.names import output_names


def test_names_are_the_recordings_own_told_apart_by_their_folders_and_safe(tmp_path):
    for p in ("r1/cam0", "r2/cam0", "solo", "a b/.hidden", "x/run.npz"):
        (tmp_path / p).mkdir(parents=True)
    paths = [tmp_path / p for p in ("r1/cam0", "r2/cam0", "solo", "a b/.hidden", "x/run.npz")]
    assert output_names(paths) == ["r1__cam0", "r2__cam0", "solo", "_hidden", "run"]
    with pytest.raises(InputError, match="given twice"):
        output_names([paths[0], tmp_path / "r1" / ".." / "r1" / "cam0"])


NAMES = st.text(min_size=1, max_size=12).filter(lambda t: "/" not in t and "\x00" not in t)


@settings(max_examples=60, deadline=None)
@given(st.lists(NAMES, min_size=1, max_size=5, unique=True))
def test_any_names_give_distinct_plain_folder_names(tmp_path_factory, parts):
    root = tmp_path_factory.mktemp("n")
    paths = [root / p for p in parts if p not in (".", "..")]
    if not paths:
        return
    names = output_names(paths)
    assert len(set(names)) == len(names)
    for n in names:
        assert n and not n.startswith(".") and "/" not in n and n not in (".", "..")


@settings(max_examples=80, deadline=None)
@given(st.one_of(st.binary(max_size=200), st.dictionaries(st.text(max_size=8), st.integers(), max_size=4)))
def test_a_record_that_is_not_a_fleet_s_is_refused_in_one_line(tmp_path_factory, junk):
    root = tmp_path_factory.mktemp("l")
    data = junk if isinstance(junk, bytes) else json.dumps({"made_by": "d2sr 1", **junk}).encode()
    (root / LEDGER).write_bytes(data)
    try:
        ledger = Ledger.read(root)
    except OutputError as exc:
        assert "\n" not in str(exc) and "not a d2sr fleet's record" in str(exc)
    else:
        assert ledger is not None


def test_a_record_naming_paths_is_read_as_names_only(tmp_path):
    body = {"made_by": "d2sr 0.10.0", "settings": {}, "recordings": [
        {"name": "../../etc", "input": "/etc/passwd", "status": "done"}]}  # fmt: skip
    (tmp_path / LEDGER).write_text(json.dumps(body))
    ledger = Ledger.read(tmp_path)
    assert ledger is not None and ledger.settled()["../../etc"].input == "/etc/passwd"
    assert Path("../../etc").name not in {p.name for p in tmp_path.iterdir()}  # nothing was followed
