"""Simulators (numpy only): the multi-sensor timing world; scenes and interference come later."""

from d2sr.sim.overlap import OverlapGraph
from d2sr.sim.timing import TimingRun, TimingSettings, simulate

__all__ = ["OverlapGraph", "TimingRun", "TimingSettings", "simulate"]
