"""Keypoint skeletons: joint names, left/right pairs, limbs for the skeleton loss, gait subset.

Joint names are snake_case and shared across skeletons ("left_heel" means the same point in
Halpe-26, BODY_25 and MediaPipe-33), so code that needs a joint asks by name.

Registry: ``SKELETONS[name]`` or :func:`get_skeleton`.
"""

from __future__ import annotations

from dataclasses import dataclass

# The common gait subset every analysis uses (not every skeleton has all of them).
GAIT_JOINTS: tuple[str, ...] = (
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_heel", "right_heel", "left_big_toe", "right_big_toe", "left_small_toe", "right_small_toe",
)

# Limbs of the paper's skeleton-consistency loss (bilateral; see the notes on the authors' code).
_LOSS_LIMBS_BILATERAL = (
    ("ankle", "knee"), ("knee", "hip"), ("shoulder", "elbow"), ("elbow", "wrist"), ("heel", "big_toe"),
)


def _lr(name: str) -> tuple[str, str]:
    return f"left_{name}", f"right_{name}"


@dataclass(frozen=True)
class Skeleton:
    """A keypoint layout.

    Attributes:
        name: registry name, e.g. "halpe26".
        joint_names: (J,) snake_case names in the detector's output order.
        limbs: pairs of joint names whose length should stay constant (skeleton loss).
        bones: pairs of joint names to draw (superset of limbs).
    """

    name: str
    joint_names: tuple[str, ...]
    limbs: tuple[tuple[str, str], ...]
    bones: tuple[tuple[str, str], ...]

    def __post_init__(self) -> None:
        names = self.joint_names
        if len(set(names)) != len(names):
            raise ValueError(f"skeleton {self.name}: duplicate joint names")
        for a, b in self.limbs + self.bones:
            for j in (a, b):
                if j not in names:
                    raise ValueError(f"skeleton {self.name}: limb/bone joint {j!r} is not a joint")

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    def index(self, joint: str) -> int:
        try:
            return self.joint_names.index(joint)
        except ValueError:
            raise KeyError(f"skeleton {self.name} has no joint {joint!r}") from None

    def has(self, joint: str) -> bool:
        return joint in self.joint_names

    @property
    def limb_indices(self) -> tuple[tuple[int, int], ...]:
        return tuple((self.index(a), self.index(b)) for a, b in self.limbs)

    @property
    def bone_indices(self) -> tuple[tuple[int, int], ...]:
        return tuple((self.index(a), self.index(b)) for a, b in self.bones)

    @property
    def left_right_pairs(self) -> tuple[tuple[int, int], ...]:
        """Index pairs (left, right) of mirrored joints (for flips and left/right swaps)."""
        pairs = []
        for i, n in enumerate(self.joint_names):
            if n.startswith("left_"):
                other = "right_" + n[len("left_"):]
                if other in self.joint_names:
                    pairs.append((i, self.index(other)))
        return tuple(pairs)

    @property
    def flip_permutation(self) -> tuple[int, ...]:
        """Permutation that swaps every left joint with its right twin."""
        perm = list(range(self.num_joints))
        for a, b in self.left_right_pairs:
            perm[a], perm[b] = b, a
        return tuple(perm)

    @property
    def gait_map(self) -> dict[str, int]:
        """Common gait joint name -> index, for the gait joints this skeleton has."""
        mapping = {j: self.index(j) for j in GAIT_JOINTS if self.has(j)}
        if "left_big_toe" not in mapping and self.has("left_foot_index"):  # MediaPipe's toe
            mapping["left_big_toe"] = self.index("left_foot_index")
            mapping["right_big_toe"] = self.index("right_foot_index")
        return mapping

    @property
    def has_feet(self) -> bool:
        """True if heels and big toes are available (needed for gait analysis)."""
        return all(k in self.gait_map for k in ("left_heel", "right_heel", "left_big_toe", "right_big_toe"))

    @property
    def openpose_body_indices(self) -> tuple[int, ...]:
        """Indices of the joints that correspond to OpenPose BODY_25 (used by the GC_d metric)."""
        return tuple(i for i, n in enumerate(self.joint_names) if n in _BODY25_NAMES)


def _limbs_for(names: tuple[str, ...], extra: tuple[tuple[str, str], ...] = ()) -> tuple[tuple[str, str], ...]:
    limbs = []
    for a, b in _LOSS_LIMBS_BILATERAL:
        for side in ("left_", "right_"):
            if side + a in names and side + b in names:
                limbs.append((side + a, side + b))
    limbs += [pair for pair in extra if pair[0] in names and pair[1] in names]
    return tuple(limbs)


def _bones_for(names: tuple[str, ...], limbs, extra=()) -> tuple[tuple[str, str], ...]:
    generic = [
        ("left_hip", "right_hip"), ("left_shoulder", "right_shoulder"), ("left_shoulder", "left_hip"),
        ("right_shoulder", "right_hip"), ("left_ankle", "left_heel"), ("right_ankle", "right_heel"),
        ("left_big_toe", "left_small_toe"), ("right_big_toe", "right_small_toe"),
        ("left_ankle", "left_big_toe"), ("right_ankle", "right_big_toe"),
        ("left_ankle", "left_foot_index"), ("right_ankle", "right_foot_index"),
        ("left_heel", "left_foot_index"), ("right_heel", "right_foot_index"),
        ("nose", "left_eye"), ("nose", "right_eye"), ("left_eye", "left_ear"), ("right_eye", "right_ear"),
    ]
    out = list(limbs)
    for pair in list(generic) + list(extra):
        if pair[0] in names and pair[1] in names and pair not in out:
            out.append(pair)
    return tuple(out)


def _make(name: str, names: list[str] | tuple[str, ...], *, extra_limbs=(), extra_bones=()) -> Skeleton:
    names = tuple(names)
    limbs = _limbs_for(names, tuple(extra_limbs))
    return Skeleton(name, names, limbs, _bones_for(names, limbs, tuple(extra_bones)))


COCO17_NAMES = (
    "nose", *_lr("eye"), *_lr("ear"), *_lr("shoulder"), *_lr("elbow"), *_lr("wrist"),
    *_lr("hip"), *_lr("knee"), *_lr("ankle"),
)
HALPE26_NAMES = COCO17_NAMES + (
    "head", "neck", "pelvis", *_lr("big_toe"), *_lr("small_toe"), *_lr("heel"),
)
_HALPE_EXTRA_LIMBS = (("pelvis", "left_hip"), ("pelvis", "right_hip"), ("left_shoulder", "right_shoulder"))
_HALPE_EXTRA_BONES = (("neck", "head"), ("neck", "pelvis"), ("neck", "left_shoulder"), ("neck", "right_shoulder"))

HALPE136_NAMES = (
    HALPE26_NAMES
    + tuple(f"face_{i}" for i in range(68))
    + tuple(f"left_hand_{i}" for i in range(21))
    + tuple(f"right_hand_{i}" for i in range(21))
)
BODY25_NAMES = (
    "nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder", "left_elbow",
    "left_wrist", "pelvis", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle",
    "right_eye", "left_eye", "right_ear", "left_ear", "left_big_toe", "left_small_toe", "left_heel",
    "right_big_toe", "right_small_toe", "right_heel",
)
_BODY25_NAMES = frozenset(BODY25_NAMES)
# OpenPose's BODY_25B (the layout Pose2Sim's OpenPose demos use): COCO-17 order, then the upper neck,
# the head top and the feet; checked against OpenPose's and Pose2Sim's skeleton definitions.
BODY25B_NAMES = (
    "nose", *_lr("eye"), *_lr("ear"), *_lr("shoulder"), *_lr("elbow"), *_lr("wrist"), *_lr("hip"),
    *_lr("knee"), *_lr("ankle"), "upper_neck", "head_top", "left_big_toe", "left_small_toe", "left_heel",
    "right_big_toe", "right_small_toe", "right_heel",
)
# OpenPose's COCO-18 ("COCO" model): nose, neck, right arm, left arm, right leg, left leg, eyes, ears.
COCO18_NAMES = (
    "nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder", "left_elbow",
    "left_wrist", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle",
    "right_eye", "left_eye", "right_ear", "left_ear",
)
# COCO-WholeBody-133 (MMPose/RTMLib "wholebody"): COCO-17, six foot points, 68 face, 21 + 21 hand points.
WHOLEBODY133_NAMES = (
    COCO17_NAMES
    + ("left_big_toe", "left_small_toe", "left_heel", "right_big_toe", "right_small_toe", "right_heel")
    + tuple(f"face_{i}" for i in range(68))
    + tuple(f"left_hand_{i}" for i in range(21))
    + tuple(f"right_hand_{i}" for i in range(21))
)
MEDIAPIPE33_NAMES = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", *_lr("ear"), "mouth_left", "mouth_right", *_lr("shoulder"), *_lr("elbow"),
    *_lr("wrist"), *_lr("pinky"), *_lr("index"), *_lr("thumb"), *_lr("hip"), *_lr("knee"), *_lr("ankle"),
    *_lr("heel"), *_lr("foot_index"),
)

SKELETONS: dict[str, Skeleton] = {
    s.name: s
    for s in (
        _make("coco17", COCO17_NAMES),
        _make("coco18", COCO18_NAMES, extra_bones=(("neck", "left_shoulder"), ("neck", "right_shoulder"))),
        _make("wholebody133", WHOLEBODY133_NAMES),
        _make("halpe26", HALPE26_NAMES, extra_limbs=_HALPE_EXTRA_LIMBS, extra_bones=_HALPE_EXTRA_BONES),
        _make("halpe136", HALPE136_NAMES, extra_limbs=_HALPE_EXTRA_LIMBS, extra_bones=_HALPE_EXTRA_BONES),
        _make("body25", BODY25_NAMES, extra_bones=(("neck", "pelvis"), ("pelvis", "left_hip"))),
        _make("body25b", BODY25B_NAMES, extra_bones=(("upper_neck", "head_top"),)),
        _make(
            "mediapipe33",
            MEDIAPIPE33_NAMES,
            extra_limbs=(("left_heel", "left_foot_index"), ("right_heel", "right_foot_index")),
        ),
    )
}


def get_skeleton(name: str) -> Skeleton:
    """Look up a skeleton by registry name; ValueError listing the known names."""
    key = name.lower().replace("-", "").replace("_", "")
    if key not in SKELETONS:
        raise ValueError(f"unknown skeleton {name!r}; known: {sorted(SKELETONS)}")
    return SKELETONS[key]
