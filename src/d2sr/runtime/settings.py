"""One run's settings, from the command line (or a caller) down to the loop: which models, how frames are
judged and repaired, how the recording is read. Frozen and validated once; every function below the CLI
takes the object, not its fields one by one."""

from __future__ import annotations

from pathlib import Path

from pydantic import ConfigDict, Field, ValidationInfo, field_validator

from d2sr.config import Settings
from d2sr.contract.catalog import DEFAULT_MODEL, REPAIR_MODELS, WEIGHTS
from d2sr.desync import CONTROLLERS, DEFAULT_ACTIVE, DEFAULT_CONTROLLER, TOTAL_FRAMES
from d2sr.frames.base import PLAUSIBLE_M
from d2sr.scene import SceneSettings

__all__ = ["DEFAULT_ACTIVE", "PRIME_FRAMES", "REPAIR", "DesyncSettings", "LoopSettings", "RunSettings"]

REPAIR = ("flagged", "all", "none")
BACKENDS = ("auto", "onnx", "torch")
# Frames a recording's loop judges ahead of its first to warm the scene (``SensorLoop.primed``): twice the
# scene's ring, so that with every other frame interfered its 16 clean frames are all judged warm.
PRIME_FRAMES = 32


class RunSettings(Settings):
    """How a run judges and repairs (defaults in brackets). Strict: each field of its own type (a path may be
    given as a string), numbers finite. Errors name the field; the command line says which flag sets it."""

    model_config = ConfigDict(frozen=True, extra="forbid", strict=True, allow_inf_nan=False)

    model: str = Field(DEFAULT_MODEL, description="auto, unet8, unet16, unet32 or unet8-temporal [auto].")
    models: Path = Field(WEIGHTS, description="The folder holding the models [the shipped ones].")
    backend: str = Field("auto", description="auto (onnxruntime when installed), onnx or torch.")
    repair: str = Field("flagged", description="Frames repaired: flagged, all or none [flagged].")
    threshold: float | None = Field(
        None, gt=0, lt=1, description="Detector probability that flags a frame [the detector's own, 0.5]."
    )
    mask_logit: float | None = Field(
        None, description="The recovery mask's threshold, lower repairs more [the model's own]."
    )
    passes: int | None = Field(
        None, ge=1, le=8, description="Recovery model runs per frame [the model's own]."
    )
    scene: bool = Field(True, description="Judge frames against the still sensor's own scene too.")
    scene_repair: bool | None = Field(
        None,
        description="The scene's own depth where it is trusted [on where "
        "frames are judged, off when every frame is repaired].",
    )
    scene_settings: SceneSettings = Field(default_factory=SceneSettings, description="The scene's numbers.")
    scene_from: Path | None = Field(
        None,
        description="A stored scene (d2sr scene learn) the scene starts "
        "from, instead of learning it from the frames.",
    )
    prime: int = Field(
        PRIME_FRAMES,
        ge=0,
        description="A recording's frames the scene learns before its "
        "first is judged (0: none, as a live sensor starts).",
    )
    depth_scale: float | None = Field(None, gt=0, description="Units per metre [what the recording says].")
    recording_scale_wrong: bool = Field(
        False,
        description="The recording's own depth scale is wrong: "
        "depth_scale replaces it (else a depth_scale that contradicts it is refused).",
    )
    max_range: float = Field(
        PLAUSIBLE_M[1], gt=0, description="Farthest median scene depth (m) the scale check accepts."
    )
    topic: str | None = Field(None, description="The depth topic of a bag [its only depth topic].")
    threads: int | None = Field(None, ge=1, description="onnxruntime threads per model [all cores].")
    int8: bool = Field(False, description="The int8 models (d2sr export --int8).")

    @field_validator("model", "backend", "repair")
    @classmethod
    def _known(cls, v: str, info: ValidationInfo) -> str:
        choices = {"model": REPAIR_MODELS, "backend": BACKENDS, "repair": REPAIR}[str(info.field_name)]
        if v not in choices:
            raise ValueError(f"unknown {v!r}; choose from {', '.join(choices)}")
        return v

    @field_validator("models", "scene_from", mode="before")
    @classmethod
    def _path(cls, v: object) -> object:
        return Path(v) if isinstance(v, str) else v

    @field_validator("scene_repair")
    @classmethod
    def _needs_scene(cls, v: bool | None, info: ValidationInfo) -> bool | None:
        if v and not info.data.get("scene", True):
            raise ValueError("the scene's repair needs the scene (scene=True)")
        return v

    @property
    def repairs_scene(self) -> bool:
        """The scene's own depth joins the repair: on where frames are judged or a stored scene is given, off
        when every frame is repaired from a scene learned on the fly (it would judge every frame for it)
        unless asked."""
        if self.scene_repair is None:
            return self.scene and (self.repair != "all" or self.scene_from is not None)
        return self.scene_repair


class DesyncSettings(Settings):
    """One sensor's de-synchronization: its duty-cycle controller, its active window and the controller's
    seed (``d2sr.Pipeline``, the ROS 2 node; ``LoopSettings`` adds what ``d2sr run`` runs on)."""

    model_config = ConfigDict(frozen=True, extra="forbid", strict=True, allow_inf_nan=False)

    controller: str = Field(DEFAULT_CONTROLLER, description="The duty-cycle controller.")
    active_frames: int = Field(
        DEFAULT_ACTIVE,
        ge=1,
        le=TOTAL_FRAMES,
        description="Frames the laser is on per 1 s period (the paper's 20%).",
    )
    seed: int = Field(0, description="Random seed of the controller and the simulated room.")

    @field_validator("controller")
    @classmethod
    def _known_controller(cls, v: str) -> str:
        if v not in CONTROLLERS:
            raise ValueError(f"unknown {v!r}; choose from {', '.join(CONTROLLERS)}")
        return v


class LoopSettings(DesyncSettings):
    """``d2sr run``'s de-synchronization and what it runs on, beside ``RunSettings``."""

    sensors: int = Field(3, ge=1, le=63, description="sim: sensors in the room.")
    seconds: float = Field(20.0, gt=0, description="sim and live: seconds to run.")
    moving: bool = Field(False, description="sim: the last sensor rides a robot.")
    trigger: str | None = Field(None, description="live: the trigger line (a d2sr.triggers spec).")
    fill: bool = Field(False, description="Also write a frame for every slot the laser skipped.")
    colour_topic: str | None = Field(None, description="A bag's colour stream, for fill.")
    report: bool = Field(True, description="Write report.html into the run folder (every source).")
