"""What a fleet reads back from fleet.json is data (issue 79): bounded, its control characters escaped."""

from __future__ import annotations

import json

import pytest

from d2sr.errors import OutputError
from d2sr.fleet.ledger import LINE, WARNINGS, Ledger, Outcome, printable


def test_warnings_and_reasons_read_back_are_one_bounded_printable_line_each():
    o = Outcome(
        name="a", input="a", status="failed", reason="bad\x1b[2J\rhidden",
        warnings=["x" * 10_000, "ring\x07", *(["more"] * 500)],
    )  # fmt: skip
    assert o.reason == "bad\\x1b[2J\\rhidden"
    assert len(o.warnings) == WARNINGS and len(o.warnings[0]) == LINE and o.warnings[0].endswith("…")
    assert o.warnings[1] == "ring\\x07"
    assert printable("plain words, é and 深度") == "plain words, é and 深度"


def test_a_record_too_large_or_too_deep_is_refused_in_one_line(tmp_path):
    (tmp_path / "fleet.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(OutputError, match="not a d2sr fleet's record"):
        Ledger.read(tmp_path)
    body = {"made_by": "d2sr 0.10.0", "settings": {}, "recordings": []}
    (tmp_path / "fleet.json").write_text(json.dumps(body))
    assert Ledger.read(tmp_path) is not None
