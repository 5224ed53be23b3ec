"""Settings of the per-frame cross-view association."""

from __future__ import annotations

from dataclasses import dataclass

from gaitcap.reconstruction.skeletons import Skeleton

DEFAULT_ASSOCIATION_JOINTS: tuple[str, ...] = (
    "nose", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
)


@dataclass(frozen=True)
class AssociationConfig:
    """Settings of the per-frame association.

    Attributes:
        confidence_threshold: keypoints at or below this confidence are ignored.
        joints: joint names used to associate (None: the body joints above that the skeleton has).
        ray_gap_mm: two rays of the same joint agree when they pass within this distance.
        min_joints: a detection needs this many confident association joints; a hypothesis this many
            agreeing joints.
        min_inlier_fraction: fraction of the shared joints that must agree for a hypothesis to hold.
        consensus_radius_mm: hypotheses (pairs of detections) whose 3D roots lie within this distance
            agree; a pair links two detections when its root is this near both their consensus positions.
        merge_mm: groups seen by different cameras whose joints lie this close on average (mm) are
            one person.
        reprojection_gate: a detection joins a person when its median reprojection error is below
            this fraction of the detection's box diagonal.
        min_views: people seen by fewer cameras are dropped.
    """

    confidence_threshold: float = 0.3
    joints: tuple[str, ...] | None = None
    ray_gap_mm: float = 120.0
    min_joints: int = 4
    min_inlier_fraction: float = 0.6
    consensus_radius_mm: float = 120.0
    merge_mm: float = 300.0
    reprojection_gate: float = 0.1
    min_views: int = 2

    def __post_init__(self) -> None:
        for name in ("ray_gap_mm", "consensus_radius_mm", "merge_mm", "reprojection_gate"):
            if not getattr(self, name) > 0:
                raise ValueError(f"AssociationConfig.{name} must be > 0, got {getattr(self, name)}")
        if self.min_joints < 1 or self.min_views < 2:
            raise ValueError("AssociationConfig: min_joints must be >= 1 and min_views >= 2")
        if not 0 < self.min_inlier_fraction <= 1:
            raise ValueError("AssociationConfig.min_inlier_fraction must lie in (0, 1]")

    def joint_indices(self, skeleton: Skeleton) -> tuple[int, ...]:
        """Indices of the association joints in ``skeleton`` (ValueError naming unknown joints)."""
        if self.joints is not None:
            missing = [j for j in self.joints if not skeleton.has(j)]
            if missing:
                raise ValueError(f"AssociationConfig.joints: skeleton {skeleton.name} has no {missing}")
            return tuple(skeleton.index(j) for j in self.joints)
        found = tuple(skeleton.index(j) for j in DEFAULT_ASSOCIATION_JOINTS if skeleton.has(j))
        return found if len(found) >= self.min_joints else tuple(range(skeleton.num_joints))
