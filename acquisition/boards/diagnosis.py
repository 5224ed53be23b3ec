"""Per camera: what the board detector found in a recording, and, when too few views were found, the
likely cause and what to change. The board's size is blamed only when the marker-to-square ratio
measured in the images disagrees with the board description."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, BoardFind

SMALL_MARKER_PX = 15.0  # ArUco decoding gets unreliable below this marker side
RATIO_TOLERANCE = 0.1  # relative disagreement of the measured marker/square ratio that blames the sizes


@dataclass(frozen=True)
class CameraDetection:
    """One camera's detection statistics.

    Attributes:
        name: camera.
        frames: frames searched.
        with_markers: frames with at least one ArUco marker (ChArUco; 0 for a checkerboard).
        with_board: frames with enough corners to use.
        marker_px: median marker side over the frames with markers, px (NaN without).
        marker_ratio: median measured marker side / square side (NaN when not measurable).
        variants: {how the board was printed, as found: views}.
        moving: views taken out of their frame sets (kept alone) because the board moved between the
            cameras' exposures.
        smeared: views left out because the board moved during the rolling shutter's readout (skewed).
        probe: {variant: frames with enough corners} found by trying every printing variant on a sample
            of this camera's frames where the configured one found nothing.
    """

    name: str
    frames: int
    with_markers: int
    with_board: int
    marker_px: float
    marker_ratio: float
    variants: dict[str, int] = field(default_factory=dict)
    moving: int = 0
    probe: dict[str, int] = field(default_factory=dict)
    smeared: int = 0

    @classmethod
    def from_finds(cls, name: str, finds: list[BoardFind], *, min_corners: int, moving: int = 0,
                   probe: dict[str, int] | None = None, smeared: int = 0) -> CameraDetection:
        marked = [f for f in finds if f.n_markers > 0]
        good = [f for f in finds if f.corners is not None and f.n_corners >= min_corners]
        ratios = [f.marker_ratio for f in marked if np.isfinite(f.marker_ratio)]
        variants = Counter(f.variant.describe() for f in good if f.variant is not None)
        return cls(name, len(finds), len(marked), len(good),
                   float(np.median([f.marker_px for f in marked])) if marked else float("nan"),
                   float(np.median(ratios)) if ratios else float("nan"), dict(variants), moving, probe or {}, smeared)

    def usable(self) -> int:
        """Views for this camera's intrinsics (moving views included: they only tie no cameras together;
        smeared ones are left out)."""
        return self.with_board - self.smeared

    def advice(self, board: BoardConfig, min_views: int) -> list[str]:
        """What to change, most likely cause first (empty when the camera has enough views)."""
        if self.usable() >= min_views:
            return []
        tips = []
        if board.kind == "charuco":
            tips += self._charuco_advice(board)
        elif self.with_board == 0:
            tips.append(f"no frame showed the whole {board.squares_x}x{board.squares_y}-square checkerboard: a "
                        "checkerboard must be entirely in view (partial views need a ChArUco board)")
        if self.moving:
            tips.append(f"{self.moving} views tie no cameras together because the board moved between the "
                        "cameras' exposures: hold it still in each position (or move it slower)")
        if self.smeared:
            tips.append(f"{self.smeared} views left out because the board moved during the image's readout "
                        "(rolling shutter): move it slower")
        tips.append(f"{self.usable()} usable views, need {min_views}: move the board through this camera's whole "
                    "view, closer and slower, in good light")
        return tips

    def _charuco_advice(self, board: BoardConfig) -> list[str]:
        tips = []
        if self.probe:
            tips.append("trying every printing variant on some of its frames found the board as " + ", ".join(
                f"{k} ({v} frames)" for k, v in self.probe.items()) + ": describe the board that way")
        if self.with_markers == 0:
            tips.append(f"no {board.dictionary} marker in any of {self.frames} frames (normal and inverted tried): "
                        "check the dictionary, and that the board is in this camera's view and lit")
            return tips
        marker = board.marker_mm if board.marker_mm is not None else 0.75 * board.square_mm
        said = marker / board.square_mm
        if np.isfinite(self.marker_ratio) and abs(self.marker_ratio / said - 1) > RATIO_TOLERANCE:
            tips.append(f"markers measure {self.marker_ratio:.2f} of a square in the images but the board "
                        f"description says {said:.2f} ({marker:g} / {board.square_mm:g} mm): check the marker "
                        "and square sizes given")
        if self.marker_px < SMALL_MARKER_PX:
            tips.append(f"markers are only {self.marker_px:.0f} px across (median): bring the board closer or "
                        "print it larger")
        if self.with_board < self.with_markers / 2:
            tips.append(f"markers seen in {self.with_markers} frames but enough corners in only "
                        f"{self.with_board}: hold the board less steeply, move slower (motion blur), add light")
        return tips

    def line(self) -> str:
        variants = ", ".join(f"{k}: {v}" for k, v in self.variants.items()) or "-"
        px = f"{self.marker_px:>10.1f}" if np.isfinite(self.marker_px) else f"{'-':>10}"  # no marker: no size
        ratio = f"{self.marker_ratio:>7.2f}" if np.isfinite(self.marker_ratio) else f"{'-':>7}"
        return (f"{self.name:<10} {self.frames:>7} {self.with_markers:>8} {self.with_board:>7} {self.moving:>7} "
                f"{px} {ratio}  {variants}")


HEADER = f"{'camera':<10} {'frames':>7} {'markers':>8} {'board':>7} {'moving':>7} {'marker px':>10} {'ratio':>7}  found as"


def detection_table(cameras: tuple[CameraDetection, ...]) -> str:
    """A table of every camera's detection statistics."""
    return "\n".join([HEADER] + [c.line() for c in cameras])


def too_few_views_error(cameras: tuple[CameraDetection, ...], board: BoardConfig, min_views: int) -> ValueError | None:
    """A ValueError naming every camera with too few usable views and what to change, or None."""
    bad = [c for c in cameras if c.usable() < min_views]
    if not bad:
        return None
    lines = [f"too few board views of {board.describe()} (need {min_views} per camera):"]
    for c in bad:
        lines.append(f"camera {c.name!r}: " + "; ".join(c.advice(board, min_views)))
    return ValueError("\n".join(lines + ["", detection_table(cameras)]))


def too_few_positions_error(cameras: tuple[CameraDetection, ...], positions: tuple[int, ...], board: BoardConfig,
                            min_views: int) -> ValueError | None:
    """A ValueError naming every camera with enough frames of the board but fewer than ``min_views``
    distinct board positions (``positions``, per camera, in the order of ``cameras``), or None."""
    bad = [(c, p) for c, p in zip(cameras, positions, strict=True) if c.usable() >= min_views and p < min_views]
    if not bad:
        return None
    lines = [f"too few distinct positions of {board.describe()} (need {min_views} per camera):"]
    lines += [f"camera {c.name!r}: " + "; ".join(positions_advice(c, p, min_views)) for c, p in bad]
    return ValueError("\n".join(lines + ["", detection_table(cameras)]))


def positions_advice(camera: CameraDetection, positions: int, min_views: int) -> list[str]:
    """What to change for a camera with enough views of the board but fewer than ``min_views`` distinct
    board positions (empty when it has enough of both)."""
    if camera.usable() < min_views or positions >= min_views:
        return []
    return [f"{camera.usable()} frames showed the board but only {positions} distinct positions remain (frames "
            "of a board held still count once; frames that could not be paired are left out): move the board to "
            f"more places in this camera's view ({min_views} needed)"]
