"""MediaPipe Pose (BlazePose, 33 landmarks incl. heels and toes), running offline on TFLite models.

The models come from the npm package ``@mediapipe/pose`` (Apache-2.0), installed by
``deploy/bootstrap.sh`` into ``<venv>/share/gaitcap/mediapipe-pose/``: ``pose_detection.tflite`` (the
person detector, shipped as ``pose_solution_packed_assets.data``) and
``pose_landmark_{lite,full,heavy}.tflite``. They run in the LiteRT interpreter (``ai-edge-litert``); the
pre- and post-processing below follows MediaPipe's pose graphs:

1. person detector (224x224 letterbox, RGB in [-1, 1], SSD anchors, weighted NMS) -> hip centre and a
   scale point -> a rotated square region of interest (2 x their distance x 1.25);
2. landmark model on that region (256x256, RGB in [0, 1]) -> 39 points (33 landmarks + 2 alignment
   points + ...), visibility = sigmoid, refined on the 64x64 heatmaps, mapped back to image px;
3. tracking: the next frame of the same camera (up to ``track_gap_frames`` frame ids on) reuses each
   person's region from the alignment landmarks 33/34; the detector runs again for one pose only when it
   is lost, for several poses every ``search_every``-th frame (for people coming into view).
Confidence = min(visibility, presence), both sigmoid outputs of the landmark model.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.detectors.base import DetectorConfig, check_image, empty_keypoints, register_detector
from gaitcap.acquisition.detectors.crops import Crop, square_crop
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.skeletons import get_skeleton

log = logging.getLogger(__name__)

MODELS_ENV = "GAITCAP_MEDIAPIPE_DIR"
LANDMARK_MODELS = ("lite", "full", "heavy")
DETECTOR_FILE = "pose_detection.tflite"
DETECTOR_INPUT_PX = 224
LANDMARK_INPUT_PX = 256
NUM_OUTPUT_LANDMARKS = 39  # 33 body landmarks + alignment points 33 (hip centre), 34 (scale) + 4 more
ROI_SCALE = 1.25


def default_model_dir() -> Path:
    """``$GAITCAP_MEDIAPIPE_DIR`` or ``<venv>/share/gaitcap/mediapipe-pose`` (where bootstrap puts them)."""
    return share_path("mediapipe-pose", env=MODELS_ENV)


@register_detector
@dataclass(frozen=True)
class MediaPipeConfig(DetectorConfig):
    """MediaPipe Pose.

    Attributes:
        model: landmark model size, one of "lite", "full", "heavy", or the path of a landmark
            ``.tflite`` file (the person detector is then looked up next to it, else in ``model_dir``).
        model_dir: folder with the .tflite files; None = :func:`default_model_dir`.
        min_detection_confidence: person detector score threshold.
        min_tracking_confidence: pose presence below this drops tracking and re-runs the detector.
        tracking: reuse the previous frame's region for consecutive frames of the same camera.
        track_gap_frames: a camera's regions are reused for a frame up to this many frame ids after the last
            one detected (1: the next frame only, as MediaPipe; 2: one frame may be missing between, as when
            the frames between the live detector's are completed after Stop, or the live pool detects every
            2nd frame id; the walker of the sports2d video moves about 20 px in 2 frames, well inside the
            region). A longer gap runs the person detector again.
        num_poses: at most this many people per image (default 4: everyone in a clinic's view; who the
            patient is is decided across cameras by the association, never per image). Tracking the
            previous frame's regions are reused; > 1 also runs the person detector for newcomers.
        search_every: with fewer than ``num_poses`` people tracked in a camera, the person detector looks
            for newcomers on every this-many-th frame of that camera (1: every frame, as MediaPipe does; 5:
            a person who walks in is found within 5 frames, 0.17 s at 30 fps, for about half the cost per
            frame of one tracked person). A camera with nobody tracked searches every frame.
        num_threads: TFLite interpreter threads.
    """

    kind = "mediapipe"
    model: str = "full"
    model_dir: Path | None = None
    min_detection_confidence: float = 0.5
    min_tracking_confidence: float = 0.5
    tracking: bool = True
    num_poses: int = 4
    search_every: int = 5
    num_threads: int = 2
    track_gap_frames: int = 2

    def __post_init__(self) -> None:
        if str(self.model) not in LANDMARK_MODELS and not str(self.model).endswith(".tflite"):
            raise ValueError(f"mediapipe model must be one of {LANDMARK_MODELS} or a .tflite path, got {self.model!r}")
        if self.num_poses < 1:
            raise ValueError(f"mediapipe num_poses must be >= 1, got {self.num_poses}")
        if self.search_every < 1:
            raise ValueError(f"mediapipe search_every must be >= 1 frame, got {self.search_every}")
        if self.track_gap_frames < 1:
            raise ValueError(f"mediapipe track_gap_frames must be >= 1 frame, got {self.track_gap_frames}")

    def build(self) -> MediaPipeDetector:
        return MediaPipeDetector(self)


def model_files(config: MediaPipeConfig) -> tuple[Path, Path]:
    """(person detector, landmark model) paths of a config."""
    folder = Path(config.model_dir) if config.model_dir is not None else default_model_dir()
    model = str(config.model)
    if model in LANDMARK_MODELS:
        return folder / DETECTOR_FILE, folder / f"pose_landmark_{model}.tflite"
    lm_path = Path(model)
    beside = lm_path.parent / DETECTOR_FILE
    return (beside if beside.is_file() else folder / DETECTOR_FILE), lm_path


@dataclass(frozen=True)
class Roi:
    """A rotated square region of interest in image px."""

    center_px: tuple[float, float]
    side_px: float
    rotation_rad: float
    score: float = 1.0


def _rgb(bgr_crop: np.ndarray) -> np.ndarray:
    """A model's BGR input crop in RGB order: the crop is cut from the BGR image and its channels swapped
    (the same pixels as cutting it from the image converted to RGB, for a fraction of the CPU)."""
    return bgr_crop[..., ::-1]


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(x, -80.0, 80.0)))


def _roi_from_points(start_px: np.ndarray, end_px: np.ndarray, score: float = 1.0) -> Roi:
    """MediaPipe's AlignmentPointsRects + RectTransformation(scale 1.25, square): centre on ``start``,
    side 2 x |end - start| x 1.25, rotated so that ``end`` is straight up."""
    d = end_px - start_px
    rotation = np.pi / 2 - np.arctan2(-d[1], d[0])
    rotation = (rotation + np.pi) % (2 * np.pi) - np.pi
    side = 2.0 * float(np.hypot(*d)) * ROI_SCALE
    return Roi((float(start_px[0]), float(start_px[1])), side, float(rotation), score)


def ssd_anchors() -> np.ndarray:
    """(2254, 2) anchor centres in [0, 1] of the pose detector (MediaPipe SsdAnchorsCalculator with
    5 layers, strides 8, 16, 32, 32, 32, aspect ratio 1 + interpolated scale, fixed anchor size)."""
    centres = []
    for stride, per_cell in ((8, 2), (16, 2), (32, 6)):  # consecutive stride-32 layers are merged
        n = int(np.ceil(DETECTOR_INPUT_PX / stride))
        ys, xs = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n, indexing="ij")
        cell = np.stack([xs.ravel(), ys.ravel()], axis=-1)
        centres.append(np.repeat(cell, per_cell, axis=0))
    return np.concatenate(centres)


def same_person(a: np.ndarray, b: np.ndarray, *, fraction: float = 0.1) -> bool:
    """Whether two (J, 3) landmark sets are one person: median joint distance below ``fraction`` of
    ``b``'s bounding-box diagonal (two detector regions on one person give two near-identical poses)."""
    diag = float(np.hypot(*(np.nanmax(b[:, :2], 0) - np.nanmin(b[:, :2], 0))))
    return bool(np.nanmedian(np.hypot(*(a[:, :2] - b[:, :2]).T)) < fraction * diag)


def box_inside(a: np.ndarray, b: np.ndarray, *, fraction: float = 0.6) -> bool:
    """Whether the landmark boxes of two (J, 3) poses overlap by at least ``fraction`` of the smaller box:
    the person detector's second region on one person (a part of the body, or the body stretched to a
    wrong head) gives a pose inside the first one's box. A person hidden that much behind another in one
    camera is left to the other cameras."""
    (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = landmark_box(a), landmark_box(b)
    inter = max(0.0, min(ax1, bx1) - max(ax0, bx0)) * max(0.0, min(ay1, by1) - max(ay0, by0))
    smaller = min((ax1 - ax0) * (ay1 - ay0), (bx1 - bx0) * (by1 - by0))
    return bool(inter >= fraction * max(smaller, 1e-9))


def _centre_inside(roi: Roi, keypoints: np.ndarray) -> bool:
    """Whether a detector region's centre (a person's hip centre) lies in a found person's landmark box."""
    x0, y0, x1, y1 = landmark_box(keypoints)
    return bool(x0 <= roi.center_px[0] <= x1 and y0 <= roi.center_px[1] <= y1)


def landmark_box(keypoints: np.ndarray, *, min_conf: float = 0.3) -> np.ndarray:
    """(4,) x0, y0, x1, y1 px around the (J, 3) keypoints with confidence >= ``min_conf`` (all if none)."""
    ok = keypoints[:, 2] >= min_conf
    xy = keypoints[ok if ok.sum() >= 2 else slice(None), :2]
    return np.concatenate([xy.min(0), xy.max(0)])


def weighted_nms(boxes: np.ndarray, scores: np.ndarray, points: np.ndarray, iou_threshold: float = 0.3):
    """MediaPipe's weighted non-max suppression.

    boxes: (N, 4) x0, y0, x1, y1; scores: (N,); points: (N, K, 2). Returns a list of
    (score, box (4,), points (K, 2)), clusters merged by score-weighted averaging, best first.
    """
    order = np.argsort(-scores)
    remaining = list(order)
    out = []
    while remaining:
        best = remaining[0]
        rest = np.array(remaining)
        iou = _iou(boxes[best], boxes[rest])
        cluster = rest[iou > iou_threshold]
        w = scores[cluster][:, None]
        box = (boxes[cluster] * w).sum(0) / w.sum()
        pts = (points[cluster] * w[:, :, None]).sum(0) / w.sum()
        out.append((float(scores[best]), box, pts))
        remaining = [int(i) for i in rest[iou <= iou_threshold]]
    return out


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[2], boxes[:, 2])
    y1 = np.minimum(box[3], boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    area = lambda b: (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1])  # noqa: E731
    return inter / np.maximum(area(box) + area(boxes) - inter, 1e-12)


def refine_from_heatmaps(xy_norm: np.ndarray, heatmaps: np.ndarray, *, kernel: int = 7, min_conf: float = 0.5):
    """MediaPipe's RefineLandmarksFromHeatmap: the sigmoid-weighted mean position in a kernel x kernel
    window (cut at the heatmap's border) of each landmark's heatmap, all landmarks at once; a landmark
    outside the heatmap or without a window value >= ``min_conf`` keeps its position.
    xy_norm: (L, 2) in [0, 1] of the crop; heatmaps: (h, w, L)."""
    h, w, n = heatmaps.shape
    out = xy_norm.copy()
    m = min(n, xy_norm.shape[0])
    half = (kernel - 1) // 2
    col = (xy_norm[:m, 0] * w).astype(np.int64)  # truncated as MediaPipe does
    row = (xy_norm[:m, 1] * h).astype(np.int64)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    offsets = np.arange(-half, half + 1)
    rr = row[:, None, None] + offsets[None, :, None]  # (m, k, 1)
    cc = col[:, None, None] + offsets[None, None, :]  # (m, 1, k)
    valid = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)  # (m, k, k)
    values = heatmaps[np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1), np.arange(m)[:, None, None]]
    conf = np.where(valid, _sigmoid(values.astype(np.float64)), 0.0)
    total = conf.sum(axis=(1, 2))
    use = inside & (conf.max(axis=(1, 2)) >= min_conf) & (total > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (cc * conf).sum(axis=(1, 2)) / total / w
        y = (rr * conf).sum(axis=(1, 2)) / total / h
    out[:m][use] = np.stack([x, y], axis=1)[use]
    return out


class PersonDetector:
    """MediaPipe's BlazePose person detector alone: people as regions of interest (rough: the landmark
    model refines them)."""

    def __init__(self, path: Path, *, min_score: float = 0.5, num_threads: int = 2):
        if not Path(path).is_file():
            raise FileNotFoundError(f"MediaPipe person detector missing: {path} (run deploy/bootstrap.sh)")
        self.min_score = min_score
        self._model = _Tflite(Path(path), num_threads)
        self._anchors_px = ssd_anchors() * DETECTOR_INPUT_PX

    def find(self, bgr: np.ndarray) -> list[Roi]:
        """Person detector on the letterboxed BGR image -> regions of interest, best first."""
        h, w = bgr.shape[:2]
        crop = square_crop((w / 2, h / 2), max(w, h), 0.0, DETECTOR_INPUT_PX)
        x = _rgb(crop.warp(bgr)).astype(np.float32) / 127.5 - 1.0
        outs = self._model.run(x[None])
        raw = next(o for o in outs if o.shape[-1] == 12)[0]
        scores = _sigmoid(next(o for o in outs if o.shape[-1] == 1)[0, :, 0])
        keep = scores >= self.min_score
        if not keep.any():
            return []
        raw, anchors = raw[keep].astype(np.float64), self._anchors_px[keep]
        centre, size = raw[:, :2] + anchors, raw[:, 2:4]
        boxes = np.concatenate([centre - size / 2, centre + size / 2], axis=1)
        points = raw[:, 4:12].reshape(-1, 4, 2) + anchors[:, None]
        rois = []
        for score, _box, pts in weighted_nms(boxes, scores[keep], points):
            img_pts = crop.to_image(pts)
            rois.append(_roi_from_points(img_pts[0], img_pts[1], score))
        return rois


class MediaPipeDetector:
    """MediaPipe Pose on TFLite; ``detect`` returns (P, 33, 3) in the ``mediapipe33`` skeleton."""

    def __init__(self, config: MediaPipeConfig):
        self.config = config
        self.skeleton = get_skeleton("mediapipe33")
        det_path, lm_path = model_files(config)
        for p in (det_path, lm_path):
            if not p.is_file():
                raise FileNotFoundError(
                    f"MediaPipe model file missing: {p} (run deploy/bootstrap.sh, which installs the npm "
                    f"package @mediapipe/pose there, or set {MODELS_ENV})"
                )
        self._people = PersonDetector(det_path, min_score=config.min_detection_confidence,
                                      num_threads=config.num_threads)
        self._lm = _Tflite(lm_path, config.num_threads)
        self._tracks: dict[str, tuple[int, Roi]] = {}
        self._searched: dict[str, int] = {}  # camera -> frame id of its last search for newcomers

    def detect(self, image_bgr: np.ndarray, *, camera: str, frame_id: int, timestamp_ns: int) -> np.ndarray:
        """(H, W, 3) BGR -> (P, 33, 3) x px, y px, confidence; P <= ``num_poses``.

        The people tracked from the previous frame of this camera come first (their landmarks' own
        regions); the person detector then runs for the others (with one pose, only when it is lost), so a
        person the detector misses in one frame is still followed."""
        bgr = check_image(image_bgr, camera=camera)  # the models' crops are cut from it, then made RGB
        people: list[np.ndarray] = []
        regions: list[Roi] = []
        for roi in self._tracked_rois(camera, frame_id):
            self._add(bgr, roi, people, regions)
        if len(people) < self.config.num_poses and self._search_due(camera, frame_id, tracked=bool(people)):
            self._searched[camera] = frame_id
            for roi in self.find_people(bgr):
                if len(people) == self.config.num_poses:
                    break
                if not any(_centre_inside(roi, p) for p in people):  # a person already found: no rerun
                    self._add(bgr, roi, people, regions)
        self._tracks.pop(camera, None)
        if self.config.tracking and regions:
            self._tracks[camera] = (frame_id, tuple(regions))
        return np.stack(people) if people else empty_keypoints(self.skeleton.num_joints)

    def _search_due(self, camera: str, frame_id: int, *, tracked: bool) -> bool:
        """Whether the person detector runs on this frame: nobody tracked, or ``search_every`` frames since
        this camera's last search (or a frame id that went back: a restarted camera)."""
        last = self._searched.get(camera)
        return not tracked or last is None or not 0 <= frame_id - last < self.config.search_every

    def _add(self, bgr: np.ndarray, roi: Roi, people: list[np.ndarray], regions: list[Roi]) -> None:
        """Landmarks on a region, kept (with the next frame's region) unless lost or already found."""
        kp, presence, next_roi = self._landmarks(bgr, roi)
        if presence < self.config.min_tracking_confidence or any(same_person(kp, p) or box_inside(kp, p) for p in people):
            return
        people.append(kp)
        regions.append(next_roi)

    def _tracked_rois(self, camera: str, frame_id: int) -> tuple[Roi, ...]:
        if not self.config.tracking or camera not in self._tracks:
            return ()
        last_id, rois = self._tracks[camera]
        return rois if 0 < frame_id - last_id <= self.config.track_gap_frames else ()

    def find_people(self, bgr: np.ndarray) -> list[Roi]:
        """Person detector on a BGR image -> regions of interest, best first."""
        return self._people.find(bgr)

    def boxes(self, image_bgr: np.ndarray, *, camera: str, frame_id: int, timestamp_ns: int) -> np.ndarray:
        """(P, 4) x0, y0, x1, y1 px: the bounding boxes of each person's confident landmarks (for a
        top-down model, which adds its own margin)."""
        people = self.detect(image_bgr, camera=camera, frame_id=frame_id, timestamp_ns=timestamp_ns)
        return np.array([landmark_box(p) for p in people]).reshape(-1, 4)

    def _landmarks(self, bgr: np.ndarray, roi: Roi) -> tuple[np.ndarray, float, Roi]:
        """Landmark model on a region -> ((33, 3) keypoints, pose presence, next frame's region)."""
        crop: Crop = square_crop(roi.center_px, roi.side_px, roi.rotation_rad, LANDMARK_INPUT_PX)
        x = _rgb(crop.warp(bgr, replicate=True)).astype(np.float32) / 255.0  # as MediaPipe's landmark graph
        outs = self._lm.run(x[None])
        raw = next(o for o in outs if o.size == NUM_OUTPUT_LANDMARKS * 5).reshape(NUM_OUTPUT_LANDMARKS, 5)
        flag = float(next(o for o in outs if o.size == 1).ravel()[0])
        heat = next(o for o in outs if o.ndim == 4 and o.shape[-1] == NUM_OUTPUT_LANDMARKS)[0]
        xy_norm = refine_from_heatmaps(raw[:, :2].astype(np.float64) / LANDMARK_INPUT_PX, heat)
        xy = crop.to_image(xy_norm * LANDMARK_INPUT_PX)
        conf = np.minimum(_sigmoid(raw[:, 3]), _sigmoid(raw[:, 4]))
        kp = np.concatenate([xy[:33], conf[:33, None]], axis=1)
        return kp, flag, _roi_from_points(xy[33], xy[34])


class _Tflite:
    """A LiteRT interpreter with one float input; ``run`` returns all outputs."""

    def __init__(self, path: Path, num_threads: int):
        try:
            from ai_edge_litert.interpreter import Interpreter
        except ImportError as exc:
            raise ImportError("MediaPipe detector needs the ai-edge-litert package (pip install ai-edge-litert)") from exc
        self._it = Interpreter(model_path=str(path), num_threads=max(1, num_threads))
        self._it.allocate_tensors()
        self._input = self._it.get_input_details()[0]["index"]
        self._outputs = [d["index"] for d in self._it.get_output_details()]

    def run(self, x: np.ndarray) -> list[np.ndarray]:
        self._it.set_tensor(self._input, np.ascontiguousarray(x, dtype=np.float32))
        self._it.invoke()
        return [self._it.get_tensor(i) for i in self._outputs]
