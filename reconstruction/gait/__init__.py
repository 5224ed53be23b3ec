"""Gait analysis from 3D trajectories: bouts, events, spatiotemporal parameters, walkway comparison.

Entry points: :func:`analyze_gait` (one trial -> :class:`GaitReport`) and :func:`compare_with_walkway`
(a session's trials vs a walkway export -> ``WalkwayComparison``).
"""

from gaitcap.reconstruction.gait.analysis import analyze_gait, compare_with_walkway
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.reconstruction.gait.quality import TrajectoryQuality
from gaitcap.reconstruction.gait.report import GaitReport
from gaitcap.reconstruction.gait.walkway import (
    AlignmentConfig,
    WalkwayComparison,
    WalkwayTrial,
    walkway_from_csv_text,
)

__all__ = [
    "AlignmentConfig", "GaitConfig", "GaitReport", "TrajectoryQuality", "WalkwayComparison", "WalkwayTrial",
    "analyze_gait", "compare_with_walkway", "walkway_from_csv_text",
]
