"""tools/verify_results.py: a re-made result is compared with the committed one figure by figure."""

from __future__ import annotations

import json

from tools.verify_results import CHEAP, differences

from helpers import ROOT


def test_a_figure_edited_by_hand_is_named_and_provenance_is_not_a_figure():
    kept = json.loads((ROOT / "docs/results/kinect2_cam0.json").read_text())
    same = json.loads(json.dumps(kept))
    same["commit"], same["date"], same["cpu"] = "0" * 40, "2030-01-01", "another machine"
    assert differences(same, kept) == []
    edited = json.loads(json.dumps(kept))
    edited["settings"]["as shipped, stored scene"]["put_back"] = 0.9
    assert differences(kept, edited) == [
        "settings.as shipped, stored scene.put_back: 0.9 -> "
        + repr(kept["settings"]["as shipped, stored scene"]["put_back"])
    ]
    edited = json.loads(json.dumps(kept))
    del edited["settings"]["--repair all"]
    assert differences(kept, edited) == ["settings.--repair all: not committed"]


def test_every_cheap_result_is_committed_with_its_command():
    for rel, args in CHEAP.items():
        result = json.loads((ROOT / rel).read_text())
        module = args[args.index("-m") + 1]
        assert result["command"].startswith(f"python -m {module} ")
