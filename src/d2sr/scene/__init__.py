"""A still sensor's scene: the statistics of its clean frames (``stats``), the labelling of a recording
against them (``labeller``, ``d2sr label``), and the reference kept online that judges each frame
(``reference``, ``evidence``) with its settings (``settings``). Numpy and OpenCV only."""

from d2sr.scene.evidence import Evidence, SceneRepair
from d2sr.scene.labeller import METHODS, THRESHOLDS, Labeller, f1, label_frames
from d2sr.scene.reference import SceneReference
from d2sr.scene.settings import SceneSettings
from d2sr.scene.stats import CleanStats, clean_stats, stack_stats

__all__ = [
    "METHODS",
    "THRESHOLDS",
    "CleanStats",
    "Evidence",
    "Labeller",
    "SceneReference",
    "SceneRepair",
    "SceneSettings",
    "clean_stats",
    "f1",
    "label_frames",
    "stack_stats",
]
