"""The synthetic calibration board: poses, observations and rendered images the real detector finds."""

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.simulator.board import (
    FLOOR_ROTATION,
    BoardMotion,
    board_trajectory,
    observe_board,
    render_board_images,
    scaled_rig,
)
from gaitcap.simulator.room import build_rig


@pytest.fixture(scope="module")
def clip():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=40, floor_frames=3, seed=3), rig)
    return rig, board, rot, tvec


def test_trajectory_starts_on_the_floor_and_stays_rigid(clip):
    _, board, rot, tvec = clip
    assert np.allclose(rot[:3], FLOOR_ROTATION) and np.allclose(tvec[:3], 0)
    assert np.allclose(rot @ np.swapaxes(rot, 1, 2), np.eye(3), atol=1e-9)
    assert np.allclose(np.linalg.det(rot), 1)
    centres = rot[3:] @ board.geometry.object_points_mm.mean(0) + tvec[3:]
    assert np.all(centres[:, 2] > 200)  # carried above the floor


def test_observations_show_only_the_printed_face_with_the_given_noise(clip):
    rig, board, rot, tvec = clip
    clean = observe_board(rig, board.geometry, rot, tvec, noise_px=0.0)
    noisy = observe_board(rig, board.geometry, rot, tvec, noise_px=0.5, seed=1)
    both = np.isfinite(clean.corners_px) & np.isfinite(noisy.corners_px)
    assert 0.4 < np.std((noisy.corners_px - clean.corners_px)[both]) < 0.6
    world = np.einsum("fij,nj->fni", rot, board.geometry.object_points_mm) + tvec[:, None]
    for c, cam in enumerate(rig):
        seen = clean.views()[c]
        facing = np.einsum("fi,fi->f", cam.center_mm - world.mean(1), -rot[:, :, 2]) > 0
        assert seen.any() and not (seen & ~facing).any()
        assert np.allclose(clean.corners_px[c, seen], cam.project(world[seen]))


def test_scrambled_orders_are_board_symmetries(clip):
    rig, board, rot, tvec = clip
    clean = observe_board(rig, board.geometry, rot, tvec, noise_px=0.0)
    mixed = observe_board(rig, board.geometry, rot, tvec, noise_px=0.0, scramble=True, seed=4)
    syms = [np.asarray(p) for p in board.geometry.symmetries]
    used = set()
    for c, f in zip(*np.nonzero(clean.views()), strict=True):
        match = [i for i, p in enumerate(syms) if np.allclose(clean.corners_px[c, f][p], mixed.corners_px[c, f])]
        assert match, (c, f)
        used.add(match[0])
    assert len(used) > 1


def test_rendered_images_give_the_projected_corners(clip):
    rig, board, rot, tvec = clip
    frames = np.arange(0, 40, 5)
    scale = 0.3
    images = render_board_images(rig, board, rot[frames], tvec[frames], scale=scale)
    truth = observe_board(scaled_rig(rig, scale), board.geometry, rot[frames], tvec[frames], noise_px=0.0)
    errors, found = [], 0
    for c, cam in enumerate(rig.names):
        assert images[cam].shape == (len(frames), 360, 576)
        for i in np.flatnonzero(truth.views()[c]):
            corners = board.detect(images[cam][i])
            if corners is None:
                continue
            found += 1
            errors.append(min(np.abs(corners - truth.corners_px[c, i][list(p)]).max()
                              for p in board.geometry.symmetries))
    assert found >= 0.6 * truth.views().sum()
    assert np.median(errors) < 0.3


def test_full_resolution_views_are_found_coarse_to_fine_with_full_resolution_accuracy(clip):
    """At 1920 x 1200 px the detector finds the board at half size and its corners again in a crop:
    every view the full-size search finds, with corners as accurate."""
    rig, board, rot, tvec = clip
    frames = np.arange(3, 40, 6)
    cam = rig.subset(["cam02"])
    images = render_board_images(cam, board, rot[frames], tvec[frames], scale=1.0)["cam02"]
    truth = observe_board(cam, board.geometry, rot[frames], tvec[frames], noise_px=0.0)
    assert images.shape[1:] == (1200, 1920)
    errors, full_errors = [], []
    for i in np.flatnonzero(truth.views()[0]):
        full = board._find(images[i])  # the plain full-size search
        if full is None:
            continue
        corners = board.detect(images[i])
        assert corners is not None, f"frame {frames[i]}: found at full size but not coarse to fine"
        expected = truth.corners_px[0, i]
        errors.append(min(np.linalg.norm(corners - expected[list(p)], axis=-1).max() for p in board.geometry.symmetries))
        full_errors.append(min(np.linalg.norm(full - expected[list(p)], axis=-1).max() for p in board.geometry.symmetries))
    assert len(errors) >= 3
    assert np.median(errors) < 0.3 and np.median(errors) <= 1.2 * np.median(full_errors)
