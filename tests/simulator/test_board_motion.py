"""A moving synthetic board: motion blur (the image averaged over the exposure) and a rolling shutter
(rows read out one after another skew it). Detection and calibration degrade gracefully, and views
smeared during the readout are found by their speed."""

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.boards.pairing import smeared_views
from gaitcap.reconstruction.calibration import calibrate_from_observations
from gaitcap.reconstruction.calibration.compare import compare_rigs
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board, scaled_rig
from gaitcap.simulator.board_render import BoardRenderer, Exposure, camera_at
from gaitcap.simulator.room import build_rig


@pytest.fixture(scope="module")
def scene():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02", "cam03", "cam04"])
    board = make_board(BoardConfig.charuco())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=300, floor_frames=10, seed=0), rig)
    return rig, board.geometry, rot, tvec


def test_rows_read_later_see_the_board_further_on(scene):
    rig, geometry, rot, tvec = scene
    still = observe_board(rig, geometry, rot, tvec, noise_px=0.0)
    rolled = observe_board(rig, geometry, rot, tvec, noise_px=0.0, readout_s=0.03)
    both = np.isfinite(still.corners_px[..., 0]) & np.isfinite(rolled.corners_px[..., 0])
    shift = np.linalg.norm(rolled.corners_px - still.corners_px, axis=-1)[both]
    floor = np.zeros(still.shape[1], dtype=bool)
    floor[:9] = True  # the board lies still on the floor first (until frame 9, when it is lifted)
    assert np.nanmax(np.linalg.norm(rolled.corners_px - still.corners_px, axis=-1)[:, floor]) < 1e-9
    # a corner in row y is seen 30 ms x y / height later: rows read late see the board further on
    row = (still.corners_px[..., 1] / np.array([s[1] for s in still.image_sizes_px])[:, None, None])[both]
    moving = shift > 0
    top, bottom = np.median(shift[moving & (row < 0.3)]), np.median(shift[moving & (row > 0.7)])
    assert np.median(shift[moving]) > 1.0 and bottom > 2 * top, (top, bottom)


def test_calibration_degrades_gracefully_and_smeared_views_are_found(scene):
    rig, geometry, rot, tvec = scene
    sharp = calibrate_from_observations(observe_board(rig, geometry, rot, tvec, noise_px=0.3, seed=1))
    obs = observe_board(rig, geometry, rot, tvec, noise_px=0.3, seed=1, readout_s=0.01)
    rolled = calibrate_from_observations(obs)
    a, b = compare_rigs(rig, sharp.rig), compare_rigs(rig, rolled.rig)
    # measured: 3.4 mm / 0.06 deg -> 7.6 mm / 0.37 deg, RMS 0.41 -> 0.52 px: worse, still usable, no failure
    assert a.centre_mm_max < 5.0 and a.rotation_deg_max < 0.1, (a.centre_mm_max, a.rotation_deg_max)
    assert b.centre_mm_max < 12.0 and b.rotation_deg_max < 0.6, (b.centre_mm_max, b.rotation_deg_max)
    assert rolled.report.reprojection_rms_px > sharp.report.reprojection_rms_px
    # the views smeared by more than 1 px in 10 ms are the fast ones: half of each camera's, at most
    smeared = smeared_views(obs.corners_px, np.broadcast_to(obs.times_s, obs.shape[:2]), 1.0, readout_s=0.01)
    views = obs.views().sum(1)
    assert np.all(smeared.sum(1) <= views // 2) and smeared.sum() > 0.3 * views.sum()
    assert not smeared[:, :9].any()  # the still floor board


def test_motion_blur_loses_views_but_never_misplaces_corners():
    rig = build_rig(10, seed=0).subset(["cam01"])
    board = make_board(BoardConfig.charuco())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=120, floor_frames=3, seed=2), rig)
    truth = observe_board(scaled_rig(rig, 0.5), board.geometry, rot, tvec, noise_px=0.0)
    frames = np.flatnonzero(truth.views()[0])[3:7]  # after the floor frames (the board far away)
    renderer = BoardRenderer(rig[0], board, size_px=camera_at(rig[0], 0.5).size_px)

    def detect(exposure_s: float) -> list[float]:
        """Each found view's largest corner error, px, with the board moving 1 m/s sideways."""
        errors = []
        for f in frames:
            image = renderer.render(rot[f], tvec[f], np.random.default_rng(0),
                                    Exposure((1000.0, 0.0, 0.0), exposure_s, samples=5))
            found = board.detect(image)
            if found is not None:
                errors.append(min(np.nanmax(np.linalg.norm(found - truth.corners_px[0, f][list(p)], axis=-1))
                                  for p in board.geometry.symmetries))
        return errors

    sharp, smeared, lost = detect(0.0), detect(0.016), detect(0.064)  # 0, 16 and 64 mm of smear
    assert len(sharp) >= 3 and max(sharp) < 1.0, sharp
    # measured: the same views found at 16 mm of smear (errors 0.2-0.5 px), none at 64 mm; never a wrong one
    assert len(smeared) >= len(sharp) - 1 and max(smeared) < 1.0, smeared
    assert len(lost) <= len(smeared) and all(e < 1.5 for e in lost), lost
