"""[Retired from src/ in issue 64 (moving_scene failed sealed set J); as it ran at 8577bfa.] The moving sensor's scene reference (d2sr.moving_reference): frames judged against the last clean frames
warped into their view by the caller's pose, and the loop's experimental use of it (off by default)."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.desync import make_controller
from d2sr.errors import ConfigError, InputError
from d2sr.frames import Frame
from d2sr.frames.base import Intrinsics
from d2sr.moving_reference import MovingReference
from d2sr.reference import EVIDENT
from d2sr.runtime.loop import Capture, SensorLoop
from d2sr.synth.warp import Pose
from test_runtime import FakeNet

SCALE = 1000.0
K = Intrinsics(160, 120, 150.0, 150.0, 79.5, 59.5)
PATCH = np.s_[40:80, 50:110]


def _view(x: float) -> np.ndarray:
    """A wall 3 m ahead seen by a camera moved ``x`` m sideways (a wall is the same at every x), with a
    box 2 m ahead fixed in the world: it moves across the view as the camera does."""
    z = np.full((K.height, K.width), 3.0)
    u = np.arange(K.width)
    box_u = K.px + (0.0 - x) / 2.0 * K.fx  # the box's centre column
    z[30:90, (np.abs(u - box_u) < 20)] = 2.0
    return np.rint(z * SCALE).astype(np.uint16)


def _at(x: float) -> Pose:
    return Pose(np.eye(3), np.array([x, 0.0, 0.0]))


def _shifted(frame: np.ndarray, cm: float) -> np.ndarray:
    out = frame.copy()
    out[PATCH] = np.where(out[PATCH] > 0, out[PATCH] - int(cm * SCALE / 100), 0)
    return out


def test_a_moved_view_of_the_same_scene_is_not_evidence_and_a_shifted_patch_is():
    ref = MovingReference(SCALE, K)
    assert not ref.evidence(_view(0.0), _at(0.0)).ready  # nothing seen yet
    ref.add(_view(0.0), _at(0.0))
    ref.add(_view(0.05), _at(0.05))
    clean = ref.evidence(_view(0.1), _at(0.1))  # the box has moved 7 px in the view: the warp follows it
    assert clean.ready and clean.dense < EVIDENT and clean.mask.mean() < 0.002
    hit = ref.evidence(_shifted(_view(0.1), 3), _at(0.1))  # 3 cm nearer, no dropouts
    assert hit.mask[PATCH].mean() > 0.6 and hit.dense > 0.05
    assert hit.mask[:, :40].mean() < 0.002
    # the same frame judged as if the camera had not moved: the box's edge deviates
    wrong = MovingReference(SCALE, K)
    wrong.add(_view(0.0), _at(0.0))
    assert wrong.evidence(_view(0.1), _at(0.0)).mask.sum() > clean.mask.sum() + 100


def test_dropouts_are_not_evidence_and_one_missed_frame_does_not_make_the_next_deviate():
    ref = MovingReference(SCALE, K)
    ref.add(_view(0.0), _at(0.0))
    holes = _view(0.05)
    holes[PATCH] = 0
    assert ref.evidence(holes, _at(0.05)).dense == 0  # which returns drop out depends on the view
    ref.add(_shifted(_view(0.05), 3), _at(0.05))  # an interfered frame the loop missed
    assert ref.evidence(_view(0.1), _at(0.1)).dense < EVIDENT  # it deviates from one reference only
    one = MovingReference(SCALE, K, frames=1)
    one.add(_shifted(_view(0.05), 3), _at(0.05))
    assert one.evidence(_view(0.1), _at(0.1)).dense > EVIDENT  # against the missed frame alone it would


def test_moving_reference_refuses_what_it_cannot_judge():
    with pytest.raises(ConfigError):
        MovingReference(0.0)
    with pytest.raises(ConfigError):
        MovingReference(SCALE, frames=0)
    ref = MovingReference(SCALE)
    with pytest.raises(InputError):
        ref.add(np.zeros((4, 4), np.float32), _at(0.0))
    ref.add(np.zeros((4, 4), np.uint16), _at(0.0))
    assert ref.intrinsics is not None and ref.intrinsics.width == 4  # guessed from the frame
    with pytest.raises(InputError):
        ref.evidence(np.zeros((4, 5), np.uint16), _at(0.0))


def test_the_loop_weighs_poses_only_when_the_experiment_is_on():
    """``moving_scene`` (off: it failed sealed set J) flags the shifted patch the detector passes; with it
    off, a frame's pose changes nothing."""

    def run(moving: bool) -> list[bool]:
        loop = SensorLoop(FakeNet(), make_controller("static", 30, 30), repair="none", scene=True,
                          moving_scene=moving, intrinsics=K)  # fmt: skip
        flags = []
        for i, x in enumerate((0.0, 0.02, 0.04, 0.06, 0.08)):
            f = _shifted(_view(x), 3) if i == 4 else _view(x)
            flags.append(loop.process(Capture(Frame(f"{i}", f), SCALE, pose=_at(x))).flagged)
        return flags

    assert run(True) == [False, False, False, False, True]
    assert run(False) == [False] * 5
