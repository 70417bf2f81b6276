"""One run's settings (d2sr.runtime.settings): one frozen, strict object from the command line to the loop;
its errors name the setting, and the command line the flag that sets it."""

from __future__ import annotations

import math

import pytest

import d2sr
from d2sr.errors import ConfigError
from d2sr.runtime.pipeline import settings_of
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.scene import SceneSettings
from helpers import d2sr_inprocess


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("threshold", 1.5),
        ("threshold", "0.5"),  # strict: no string taken for a number
        ("mask_logit", math.nan),
        ("passes", True),  # a bool is not a count
        ("passes", 9),
        ("model", "unet9"),
        ("backend", "cuda"),
        ("repair", "some"),
        ("max_range", math.inf),
        ("depth_scale", 0),
        ("prime", -1),
    ],
)
def test_a_bad_setting_is_a_config_error_naming_it(field, value):
    with pytest.raises(ConfigError) as err:
        RunSettings(**{field: value})
    assert err.value.setting == field and field in str(err.value) and len(str(err.value).splitlines()) == 1


def test_settings_are_frozen_and_the_scene_s_repair_needs_the_scene():
    s = RunSettings()
    with pytest.raises(Exception):  # noqa: B017 - pydantic's frozen-instance error
        s.threshold = 0.9  # type: ignore[misc]
    assert RunSettings(models="some/folder").models.name == "folder"  # a path may come as a string
    with pytest.raises(ConfigError, match="needs the scene") as err:
        RunSettings(scene=False, scene_repair=True)
    assert err.value.setting == "scene_repair"
    # Unset, the scene repairs where frames are judged, not when every frame is repaired.
    assert RunSettings().repairs_scene and not RunSettings(repair="all").repairs_scene
    assert RunSettings(repair="all", scene_repair=True).repairs_scene
    assert not RunSettings(scene=False).repairs_scene


def test_fields_by_keyword_go_over_the_object_and_unknown_ones_are_refused():
    base = RunSettings(model="unet8", threshold=0.6)
    s = settings_of(base, {"passes": 1})
    assert (s.model, s.threshold, s.passes) == ("unet8", 0.6, 1)
    assert settings_of(base, {}) is base and settings_of(None, {}) == RunSettings()
    with pytest.raises(ConfigError, match="unknown setting 'treshold'"):
        settings_of(base, {"treshold": 0.6})
    with pytest.raises(ConfigError, match="settings must be RunSettings"):
        settings_of({"model": "unet8"}, {})  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="shift_area"):
        RunSettings(scene_settings=SceneSettings(shift_area=2.0))


def test_the_library_takes_the_object_or_its_fields():
    with pytest.raises(ConfigError, match="threshold"):
        d2sr.Pipeline(depth_scale=4000, threshold=2.0)
    with pytest.raises(ConfigError, match="controller"):
        LoopSettings(controller="nope")
    with pytest.raises(ConfigError, match="active_frames"):
        LoopSettings(active_frames=31)


def test_the_command_line_names_the_flag_that_sets_a_bad_setting(tmp_path):
    src = tmp_path / "rec"
    src.mkdir()
    code, _, err = d2sr_inprocess("recover", str(src), "--out", str(tmp_path / "o"), "--mask-logit", "nan")
    assert code == 2 and "error: --mask-logit: Input should be a finite number (got nan)" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()
