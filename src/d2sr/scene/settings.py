"""The scene reference's settings: one frozen pydantic model, each field with the reason for its value.
The measurements behind each value are in the research notes (``lab/notes/scene-reference.md``,
``lab/notes/decisions.md``); every value was judged on sets it was not chosen on."""

from __future__ import annotations

from pydantic import Field, model_validator

from d2sr.config import Settings

__all__ = ["SceneSettings"]


class SceneSettings(Settings):
    """How a still sensor's scene is kept and how a frame is judged against it (metres, shares, pixels)."""

    # The ring of clean frames and its upkeep.
    frames: int = Field(16, ge=3, description="Clean frames kept: a pixel's statistics at most this old.")
    warm: int = Field(4, ge=3, description="Clean frames before any evidence: fewer give no quantiles.")
    stripes: int = Field(
        16,
        ge=1,
        description="Row stripes re-summarized one per clean frame: 16 cost a "
        "still L515 frame 4.2-4.4 ms where 8 cost 5.1, with the same verdicts.",
    )
    persist: int = Field(
        30,
        ge=1,
        description="Frames a pixel deviates in a row before its new value is "
        "the scene (a chair moved; a person walking past deviates briefly per pixel).",
    )
    moved: float = Field(
        0.1,
        gt=0,
        le=1,
        description="Share of the known scene deviating that, for "
        "moved_frames frames in a row, means the camera moved: the scene starts again.",
    )
    moved_frames: int = Field(3, ge=1, description="Frames in a row of such change before the restart.")
    elsewhere: float = Field(
        0.7,
        gt=0,
        le=1,
        description="A frame deviating by more is another view and "
        "gets no evidence: other L515 views deviate by 0.81-0.89, interference <= 0.58.",
    )
    rest: int = Field(
        15,
        ge=0,
        description="Frames the scene rests after a restart because the view "
        "changed, doubling per further restart: a moving sensor pays for no scene.",
    )
    rest_max: int = Field(120, ge=0, description="The longest rest (4 s at 30 fps).")
    # Stillness: evidence is used only once the sensor held still.
    still_share: float | None = Field(
        0.1,
        gt=0,
        le=1,
        description="The stillness gate: still L515s deviate "
        "by a median 0.011 a frame, a hand-held D435 by 0.36 (None: a fixed "
        "mount, always still).",
    )
    still_q: float = Field(
        0.25,
        gt=0,
        le=1,
        description="Quantile of recent clean frames' shares the gate "
        "reads: a median shuts it where interfered frames pass as clean.",
    )
    still_frames: int = Field(16, ge=1, description="Recent clean frames the gate reads.")
    still_min: int = Field(1, ge=1, description="Clean frames the gate needs since the scene started.")
    # Deviation: what a pixel's clean range allows.
    tol_abs: float = Field(
        0.005,
        ge=0,
        description="Metres beyond a pixel's clean range that deviate: "
        "tighter than d2sr label's 2 cm, since a surface read 2-5 cm near is the target.",
    )
    tol_rel: float = Field(0.005, ge=0, description="The same, as a share of the range.")
    range_rate: float = Field(
        0.5,
        gt=0,
        le=1,
        description="A pixel's clean range says where its surface is "
        "only where it returned this often; a return where it seldom does is kept.",
    )
    trust_rate: float = Field(
        0.9,
        gt=0,
        le=1,
        description="A pixel returning this often is steady: its "
        "dropout is interference, and the repair trusts its depth.",
    )
    trust_abs: float = Field(
        0.02,
        ge=0,
        description="Metres a trusted pixel's clean depths spread at most "
        "(its own noise, not a model's 10%).",
    )
    trust_rel: float = Field(0.01, ge=0, description="The same, as a share of the range.")
    split_part: float = Field(
        0.25,
        gt=0,
        le=0.5,
        description="A pixel whose clean returns part into two depths, "
        "each with this share of them or more, tells no surface (interference the detector passed, repeating "
        "at one place in a third of the frames or more): parted at 0.25, 97-99.8% of a real L515 band read "
        "30 cm off in every other frame or two of three; 0.02-0.1% of clean L515 pixels, 0.01-0.07% of the "
        "real Kinect v2's interfered ones (its offsets scatter about the truth).",
    )
    # Verdicts on a whole frame.
    quiet: float = Field(
        0.0005,
        gt=0,
        le=1,
        description="Dense evidence below this share: the frame matches "
        "its scene, a detector's flag on it is a false alarm.",
    )
    evident: float = Field(
        0.003,
        gt=0,
        le=1,
        description="Fresh dense evidence at this share flags a frame "
        "whatever the detector says: keeps a walking person within 1% of frames flagged.",
    )
    # Surfaces read a little off as a whole (a CW-ToF camera's light).
    shift_px: int = Field(
        15,
        ge=3,
        le=15,
        description="Side (px) of the window whose mean tells a shifted "
        "surface; at most 15, since a window's count of pixels is kept in a byte (15 x 15 = 225).",
    )
    shift_m: float = Field(
        0.01,
        gt=0,
        description="Metres a window's mean reads off to be shifted: half "
        "of it per pixel changed over 2% of clean pixels.",
    )
    shift_rate: float = Field(
        0.7,
        gt=0,
        le=1,
        description="Windows are worked out over pixels returning this "
        "often: real L515 surfaces flicker more than trust_rate allows.",
    )
    shift_area: float = Field(
        0.01,
        gt=0,
        le=1,
        description="Fresh shifted windows over this share flag a "
        "frame: twice the most a clean frame reached (0.0043).",
    )
    offset_cap: float = Field(
        0.05,
        gt=0,
        description="The most (m) a shifted surface's offset replaces the "
        "scene's fill: a CW-ToF camera shifts 2-5 cm; beyond, the median does better.",
    )
    off_m: float = Field(
        0.02,
        gt=0,
        description="Metres half a window's pixels read off, either way, for "
        "a rippled or blotched surface whose mean stays about right.",
    )
    off_area: float = Field(
        0.001,
        gt=0,
        le=1,
        description="Fresh off windows over this share flag a frame: "
        "twice the most a clean frame reached (0.00049).",
    )
    # Returns read far off (thin lines and dots of interference).
    far_abs: float = Field(
        0.1,
        gt=0,
        description="Metres beyond a pixel's clean range that read far off: "
        "the sensor's own flicker does not go that far.",
    )
    far_rel: float = Field(0.05, ge=0, description="The same, as a share of the range.")
    far_area: float = Field(
        0.001,
        gt=0,
        le=1,
        description="Fresh far-off returns over this share flag a "
        "frame: twice the most a clean frame reached.",
    )
    # Something that moved explains a deviation; interference flickers.
    motion_px: int = Field(15, ge=1, description="Pixels a moving surface travels between two frames.")
    motion_abs: float = Field(
        0.05, ge=0, description="Metres a deviation reads near one of the frame before to be that surface."
    )
    motion_rel: float = Field(0.05, ge=0, description="The same, as a share of the range.")
    flicker_m: float = Field(
        0.01,
        gt=0,
        description="Metres a patch on a full live scene's surface changed "
        "since the frame before (a shift_px window's mean) to be interference the motion test would explain, "
        "and the most the scene's clean returns may part there: a real Kinect v2's interfered pixels change "
        "by a median 18 mm frame to frame, its frames alone by 1 mm.",
    )

    @model_validator(mode="after")
    def _warm_within_ring(self) -> SceneSettings:
        if self.warm > self.frames:
            raise ValueError(f"need warm <= frames, got warm={self.warm}, frames={self.frames}")
        return self
