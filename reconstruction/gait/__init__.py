"""Gait analysis from 3D trajectories: bouts, events, spatiotemporal parameters, walkway comparison.

Entry points: :func:`analyze_gait` (one trial -> :class:`GaitReport`) and :func:`compare_with_walkway`
(a session's trials vs a walkway export -> ``WalkwayComparison``).
"""

from reconstruction.gait.analysis import analyze_gait, compare_with_walkway
from reconstruction.gait.config import GaitConfig
from reconstruction.gait.quality import TrajectoryQuality
from reconstruction.gait.report import GaitReport
from reconstruction.gait.walkway import AlignmentConfig, WalkwayComparison, WalkwayTrial, read_walkway_csv

__all__ = [
    "AlignmentConfig", "GaitConfig", "GaitReport", "TrajectoryQuality", "WalkwayComparison", "WalkwayTrial",
    "analyze_gait", "compare_with_walkway", "read_walkway_csv",
]
