"""MediaPipe Pose offline on a real video of a person walking (the sports2d demo: side view, right to left).

The model files and the video are installed by deploy/bootstrap.sh under <venv>/share/gaitcap/.
"""

import functools
from pathlib import Path

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.detectors.base import DETECTOR_CONFIGS, Detector
from gaitcap.acquisition.detectors.mediapipe import (
    MediaPipeConfig,
    box_inside,
    default_model_dir,
    refine_from_heatmaps,
    same_person,
    ssd_anchors,
    weighted_nms,
)
from gaitcap.acquisition.installed import share_path

VIDEO = share_path("testdata", "sports2d-demo.mp4")
FIRST, COUNT = 80, 90  # the walker crosses the frame in these frames (30 fps)

needs_models = pytest.mark.skipif(
    not (default_model_dir() / "pose_landmark_full.tflite").is_file() or not VIDEO.is_file(),
    reason="MediaPipe models / test video not installed (run deploy/bootstrap.sh)",
)


@functools.lru_cache(maxsize=4)
def _frames(first, count):
    cap = cv2.VideoCapture(str(VIDEO))
    cap.set(cv2.CAP_PROP_POS_FRAMES, first)
    frames = []
    for _ in range(count):
        ok, frame = cap.read()
        assert ok, "demo video shorter than expected"
        frames.append(frame)
    cap.release()
    return tuple(frames)


@pytest.fixture(scope="module")
def walk():
    """(T, 33, 3) keypoints of the walker, and the detector (one pose: tracked from frame to frame)."""
    det = MediaPipeConfig(num_poses=1).build()
    out = []
    for i, frame in enumerate(_frames(FIRST, COUNT)):
        kp = det.detect(frame, camera="side", frame_id=FIRST + i, timestamp_ns=0)
        assert kp.ndim == 3 and kp.shape[1:] == (33, 3) and kp.shape[0] <= 1
        out.append(kp[0] if len(kp) else np.full((33, 3), np.nan))
    return np.array(out), det


def test_anchor_layout():
    a = ssd_anchors()
    assert a.shape == (2254, 2)
    np.testing.assert_allclose(a[0], [0.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(a[1], a[0])  # two anchors per cell at stride 8
    np.testing.assert_allclose(a[2], [1.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(a[-1], [6.5 / 7, 6.5 / 7])


def test_weighted_nms_merges_overlapping_boxes():
    boxes = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [50, 50, 60, 60]], float)
    scores = np.array([0.9, 0.3, 0.6])
    pts = boxes[:, None, :2].repeat(4, axis=1)
    out = weighted_nms(boxes, scores, pts)
    assert [round(s, 2) for s, _, _ in out] == [0.9, 0.6]
    np.testing.assert_allclose(out[0][1], [0.25, 0, 10.25, 10])  # score-weighted mean


def test_heatmap_refinement_moves_to_the_peak():
    heat = np.full((64, 64, 2), -10.0)
    heat[30:33, 40:43, 0] = 5.0  # peak centred on col 41, row 31
    xy = refine_from_heatmaps(np.array([[40 / 64, 30 / 64], [0.5, 0.5]]), heat)
    np.testing.assert_allclose(xy[0], [41 / 64, 31 / 64], atol=1e-3)
    np.testing.assert_allclose(xy[1], [0.5, 0.5])  # nothing confident there: unchanged


def _refined_one_by_one(xy_norm, heatmaps, kernel=7, min_conf=0.5):
    """MediaPipe's refinement written out landmark by landmark (the window cut at the border)."""
    h, w, _ = heatmaps.shape
    out, half = xy_norm.copy(), (kernel - 1) // 2
    for i, (x, y) in enumerate(xy_norm):
        col, row = int(x * w), int(y * h)
        if not (0 <= col < w and 0 <= row < h):
            continue
        r0, c0 = max(0, row - half), max(0, col - half)
        conf = 1 / (1 + np.exp(-heatmaps[r0 : row + half + 1, c0 : col + half + 1, i].astype(float)))
        if conf.max() >= min_conf:
            rr, cc = np.mgrid[r0 : r0 + conf.shape[0], c0 : c0 + conf.shape[1]]
            out[i] = ((cc * conf).sum() / conf.sum() / w, (rr * conf).sum() / conf.sum() / h)
    return out


def test_heatmap_refinement_of_all_landmarks_at_once_is_the_one_by_one_refinement():
    rng = np.random.default_rng(3)
    for _ in range(20):
        heat = rng.normal(-1, 3, (64, 64, 39)).astype(np.float32)
        xy = rng.uniform(-0.1, 1.1, (39, 2))  # some outside the crop, many windows cut at its border
        np.testing.assert_allclose(refine_from_heatmaps(xy, heat), _refined_one_by_one(xy, heat), atol=1e-12)


def test_same_person():
    a = np.zeros((33, 3))
    a[:, 0], a[:, 1] = np.linspace(0, 100, 33), np.linspace(0, 200, 33)
    assert same_person(a + [3, 3, 0], a)
    assert not same_person(a + [60, 0, 0], a)


def test_box_inside():
    a = np.zeros((33, 3))
    a[:, 0], a[:, 1], a[:, 2] = np.linspace(0, 100, 33), np.linspace(0, 400, 33), 1.0
    legs = a.copy()
    legs[:20] = a[20]  # a second region on the same body: the lower half
    assert box_inside(legs, a)
    assert not box_inside(a + [150, 0, 0], a)  # side by side
    assert not box_inside(a + [60, 0, 0], a)  # overlapping by 40 %


def test_config_checks_and_missing_models(tmp_path):
    assert DETECTOR_CONFIGS["mediapipe"] is MediaPipeConfig
    with pytest.raises(ValueError, match="mediapipe model"):
        MediaPipeConfig(model="huge")
    with pytest.raises(FileNotFoundError, match="bootstrap"):
        MediaPipeConfig(model_dir=tmp_path).build()


@needs_models
def test_walker_anatomy_and_direction(walk):
    kp, det = walk
    assert isinstance(det, Detector) and det.skeleton.name == "mediapipe33"
    j = det.skeleton.index
    found = np.isfinite(kp[:, 0, 0])
    assert found.mean() >= 0.95
    kp = kp[found]
    assert np.all((kp[..., 2] >= 0) & (kp[..., 2] <= 1))
    y = lambda n: kp[:, j(n), 1]  # noqa: E731  (image y points down)
    for side in ("left", "right"):
        order = (y(f"{side}_shoulder") < y(f"{side}_hip")) & (y(f"{side}_hip") < y(f"{side}_knee"))
        order &= (y(f"{side}_knee") < y(f"{side}_ankle")) & (y(f"{side}_knee") < y(f"{side}_heel"))
        assert order.mean() >= 0.9, side
    assert np.median(y("nose")) < np.median(y("left_shoulder"))
    # The walker is in the lower half of the 1768 x 994 frame and walks right to left at ~10 px/frame.
    hip_x = (kp[:, j("left_hip"), 0] + kp[:, j("right_hip"), 0]) / 2
    assert np.all(np.median(y("left_heel")) > 994 / 2)
    slope = np.polyfit(np.flatnonzero(found), hip_x, 1)[0]
    assert -14 < slope < -6


@needs_models
def test_agrees_with_the_official_mediapipe(walk):
    """Reference: Google's own mediapipe 0.10.21 (legacy ``mp.solutions.pose``, full model, video mode,
    no smoothing) on the same frames, stored in data/ (generated once in a separate numpy<2 venv)."""
    kp, _ = walk
    ref = np.load(Path(__file__).parent / "data" / "mediapipe_0.10.21_sports2d_demo.npz")
    mine = kp[ref["frames"] - FIRST]
    dist = np.linalg.norm(mine[:, :, :2] - ref["keypoints_px"][:, :, :2], axis=-1)
    assert np.median(dist) < 4.0  # px, in a 1768 x 994 frame (measured 1.9)
    assert np.percentile(dist, 90) < 12.0  # (measured 5.5)
    vis_diff = np.abs(mine[:, :, 2] - ref["keypoints_px"][:, :, 2])
    assert np.median(vis_diff) < 0.01 and vis_diff.max() < 0.3  # (measured 0.0004, max 0.19)


@needs_models
def test_image_mode_agrees_with_the_official_mediapipe():
    """The person detector path (every frame detected, no tracking) against mediapipe's image mode."""
    ref = np.load(Path(__file__).parent / "data" / "mediapipe_0.10.21_sports2d_demo.npz")
    det = MediaPipeConfig(tracking=False, num_poses=1).build()
    frames = _frames(FIRST, COUNT)
    mine = np.full((len(ref["frames"]), 33, 3), np.nan)
    for k, f in enumerate(ref["frames"]):
        kp = det.detect(frames[f - FIRST], camera="side", frame_id=int(f), timestamp_ns=0)
        if len(kp):
            mine[k] = kp[0]
    theirs = ref["keypoints_image_mode_px"]
    found_mine, found_theirs = np.isfinite(mine[:, 0, 0]), np.isfinite(theirs[:, 0, 0])
    assert np.mean(found_mine == found_theirs) >= 0.9 and found_theirs.mean() > 0.7
    both = found_mine & found_theirs
    dist = np.linalg.norm(mine[both, :, :2] - theirs[both, :, :2], axis=-1)
    assert np.median(dist) < 5.0  # px (measured 2.4)


@needs_models
def test_walker_feet_alternate_stance_and_swing(walk):
    kp, det = walk
    j = det.skeleton.index
    hip_x = (kp[:, j("left_hip"), 0] + kp[:, j("right_hip"), 0]) / 2
    speed = np.nanmedian(np.abs(np.diff(hip_x)))
    vl = np.abs(np.diff(kp[:, j("left_heel"), 0]))
    vr = np.abs(np.diff(kp[:, j("right_heel"), 0]))
    still = lambda v: v < 0.5 * speed  # noqa: E731  (stance: the heel stays put)
    swing = lambda v: v > 1.5 * speed  # noqa: E731  (swing: it moves faster than the body)
    assert np.mean(still(np.minimum(vl, vr))) >= 0.65  # mostly a foot on the ground
    assert np.mean(swing(vl) & swing(vr)) <= 0.2  # rarely both feet in the air
    for v in (vl, vr):
        assert 0.2 <= np.mean(still(v)) <= 0.7 and np.mean(swing(v)) >= 0.2
    one_swings = swing(vl) | swing(vr)
    other_still = np.where(swing(vl), still(vr), still(vl))
    assert np.mean(other_still[one_swings]) >= 0.55


@needs_models
def test_tracking_reuses_the_region_and_blank_image_finds_nobody(monkeypatch):
    det = MediaPipeConfig(num_poses=1).build()
    calls = []
    real = det.find_people
    monkeypatch.setattr(det, "find_people", lambda rgb: calls.append(1) or real(rgb))
    frames = _frames(120, 6)
    for i, frame in enumerate(frames):
        assert det.detect(frame, camera="a", frame_id=i, timestamp_ns=0).shape == (1, 33, 3)
    assert len(calls) == 1  # detector once, then the landmarks' own region
    det.detect(frames[0], camera="b", frame_id=0, timestamp_ns=0)  # another camera: its own track
    det.detect(frames[0], camera="a", frame_id=10, timestamp_ns=0)  # a gap: detect again
    assert len(calls) == 3


@needs_models
def test_tracking_holds_over_one_missing_frame_and_restarts_after_a_longer_gap(monkeypatch):
    """Completing the frames between live ones after Stop: a camera's frames 0, 1, 3, 4 (2 detected live)
    keep the walker's region; with ``track_gap_frames=1`` (MediaPipe's own way) frame 3 searches again, and
    frames 4 -> 7 is a gap of 3: searched again with the default too."""
    frames = _frames(120, 8)
    for gap, searches in ((2, [0, 7]), (1, [0, 3, 7])):
        det = MediaPipeConfig(num_poses=1, track_gap_frames=gap).build()
        calls, now = [], [0]  # the frame ids the person detector ran on; the frame being detected
        real = det.find_people
        monkeypatch.setattr(det, "find_people", lambda bgr, calls=calls, now=now, real=real: calls.append(now[0])
                            or real(bgr))
        found = []
        for i in (0, 1, 3, 4, 7):
            now[0] = i
            found.append(len(det.detect(frames[i], camera="a", frame_id=i, timestamp_ns=0)))
        assert found == [1] * 5 and calls == searches, (gap, calls)
    with pytest.raises(ValueError, match="track_gap_frames"):
        MediaPipeConfig(track_gap_frames=0)
    blank = np.full((480, 640, 3), 127, np.uint8)
    assert det.detect(blank, camera="c", frame_id=0, timestamp_ns=0).shape == (0, 33, 3)


@needs_models
def test_everyone_by_default_finds_the_walker_once_in_every_frame():
    """Default options look for several people (num_poses 4, tracked): the one walker of the video is
    found in all 90 frames and never twice (the person detector's second region on a body, e.g. the
    legs alone, is the same person)."""
    det = MediaPipeConfig().build()
    assert det.config.num_poses > 1
    counts = [len(det.detect(f, camera="side", frame_id=i, timestamp_ns=0))
              for i, f in enumerate(_frames(FIRST, COUNT))]
    assert counts == [1] * COUNT  # (4 poses untracked, without box_inside: 1 frame had none, 10 had 2-3)


@needs_models
def test_with_someone_tracked_the_person_detector_looks_for_newcomers_every_search_every_frames(monkeypatch):
    """Several poses (the default): while the walker is tracked, the person detector runs on every 5th frame
    of a camera only (each camera counted alone; a camera with nobody tracked searches every frame), and
    the walker is still found in every frame; search_every=1 is MediaPipe's every frame."""
    frames = _frames(FIRST, 20)
    for every, searches in ((5, [0, 5, 10, 15]), (1, list(range(20)))):
        det = MediaPipeConfig(search_every=every).build()
        calls = []
        real = det.find_people
        monkeypatch.setattr(det, "find_people", lambda rgb, calls=calls, real=real: calls.append(1) or real(rgb))
        searched = []
        for i, frame in enumerate(frames):
            before = len(calls)
            assert len(det.detect(frame, camera="a", frame_id=i, timestamp_ns=0)) == 1, (every, i)
            if len(calls) > before:
                searched.append(i)
        assert searched == searches, (every, searched)
    blank = np.full((480, 640, 3), 127, np.uint8)
    det = MediaPipeConfig().build()
    calls = []
    real = det.find_people
    monkeypatch.setattr(det, "find_people", lambda rgb: calls.append(1) or real(rgb))
    for i in range(3):  # nobody to track: every frame
        det.detect(blank, camera="empty", frame_id=i, timestamp_ns=0)
    assert len(calls) == 3
    with pytest.raises(ValueError, match="search_every"):
        MediaPipeConfig(search_every=0)


@needs_models
def test_lite_model_by_path_agrees_with_full(walk):
    kp_full, _ = walk
    lite = MediaPipeConfig(model=str(default_model_dir() / "pose_landmark_lite.tflite")).build()
    frame = _frames(FIRST + 40, 1)[0]
    kp = lite.detect(frame, camera="side", frame_id=0, timestamp_ns=0)
    assert kp.shape == (1, 33, 3)
    hips = [23, 24, 25, 26]  # hips and knees: the lite and full models agree within a few percent of the body
    assert np.nanmedian(np.abs(kp[0, hips, :2] - kp_full[40, hips, :2])) < 25


@needs_models
def test_landmark_boxes_hold_the_walker(walk):
    kp, det = walk
    frames = _frames(FIRST, COUNT)
    fresh = MediaPipeConfig().build()
    for i in range(0, COUNT, 30):
        (x0, y0, x1, y1), = fresh.boxes(frames[i], camera="side", frame_id=i, timestamp_ns=0)
        body = kp[i, [0, 11, 12, 23, 24, 27, 28, 29, 30], :2]  # nose, shoulders, hips, ankles, heels
        assert np.all((body[:, 0] >= x0 - 5) & (body[:, 0] <= x1 + 5) & (body[:, 1] >= y0 - 5) & (body[:, 1] <= y1 + 5))
        assert 250 < y1 - y0 < 500 and 50 < x1 - x0 < 400  # the walker is ~370 px tall in 1768 x 994
