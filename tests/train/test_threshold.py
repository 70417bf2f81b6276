"""`d2sr threshold`: a recovery model's mask threshold chosen again, written beside new, never in place."""

import hashlib
import shutil

import onnx
import pytest
from safetensors.torch import load_file

from d2sr.contract.catalog import WEIGHTS
from d2sr.models.store import mask_logit, read_card
from d2sr.train.loop import MASK_LOGITS, MAX_CLEAN_CHANGED
from helpers import d2sr


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_threshold_writes_the_same_weights_with_the_rule_kept(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for ext in (".safetensors", ".card.json"):
        shutil.copy(WEIGHTS / f"unet8{ext}", src / f"unet8{ext}")
    before = _digest(src / "unet8.safetensors")
    out = tmp_path / "out"
    few = ("--cache", str(tmp_path / "c"), "--validation", "20")  # the rule is the same on fewer frames
    res = d2sr("threshold", str(src / "unet8.safetensors"), "--out", str(out), *few)
    assert res.returncode == 0, res.stderr
    assert _digest(src / "unet8.safetensors") == before  # the input is never written
    new = out / "unet8.safetensors"
    a, b = load_file(src / "unet8.safetensors"), load_file(new)
    assert a.keys() == b.keys() and all((a[k] == b[k]).all() for k in a)
    card = read_card(new)
    chosen = card["training"]["mask_threshold"]
    assert mask_logit(new) == chosen["mask_logit"] in MASK_LOGITS
    assert chosen["as_recovered"]["clean_changed"] <= MAX_CLEAN_CHANGED and "20 generated" in chosen["rule"]
    assert card["rethreshold"]["was"] == mask_logit(src / "unet8.safetensors") and "metrics" not in card
    meta = {p.key: p.value for p in onnx.load(str(out / "unet8.onnx")).metadata_props}
    assert float(meta["mask_logit"]) == chosen["mask_logit"]
    # an existing output is refused; the weights' own folder is never the output
    again = d2sr("threshold", str(new), "--out", str(out), *few)
    inside = d2sr("threshold", str(new), "--out", str(out / "x"), *few)
    assert again.returncode == 2 and inside.returncode == 2
    assert "Traceback" not in again.stderr + inside.stderr


@pytest.mark.slow  # a subprocess: not in make test-fast
def test_threshold_refuses_what_is_not_a_recovery_model(tmp_path):
    res = d2sr("threshold", str(WEIGHTS / "detector.safetensors"), "--out", str(tmp_path / "o"))
    assert (
        res.returncode == 2
        and "not a recovery model" in res.stderr
        and len(res.stderr.strip().splitlines()) == 1
    )
    res = d2sr("threshold", str(tmp_path / "none.safetensors"), "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and "no such weights file" in res.stderr
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"not a model")
    res = d2sr("threshold", str(bad), "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow  # generates frames with their last clean frames and runs the model on them
def test_a_gated_temporal_model_is_chosen_for_on_lined_up_frames_only(tmp_path):
    import numpy as np

    from d2sr.models.store import load_model
    from d2sr.sim.dataset import VALIDATION_SEED
    from d2sr.train.data import lines_up, synth_set
    from d2sr.train.loop import choose_mask_logit

    model, _ = load_model(WEIGHTS / "unet8-temporal.safetensors")
    ss = synth_set(tmp_path, 20, VALIDATION_SEED, progress=False, previous=True)
    hit = np.flatnonzero(ss.labels)
    up = sum(lines_up(ss.frames[i], ss.previous[i], float(ss.scales[i])) for i in hit)
    assert 0 < up < len(hit)  # these seeds hold both kinds
    gated = choose_mask_logit(model, tmp_path, False, 20, gate_previous=True)
    plain = choose_mask_logit(model, tmp_path, False, 20)
    assert f"the {up} interfered ones whose last clean frame lines up" in gated["rule"]
    assert "lines up" not in plain["rule"] and gated["rmse_cm"] != plain["rmse_cm"]
