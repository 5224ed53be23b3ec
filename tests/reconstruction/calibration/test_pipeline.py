"""End to end on observations of the synthetic room: 10 cameras, 600 frames (a 60 s recording at 10 frames/s),
the board lying still on the floor first (its detection errors repeat) and laid down again at three spots."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.calibration import BoardObservations, calibrate_from_observations
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.reconstruction.calibration.still import merge_still_frames
from gaitcap.reconstruction.camera import Camera
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board
from gaitcap.simulator.room import build_rig

NOISE_PX = 0.3
N_BAD = 40
FLOOR_SPOTS_MM = ((1500.0, 1500.0), (-1500.0, 1200.0), (1000.0, -1500.0))  # the board laid down again


@pytest.fixture(scope="module")
def room():
    rig = build_rig(10, seed=0)
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=600, floor_frames=20, seed=1, floor_spots_mm=FLOOR_SPOTS_MM), rig)
    obs = observe_board(rig, board.geometry, rot, tvec, noise_px=NOISE_PX, scramble=True, seed=2, still_floor=True)
    # the trap: the floor board reported in mirror order by every camera reprojects just as well, with
    # the world upside down
    corners = obs.corners_px.copy()
    corners[:, :20] = corners[:, :20][:, :, list(board.geometry.symmetries[2])]
    # and some corners misplaced by the detector
    rng = np.random.default_rng(5)
    moving = 20 + 10 * len(FLOOR_SPOTS_MM)  # frames before this lie still on the floor
    c_idx, f_idx, n_idx = np.nonzero(np.isfinite(corners[:, moving:, :, 0]))
    bad = rng.choice(len(c_idx), N_BAD, replace=False)
    corners[c_idx[bad], f_idx[bad] + moving, n_idx[bad]] += rng.choice([-1, 1], (N_BAD, 2)) * rng.uniform(6, 20, (N_BAD, 2))
    obs = BoardObservations(obs.camera_names, obs.image_sizes_px, corners, obs.board, obs.times_s)
    return rig, obs, calibrate_from_observations(obs)


def test_recovers_the_room_rig(room):
    rig, _, res = room
    for true, got in zip(rig, res.rig, strict=True):
        assert np.linalg.norm(true.center_mm - got.center_mm) < 5.0, true.name
        assert rotation_angle_deg(true.rotation, got.rotation) < 0.2, true.name
        assert abs(got.matrix_px[0, 0] / true.matrix_px[0, 0] - 1) < 0.005, true.name
        assert abs(got.dist[0] - true.dist[0]) < 0.005, true.name
        assert np.all(got.dist[1:] == 0)  # the paper's k1-only model by default


def test_world_is_z_up_although_views_came_in_scrambled_and_mirrored_order(room):
    rig, obs, res = room
    assert all(c.center_mm[2] > 1500 for c in res.rig)
    assert not res.report.world_flipped
    # the scrambled detector orders included mirrored ones; all views still entered the bundle (each
    # still floor scene once)
    views = merge_still_frames(obs)[0].views().sum()
    assert res.report.n_corners + res.report.n_outliers >= 0.98 * views * obs.board.num_corners


def test_quality_report(room, tmp_path):
    _, obs, res = room
    rep = res.report
    assert NOISE_PX * np.sqrt(2) * 0.9 < rep.reprojection_rms_px < NOISE_PX * np.sqrt(2) * 1.1
    assert abs(rep.square_residual_pct) < 0.2
    assert N_BAD <= rep.n_outliers < 2 * N_BAD
    assert rep.floor_frames == 4  # each still floor scene counts once
    assert [q.name for q in rep.cameras] == list(obs.camera_names)
    merged_views = merge_still_frames(obs)[0].views().sum(1)
    assert all(q.n_detections == n for q, n in zip(rep.cameras, merged_views, strict=True))
    assert all(0.2 < q.coverage <= 1 and q.reprojection_p95_px > q.reprojection_mean_px for q in rep.cameras)
    assert '"reprojection_rms_px"' in json.dumps(rep.to_dict())
    save_rig(res.rig, tmp_path / "c.toml")
    back = load_rig(tmp_path / "c.toml")
    assert np.allclose(back["cam01"].center_mm, res.rig["cam01"].center_mm)


def _drop_camera_views(obs: BoardObservations, cam: int, keep: int) -> BoardObservations:
    corners = obs.corners_px.copy()
    views = np.flatnonzero(obs.views()[cam])
    corners[cam, views[: len(views) - keep]] = np.nan  # keeps its last views (the board moving)
    return BoardObservations(obs.camera_names, obs.image_sizes_px, corners, obs.board, obs.times_s)


def test_camera_that_never_sees_the_board_is_named(room):
    _, obs, _ = room
    with pytest.raises(ValueError, match=r"'cam03' \(0 views\).*record again"):
        calibrate_from_observations(_drop_camera_views(obs, 2, 0))
    with pytest.raises(ValueError, match=r"'cam05' \(3 views\)"):
        calibrate_from_observations(_drop_camera_views(obs, 4, 3))


def test_cameras_without_shared_views_are_named(room):
    _, obs, _ = room
    corners = obs.corners_px[:4].copy()
    views = obs.views()[:4]
    shared = views[3] & views[:3].any(0)
    corners[3, shared] = np.nan  # cam04 only sees the board when none of the others does
    assert (views[3] & ~shared).sum() >= 6, "the clip needs solo views of cam04 for this test"
    sub = BoardObservations(obs.camera_names[:4], obs.image_sizes_px[:4], corners, obs.board)
    with pytest.raises(ValueError, match=r"\['cam04'\] share no board views"):
        calibrate_from_observations(sub)


def test_fronto_parallel_views_are_degenerate():
    board = make_board(BoardConfig.checkerboard()).geometry
    cam = Camera("flat", (1280, 800), np.array([[900.0, 0, 640], [0, 900, 400], [0, 0, 1]]))
    rng = np.random.default_rng(0)
    corners = []
    for _ in range(10):  # board parallel to the image plane at one depth, only shifted
        pts = board.object_points_mm + [rng.uniform(-600, 0), rng.uniform(-400, 0), 2500.0]
        corners.append(cam.project(pts) + rng.normal(0, 0.3, (board.num_corners, 2)))
    obs = BoardObservations(("flat",), ((1280, 800),), np.array(corners)[None], board)
    with pytest.raises(ValueError, match="camera 'flat': board views are degenerate.*0 of 10 views are tilted"):
        calibrate_from_observations(obs)


def test_identical_cameras_are_grouped_by_image_size_and_focal_length():
    from gaitcap.reconstruction.calibration.pipeline import focal_groups

    # caliscope's 4 webcams: only the two of 637 and 640 px are one model
    assert focal_groups([(1280, 720)] * 4, np.array([895.0, 704, 637, 640]), 0.05).tolist() == [-1, -1, 0, 0]
    # a chain of focal lengths each within 5 % of the next is one model; another image size is not
    groups = focal_groups([(1920, 1080)] * 4 + [(1280, 720)], np.array([1050.0, 1090, 1130, 1400, 1100]), 0.05)
    assert groups.tolist() == [0, 0, 0, -1, -1]
