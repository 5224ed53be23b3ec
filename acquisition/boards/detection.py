"""Calibration boards: definitions, images of them (for printing and for the synthetic world), and
sub-pixel corner detection in camera images with OpenCV.

Two boards, as in the paper: a plain checkerboard of 7 x 5 squares of 110 mm (6 x 4 inner corners) and
a ChArUco board of 5 x 7 squares of 109 mm. Board frame: x along the columns, y along the rows (both
in the printed image's direction), z into the board; corner 0 is the first inner corner.

Boards as people print them: a ChArUco board may be printed inverted (white markers on black), in
OpenCV's legacy layout (before 4.6 boards with an even number of rows had their markers in the other
squares), or on both faces (the back as a mirror image, seen from behind). Unless the config says
which, every variant is tried when the last one that worked finds nothing, and each detection says
which was used (:class:`BoardFind`). Partial views are fine: corners come from any subset of markers.

A plain checkerboard does not tell which way round it is held: the detector may report its corners
rotated by 180 degrees or mirrored. Those orders are listed as the board's symmetries and resolved by
the calibration (front-facing test per view, consistency across cameras per frame). ChArUco corners
carry ids and have no such ambiguity.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardGeometry, grid_board

log = logging.getLogger(__name__)

CHARUCO_MIN_CORNERS = 6
COARSE_WIDTH_PX = 1280  # wider images are searched for a checkerboard at half size first
CROP_MARGIN_PX = 40
SMALL_WIDTH_PX = 400  # narrower images (the demo's 240 px) are searched again enlarged when the board is not found
ENLARGE = 3  # by this factor (bicubic): findChessboardCornersSB misses squares of 2-5 px that it finds enlarged


@dataclass(frozen=True)
class BoardConfig:
    """Which board was filmed.

    Attributes:
        kind: "checkerboard" or "charuco".
        squares_x / squares_y: number of squares along x (columns) and y (rows).
        square_mm: side of a square, mm.
        marker_mm: ChArUco marker side, mm (default 0.75 x square).
        dictionary: ChArUco ArUco dictionary name in cv2.aruco.
        inverted: ChArUco printed white markers on black (None: try both).
        legacy_layout: ChArUco in OpenCV's pre-4.6 layout (None: try both where they differ).
    """

    kind: Literal["checkerboard", "charuco"] = "checkerboard"
    squares_x: int = 7
    squares_y: int = 5
    square_mm: float = 110.0
    marker_mm: float | None = None
    dictionary: str = "DICT_4X4_50"
    inverted: bool | None = None
    legacy_layout: bool | None = None

    def describe(self) -> str:
        """One line with every parameter (printed on the board and in messages)."""
        text = f"{self.kind} {self.squares_x} x {self.squares_y} squares of {self.square_mm:g} mm"
        if self.kind == "charuco":
            marker = self.marker_mm if self.marker_mm is not None else 0.75 * self.square_mm
            text += f", markers {marker:g} mm {self.dictionary}"
            text += ", inverted" if self.inverted else ""
            text += ", legacy layout" if self.legacy_layout else ""
        return text

    @classmethod
    def checkerboard(cls, squares_x: int = 7, squares_y: int = 5, square_mm: float = 110.0) -> BoardConfig:
        """The paper's board: 7 x 5 squares of 110 mm."""
        return cls("checkerboard", squares_x, squares_y, square_mm)

    @classmethod
    def charuco(cls, squares_x: int = 5, squares_y: int = 7, square_mm: float = 109.0, marker_mm: float | None = None,
                dictionary: str = "DICT_4X4_50") -> BoardConfig:
        """The paper authors' current board: ChArUco 5 x 7 squares of 109 mm."""
        return cls("charuco", squares_x, squares_y, square_mm, marker_mm, dictionary)


@dataclass(frozen=True)
class CharucoVariant:
    """How a ChArUco board was printed: inverted (white markers on black), OpenCV's legacy layout, or
    seen from behind on a board printed on both faces (found in the mirrored image)."""

    inverted: bool = False
    legacy: bool = False
    mirrored: bool = False

    def describe(self) -> str:
        parts = [name for name, on in (("inverted", self.inverted), ("legacy layout", self.legacy),
                                       ("back side", self.mirrored)) if on]
        return ", ".join(parts) or "normal"


@dataclass(frozen=True, eq=False)
class BoardFind:
    """What the detector found in one image.

    Attributes:
        corners: (N, 2) px (NaN for corners not found) or None when too few were found.
        n_markers: ArUco markers found (0 for a checkerboard).
        n_corners: board corners found.
        marker_px: median marker side, px (NaN without markers).
        marker_ratio: marker side / square side measured in the image (NaN when fewer than 4 markers).
        variant: how the board was printed, as found (ChArUco), or None when nothing was found.
    """

    corners: np.ndarray | None
    n_markers: int = 0
    n_corners: int = 0
    marker_px: float = float("nan")
    marker_ratio: float = float("nan")
    variant: CharucoVariant | None = None


def _gray(image: np.ndarray) -> np.ndarray:
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return image


class Checkerboard:
    """Plain checkerboard; detection with ``findChessboardCornersSB`` (sub-pixel by construction)."""

    def __init__(self, config: BoardConfig):
        if config.squares_x < 3 or config.squares_y < 3:
            raise ValueError(f"checkerboard: needs at least 3 x 3 squares, got {config.squares_x} x {config.squares_y}")
        self.config = config
        self.pattern = (config.squares_x - 1, config.squares_y - 1)  # inner corners (columns, rows)
        name = f"checkerboard {config.squares_x}x{config.squares_y} squares of {config.square_mm:g} mm"
        n = self.pattern[0] * self.pattern[1]
        self.geometry: BoardGeometry = grid_board(
            name, corners_x=self.pattern[0], corners_y=self.pattern[1], square_mm=config.square_mm,
            mirror_ambiguous=True, min_corners=n,
        )

    def find(self, image: np.ndarray) -> BoardFind:
        """The board in one image (a checkerboard has no markers: only the corner count is known)."""
        corners = self.detect(image)
        return BoardFind(corners, n_corners=0 if corners is None else len(corners))

    def detect(self, image: np.ndarray) -> np.ndarray | None:
        """Corners (N, 2) px in detector order, or None when the whole board is not found.

        Images wider than ``COARSE_WIDTH_PX`` are searched coarse to fine: the board is found in a
        half-size copy, then its corners are found again at full resolution in a crop around it (about a
        tenth of the cost of a full-size search, the same corners). A board missed at half size is
        searched at full size when a quick check says one is there.
        """
        gray = _gray(image)
        h, w = gray.shape
        if w < SMALL_WIDTH_PX:
            return self._find_small(gray)
        if w <= COARSE_WIDTH_PX:
            return self._find(gray)
        coarse = self._find(cv2.resize(gray, (w // 2, h // 2), interpolation=cv2.INTER_AREA))
        if coarse is None:
            return self._find(gray) if cv2.checkChessboard(gray, self.pattern) else None
        guess = (coarse + 0.5) * 2 - 0.5  # pixel centres at integers in both images
        grid = guess.reshape(self.pattern[1], self.pattern[0], 2)
        spacing = float(np.median(np.linalg.norm(np.diff(grid, axis=1), axis=-1)))
        margin = max(CROP_MARGIN_PX, 1.5 * spacing)
        x0, y0 = np.maximum(np.floor(guess.min(0) - margin), 0).astype(int)
        x1, y1 = np.minimum(np.ceil(guess.max(0) + margin), [w, h]).astype(int)
        fine = self._find(np.ascontiguousarray(gray[y0:y1, x0:x1]))
        if fine is None:
            return self._find(gray)
        fine = fine + [x0, y0]
        off = min(np.abs(fine[list(p)] - guess).max() for p in self.geometry.symmetries)  # any corner order
        return fine if off <= max(4.0, 0.5 * spacing) else self._find(gray)

    def _find_small(self, gray: np.ndarray) -> np.ndarray | None:
        """A small image (under ``SMALL_WIDTH_PX`` wide): as it is, else enlarged ``ENLARGE`` x (the
        demo's 240 x 180 px cameras see the board's squares 2-5 px wide: in 6.5 s of the short clip at
        30 fps the board was found in 499 of 1950 camera frames, 149 as they are), corners mapped back to
        the image's pixels. One plain ``findChessboardCornersSB`` search there (no accuracy pass, no
        retries: 45 ms a 240 x 180 frame against 170 ms with the accuracy flag, corners of a flat board
        within 0.2 px either way)."""
        corners = self._find(gray)
        if corners is not None:
            return corners
        big = cv2.resize(gray, None, fx=ENLARGE, fy=ENLARGE, interpolation=cv2.INTER_CUBIC)
        corners = self._search(big, 0)
        return None if corners is None else (corners + 0.5) / ENLARGE - 0.5  # pixel centres at integers

    def _find(self, gray: np.ndarray) -> np.ndarray | None:
        """findChessboardCornersSB as is, then, when a quick check says a board is there, with the
        histogram equalised (finds boards in dim images but moves the corners: median error 0.07 px
        against 0.04 px on rendered 1920 x 1200 views), then with the exhaustive search (hand-held boards
        turned in the image: 11 more of Pose2Sim's 28 real demo views)."""
        corners = self._search(gray, cv2.CALIB_CB_ACCURACY)
        if corners is None and cv2.checkChessboard(gray, self.pattern):
            corners = self._search(gray, cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_NORMALIZE_IMAGE)
            if corners is None:
                corners = self._search(gray, cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_EXHAUSTIVE)
        return corners

    def _search(self, gray: np.ndarray, flags: int) -> np.ndarray | None:
        found, corners = cv2.findChessboardCornersSB(gray, self.pattern, flags=flags)
        if not found or corners is None or len(corners) != self.geometry.num_corners:
            return None
        return corners.reshape(-1, 2).astype(np.float64)

    def texture(self, px_per_mm: float, margin_squares: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
        """Printable image (uint8) and the px position (2,) of corner 0 in it (pixel centres at integers)."""
        sq = self.config.square_mm * px_per_mm
        margin = margin_squares * sq
        w = int(round(self.config.squares_x * sq + 2 * margin))
        h = int(round(self.config.squares_y * sq + 2 * margin))
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
        i = np.floor((xx - margin) / sq)
        j = np.floor((yy - margin) / sq)
        inside = (i >= 0) & (i < self.config.squares_x) & (j >= 0) & (j < self.config.squares_y)
        img = np.where(inside & ((i + j) % 2 == 0), 0, 255).astype(np.uint8)
        return img, np.array([margin + sq, margin + sq]) - 0.5  # OpenCV convention: pixel centres at integers


def _choices(fixed: bool | None) -> tuple[bool, ...]:
    return (fixed,) if fixed is not None else (False, True)


class CharucoBoard:
    """ChArUco board; detection with ``cv2.aruco`` (partial views allowed, printing variants tried)."""

    def __init__(self, config: BoardConfig):
        dict_id = getattr(cv2.aruco, config.dictionary, None)
        if dict_id is None or not config.dictionary.startswith("DICT_"):
            raise ValueError(f"charuco: unknown ArUco dictionary {config.dictionary!r} (e.g. DICT_4X4_50)")
        marker = config.marker_mm if config.marker_mm is not None else 0.75 * config.square_mm
        if not 0 < marker < config.square_mm:
            raise ValueError(f"charuco: marker_mm must lie in (0, square_mm), got {marker}")
        if config.squares_x < 2 or config.squares_y < 2 or config.squares_x * config.squares_y < 6:
            raise ValueError(f"charuco: too few squares ({config.squares_x} x {config.squares_y})")
        self.config = config
        self.dictionary = cv2.aruco.getPredefinedDictionary(dict_id)
        self.aruco = cv2.aruco.ArucoDetector(self.dictionary)
        self.boards = {legacy: self._board(marker, legacy) for legacy in (False, True)}
        self.board = self.boards[bool(config.legacy_layout)]
        self.detectors = {legacy: cv2.aruco.CharucoDetector(b) for legacy, b in self.boards.items()}
        differ = config.squares_y % 2 == 0  # OpenCV 4.6 changed the layout of boards with even rows only
        layouts = _choices(config.legacy_layout) if differ else (bool(config.legacy_layout),)
        self.variants = [CharucoVariant(inv, leg, mir) for inv in _choices(config.inverted) for leg in layouts
                         for mir in (False, True)]
        self.preferred = self.variants[0]
        self.ratio = marker / config.square_mm
        pts = np.asarray(self.board.getChessboardCorners(), dtype=np.float64).reshape(-1, 3)
        self.offset_mm = pts[0, :2].copy()
        pts[:, :2] -= self.offset_mm
        nx, ny = config.squares_x - 1, config.squares_y - 1
        base = grid_board("", corners_x=nx, corners_y=ny, square_mm=config.square_mm, mirror_ambiguous=False,
                          min_corners=CHARUCO_MIN_CORNERS)
        if not np.allclose(base.object_points_mm, pts):
            raise ValueError("charuco: OpenCV's corner layout is not row-major; unsupported OpenCV version")
        name = f"charuco {config.squares_x}x{config.squares_y} squares of {config.square_mm:g} mm, {config.dictionary}"
        self.geometry = BoardGeometry(name, pts, config.square_mm, base.neighbours, base.symmetries,
                                      CHARUCO_MIN_CORNERS)

    def _board(self, marker_mm: float, legacy: bool):
        board = cv2.aruco.CharucoBoard((self.config.squares_x, self.config.squares_y), self.config.square_mm,
                                       marker_mm, self.dictionary)
        board.setLegacyPattern(legacy)
        return board

    def detect(self, image: np.ndarray) -> np.ndarray | None:
        """Corners (N, 2) px with NaN for corners not found, or None when too few are found."""
        return self.find(image).corners

    def find(self, image: np.ndarray) -> BoardFind:
        """The board in one image: the variant that worked last first, then every other one; the one
        with most corners wins."""
        gray = _gray(image)
        best = self._try(gray, self.preferred, {})
        if best.n_corners >= CHARUCO_MIN_CORNERS:
            return best
        markers: dict = {}
        for variant in self.variants:
            if variant != self.preferred:
                found = self._try(gray, variant, markers)
                if (found.n_corners, found.n_markers) > (best.n_corners, best.n_markers):
                    best = found
        if best.n_corners >= CHARUCO_MIN_CORNERS and best.variant is not None:
            self.preferred = best.variant
        return best

    def _markers(self, gray: np.ndarray, inverted: bool, mirrored: bool, cache: dict):
        key = (inverted, mirrored)
        if key not in cache:
            img = 255 - gray if inverted else gray
            img = cv2.flip(img, 1) if mirrored else img
            corners, ids, _ = self.aruco.detectMarkers(img)
            cache[key] = (img, corners, ids)
        return cache[key]

    def _try(self, gray: np.ndarray, variant: CharucoVariant, cache: dict) -> BoardFind:
        img, marker_corners, marker_ids = self._markers(gray, variant.inverted, variant.mirrored, cache)
        if marker_ids is None or len(marker_ids) == 0:
            return BoardFind(None)
        corners, ids, _, _ = self.detectors[variant.legacy].detectBoard(
            img, markerCorners=marker_corners, markerIds=marker_ids)
        quads = np.asarray(marker_corners, dtype=np.float64).reshape(-1, 4, 2)
        side_px = float(np.median(np.linalg.norm(quads - np.roll(quads, 1, axis=1), axis=-1)))
        ratio = self._marker_ratio(quads, marker_ids.ravel(), variant.legacy)
        n = 0 if ids is None else len(ids)
        out = None
        if n >= CHARUCO_MIN_CORNERS:
            out = np.full((self.geometry.num_corners, 2), np.nan)
            uv = corners.reshape(-1, 2).astype(np.float64)
            if variant.mirrored:
                uv[:, 0] = img.shape[1] - 1 - uv[:, 0]  # back to the camera's image (pixel centres at integers)
            out[ids.ravel()] = uv
        return BoardFind(out, len(marker_ids), n, side_px, ratio, variant)

    def _marker_ratio(self, quads: np.ndarray, ids: np.ndarray, legacy: bool) -> float:
        """Marker side / square side as printed, measured from the markers alone: a homography from the
        markers' centres (which sit at square centres whatever the marker size) to their places on the
        board, in squares, maps each marker's corners back onto the board; their spacing is the ratio."""
        board = self.boards[legacy]
        obj = np.asarray(board.getObjPoints(), dtype=np.float64)[:, :, :2] / self.config.square_mm
        index = {int(i): k for k, i in enumerate(np.asarray(board.getIds()).ravel())}
        known = [k for k, i in enumerate(ids) if int(i) in index]
        if len(known) < 4:
            return float("nan")
        centres_board = np.stack([obj[index[int(ids[k])]].mean(0) for k in known])
        centres_img = quads[known].mean(1)
        if np.linalg.matrix_rank(np.c_[centres_board, np.ones(len(known))]) < 3:
            return float("nan")  # all markers on one line
        hom, _ = cv2.findHomography(centres_img, centres_board)
        if hom is None:
            return float("nan")
        back = cv2.perspectiveTransform(quads[known].reshape(-1, 1, 2), hom).reshape(-1, 4, 2)
        return float(np.median(np.linalg.norm(back - np.roll(back, 1, axis=1), axis=-1)))

    def texture(self, px_per_mm: float, margin_squares: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
        """Printable image (uint8) and the px position (2,) of corner 0 in it (pixel centres at integers)."""
        square_px = self.config.square_mm * px_per_mm
        if abs(square_px - round(square_px)) > 1e-6:
            raise ValueError(f"charuco texture: px_per_mm {px_per_mm} must give whole pixels per square")
        margin = int(round(margin_squares * square_px))
        w = int(round(self.config.squares_x * square_px)) + 2 * margin
        h = int(round(self.config.squares_y * square_px)) + 2 * margin
        img = self.board.generateImage((w, h), marginSize=margin, borderBits=1)
        img = 255 - img if self.config.inverted else img
        return img, margin + self.offset_mm * px_per_mm - 0.5  # OpenCV convention: pixel centres at integers


Board = Checkerboard | CharucoBoard
BOARD_KINDS: dict[str, type[Checkerboard] | type[CharucoBoard]] = {"checkerboard": Checkerboard, "charuco": CharucoBoard}


def make_board(config: BoardConfig) -> Board:
    """The board object for a config (registry lookup by ``config.kind``)."""
    if config.kind not in BOARD_KINDS:
        raise ValueError(f"board kind {config.kind!r} is unknown; choose one of {sorted(BOARD_KINDS)}")
    return BOARD_KINDS[config.kind](config)
