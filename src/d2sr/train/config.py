"""Training settings (pydantic, read from TOML)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal

from pydantic import Field, model_validator

from d2sr.config import Settings

if TYPE_CHECKING:
    from d2sr.sim.rooms import SensorModel

VALIDATION_FRAMES = 100  # generated frames that choose a recovery model's mask threshold

__all__ = ["Folders", "TrainSettings"]


class Folders(Settings):
    """Labelled frames of your own: interfered ``input``, ground-truth ``target`` depth and optional
    ``masks`` (as written by ``d2sr simulate`` per sensor: depth/clean/masks, or by ``d2sr label``)."""

    input: Path
    target: Path
    masks: Path | None = None
    topic: str | None = None


MAX_BATCH = 1024  # frames a step: beyond any machine's memory at 640x480 (a billion hung making its indices)


class TrainSettings(Settings):
    task: Literal["detector", "recovery"]
    model: str = Field("detector", description="a name from d2sr.models.MODELS")
    seed: int = 0
    steps: int = Field(3000, ge=1)
    batch: int = Field(16, ge=1, le=MAX_BATCH)
    lr: float = Field(2e-3, gt=0)
    weight_decay: float = Field(1e-4, ge=0)
    init: Path | None = Field(None, description="weights to start from (fine-tuning); see warm_start")
    crop: tuple[int, int] = Field((192, 256), description="recovery trains on crops (height, width)")
    mask_weight: float = Field(3.0, ge=0, description="recovery: weight of the mask head's BCE")
    mask_error_weight: float = Field(
        0.0,
        ge=0,
        description="recovery: an interfered pixel's mask BCE weighs 1 + this x its depth error in metres "
        "(capped at 2 m), rescaled to mean 1 over the batch's interfered pixels: a missed pixel costs RMSE "
        "by its error (0: every pixel alike)",
    )
    dice: float = Field(1.0, ge=0, description="recovery: weight of the soft-F1 (Dice) term on the mask")
    clean_share: float = Field(0.25, ge=0, le=1, description="recovery: share of clean frames in a batch")
    second_pass: float = Field(
        0.0,
        ge=0,
        le=1,
        description="recovery: share of interfered frames trained on as recover's second pass sees them "
        "(the frame with the model's own guarded first repair filled in)",
    )
    gate_previous: bool = Field(
        False,
        description="temporal recovery: a last clean frame that does not line up with the frame "
        "(contract.agreement below LINES_UP) is given as none in training, and the mask threshold is chosen "
        "on the lined-up frames only: --model auto gives the others to the single-frame model",
    )
    clean_previous: bool = Field(
        False,
        description="temporal detector: its second input is the sensor's last clean frame where it lines up "
        "with the frame (contract.agreement >= LINES_UP), else the frame itself; never an interfered one, so "
        "a difference from it means this frame is hit",
    )
    warp_interference: float = Field(
        0.0,
        ge=0,
        le=1,
        description="recovery: share of interfered frames whose interference is moved by a smooth random "
        "displacement before training (train.data.warp_interference): shapes no generator family has",
    )
    stack_interference: float = Field(
        0.0,
        ge=0,
        le=1,
        description="recovery: chance that an interfered frame also gets another interfered frame's pattern "
        "(its mask and depth ratio, as a further sensor's), drawn in proportion to its share of pixels hit, "
        "and again for each further one (at most 3): heavily hit frames, rare among generated ones",
    )
    mirror_interference: float = Field(
        0.0,
        ge=0,
        le=1,
        description="recovery: share of interfered frames whose hit returns take the inverse of their depth "
        "ratio (train.data.mirror_pattern): too short becomes too far by the same factor and back, so every "
        "shape the generator draws also reads as a delayed echo",
    )
    shell_interference: float = Field(
        0.0,
        ge=0,
        le=1,
        description="recovery: share of interfered frames that also get a pattern confined to one shell of "
        "the scene's depth (sim.families.shell_interference): hit regions that follow the room's surfaces",
    )
    teacher: Path | None = Field(
        None,
        description="recovery: weights of a recovery model whose repair, as recover makes it (its passes, "
        "its own mask threshold), the model also learns from beside the truth (distillation)",
    )
    teacher_weight: float = Field(
        1.0, ge=0, description="recovery: weight of the teacher's mask and depth beside the truth's"
    )
    synthetic: int = Field(4000, ge=0, description="generated frames (0: only folders)")
    cw_tof: int = Field(
        0,
        ge=0,
        description="frames of continuous-wave ToF interference (sim.cwtof) made from the generated set's "
        "first clean frames, trained on beside it",
    )
    validation: int = Field(
        VALIDATION_FRAMES,
        ge=2,
        description="recovery: generated validation frames that choose the mask threshold",
    )
    min_share: float = Field(
        0.003,
        ge=0,
        lt=1,
        description="detector: interfered frames with a smaller share of pixels changed are not trained on "
        "(a handful of changed pixels is not something a frame-level label can teach)",
    )
    leave_out: tuple[str, ...] = Field(
        (), description="interference families whose frames are left out of training (generalization tests)"
    )
    cache: Path = Field(Path("out/data"), description="where generated data sets are kept")
    sensor: Path | None = Field(
        None,
        description="a calibration.json from d2sr calibrate: generated L515 frames (training and the "
        "mask threshold's validation) are drawn around its fit instead of the shipped one",
    )
    folders: tuple[Folders, ...] = ()
    checkpoint_every: int = Field(250, ge=1)
    time_limit_min: float = Field(0, ge=0, description="stop early after this many minutes (0: none)")

    def sensor_model(self) -> SensorModel | None:
        """The L515 fit of ``sensor`` (None: the shipped fit)."""
        from d2sr.sim.calibrate import fitted_model

        return fitted_model(self.sensor) if self.sensor is not None else None

    @model_validator(mode="after")
    def _check(self) -> TrainSettings:
        from d2sr.contract.catalog import DETECTOR_NAMES, PAD, RECOVERY_NAMES, TEMPORAL_RECOVERY

        if self.model not in DETECTOR_NAMES + RECOVERY_NAMES:
            raise ValueError(
                f"unknown model {self.model!r}; choose from {', '.join(DETECTOR_NAMES + RECOVERY_NAMES)}"
            )
        want = DETECTOR_NAMES if self.task == "detector" else RECOVERY_NAMES
        if self.model not in want:
            raise ValueError(f"task {self.task} takes one of {', '.join(want)}, not {self.model}")
        if self.sensor is not None:
            self.sensor_model()  # a bad file fails here, not after the data set is generated
        if self.synthetic == 0 and not self.folders:
            raise ValueError("no data: set synthetic > 0 or give folders")
        from d2sr.sim.families import FAMILIES

        if set(self.leave_out) - set(FAMILIES):
            raise ValueError(f"leave_out takes families among {', '.join(FAMILIES)}, got {self.leave_out}")
        if self.crop[0] % PAD or self.crop[1] % PAD:
            raise ValueError(f"crop must be multiples of {PAD}, got {self.crop}")
        augments = ("warp", "stack", "mirror", "shell")
        if self.task != "recovery" and any(getattr(self, f"{a}_interference") for a in augments):
            raise ValueError("the *_interference settings are for recovery models")
        if self.teacher is not None and (self.task != "recovery" or not self.teacher.is_file()):
            raise ValueError(f"teacher must be a recovery model's weights file, got {self.teacher}")
        if self.clean_previous and self.model != "detector-temporal":
            raise ValueError(f"clean_previous is for the temporal detector, not {self.model}")
        if self.gate_previous and self.model != TEMPORAL_RECOVERY:
            raise ValueError(
                f"gate_previous is for the temporal recovery model ({TEMPORAL_RECOVERY}), not {self.model}"
            )
        return self
