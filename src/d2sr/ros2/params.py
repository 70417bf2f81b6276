"""A ROS 2 parameters file for ``d2sr ros2`` (``--params-file``), in ROS 2's own layout::

    d2sr:                      # the node's name (``--node-name``), or /** for every node
      ros__parameters:
        topic: /camera/depth/image_rect_raw   # or a list: [/cam1/depth/image_rect_raw, ...]
        depth_scale: 1000.0
        active_frames: 6

Keys are the command's options with ``_`` for ``-``, and ``<stream>_qos`` for a stream's own QoS profile;
a flag given on the command line wins over the file.
The file is data: read with a safe YAML loader, every key and value checked, anything else refused in one
line."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import (
    AliasChoices,
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    create_model,
    field_validator,
)

from d2sr.errors import ConfigError, InputError
from d2sr.runtime.settings import LoopSettings, RunSettings

__all__ = ["NodeParams", "read_params"]

MAX_BYTES = 1 << 20  # a parameters file is a few lines; a larger one is not one
Profile = Literal["SENSOR_DATA", "SYSTEM_DEFAULT", "DEFAULT"]  # d2sr.ros2.node.PROFILES


def _as_set(settings: type[BaseModel], *names: str) -> dict[str, Any]:
    """``names``' types as the settings declare them, each optional here (a file sets some keys only)."""
    types: dict[str, Any] = {n: settings.model_fields[n].annotation for n in names}
    return {n: (t | None, None) for n, t in types.items()}


class _NodeOnly(BaseModel):
    """The node's own parameters, which no settings object holds."""

    model_config = ConfigDict(extra="forbid", strict=False)

    topic: str | list[str] | None = None  # a list: several cameras in one process
    qos: str | None = None
    transport: str | None = None
    node_name: str | None = None
    namespace: str | None = None
    remap: list[str] | None = None  # ROS 2's FROM:=TO rules
    trigger: str | list[str] | None = None  # with several topics, one per topic
    colour_topic: str | list[str] | None = None
    scene_from: Path | list[Path] | None = None  # with several topics, one per topic
    # Each stream's QoS (rclcpp's profile names; realsense-ros names its own depth_qos and info_qos alike):
    # what the node reads takes SENSOR_DATA, what it writes --qos's, unless set here.
    depth_qos: Profile | None = None
    info_qos: Profile | None = None
    # realsense-ros and orbbec_camera spell it color_qos: the file takes theirs too.
    colour_qos: Profile | None = Field(None, validation_alias=AliasChoices("colour_qos", "color_qos"))
    repaired_qos: Profile | None = None
    mask_qos: Profile | None = None
    status_qos: Profile | None = None
    camera_info_qos: Profile | None = None
    diagnostics_qos: Profile | None = None
    confidence_qos: Profile | None = None

    @field_validator(
        "depth_scale",
        "active_frames",
        "threshold",
        "mask_logit",
        "passes",
        "seconds",
        mode="before",
        check_fields=False,
    )
    @classmethod
    def _not_a_switch(cls, v: object) -> object:
        """YAML's true is no number (pydantic's lax mode would read it as 1)."""
        if isinstance(v, bool):
            raise ValueError("a number, not true or false")
        return v


# The parameters ``d2sr ros2`` takes from a file (each as its flag): the node's own, and the settings'
# fields the node passes on, typed as those settings type them.
NodeParams = create_model(
    "NodeParams",
    __base__=_NodeOnly,
    **_as_set(
        RunSettings, "depth_scale", "repair", "model", "models", "threshold", "mask_logit", "passes", "scene"
    ),
    **_as_set(LoopSettings, "controller", "active_frames", "seconds"),
)


def read_params(path: Path, node_name: str) -> dict[str, Any]:
    """The parameters for node ``node_name`` in ``path`` (its own section, then ``/**``'s beneath it), as
    ``{option: value}`` of the options the file sets."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        if path.stat().st_size > MAX_BYTES:
            raise InputError(
                f"{path}: larger than {MAX_BYTES // 1024} KiB; not a parameters file", "params_file"
            )
        data = YAML(typ="safe", pure=True).load(path.read_text(errors="strict"))
    except (OSError, UnicodeError) as exc:
        raise InputError(
            f"{path}: cannot read it ({getattr(exc, 'strerror', None) or exc})", "params_file"
        ) from None
    except (YAMLError, ValueError, RecursionError) as exc:  # a 5,000-digit number, nesting 30,000 deep
        text = str(exc).strip()
        first = text.splitlines()[0][:200] if text else type(exc).__name__
        raise InputError(f"{path}: not YAML d2sr reads ({first})", "params_file") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: not a ROS 2 parameters file (node: ros__parameters: ...)", "params_file")
    merged: dict[str, Any] = {}
    for key in ("/**", node_name, "/" + node_name):
        section = data.get(key)
        if section is None:
            continue
        params = section.get("ros__parameters") if isinstance(section, dict) else None
        if not isinstance(params, dict):
            raise InputError(f"{path}: {key}: has no ros__parameters mapping", "params_file")
        merged |= params
    try:
        checked = NodeParams.model_validate(merged)
    except ValidationError as exc:
        e = exc.errors()[0]
        key = str(e["loc"][0]) if e["loc"] else "?"
        if len(exc.errors()) > 1 and all(x["loc"][:1] == e["loc"][:1] for x in exc.errors()):
            # a key that takes one value or a list of them (topic, trigger, ...) fitted neither
            raise ConfigError(f"{path}: {key}: expected one value or a list of them", "params_file") from None
        where = ".".join(str(p) for p in e["loc"]) or "?"
        raise ConfigError(f"{path}: {where}: {e['msg']}", "params_file") from None
    return checked.model_dump(exclude_unset=True)
