"""Intrinsics chosen per camera by held-out error (synthetic room, 2 cameras whose principal points lie
60 px off their image centres, the board shown across each image): with the principal point held at the
centre each camera turns to make up for it and explains views it did not fit worse, so the free principal
point is chosen for every camera, with the figures that made the choice in its reason and notes."""

from dataclasses import replace

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.reconstruction.calibration import (
    CalibrationConfig,
    IntrinsicsConfig,
    calibrate_from_observations,
)
from gaitcap.reconstruction.calibration.holdout import HoldoutConfig
from gaitcap.reconstruction.calibration.intrinsics import DistortionModel, PrincipalPoint
from gaitcap.reconstruction.calibration.model_choice import (
    Candidate,
    best_single_fallback,
    choose_fit,
    choose_intrinsics,
    fit_candidates,
)
from gaitcap.reconstruction.camera import Rig
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board
from gaitcap.simulator.room import build_rig

HELD, FREE = (Candidate(DistortionModel.K1, p) for p in (PrincipalPoint.HELD, PrincipalPoint.FREE))


@pytest.fixture(scope="module")
def shifted():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    moved = []
    for cam in rig:
        k = cam.matrix_px.copy()
        k[:2, 2] = np.asarray(cam.size_px) / 2 + [60.0, -60.0]
        moved.append(replace(cam, matrix_px=k))
    rig = Rig(tuple(moved))
    board = make_board(BoardConfig.checkerboard()).geometry
    rot, tvec = board_trajectory(board, BoardMotion(n_frames=80, floor_frames=5, seed=1), rig)
    return rig, observe_board(rig, board, rot, tvec, noise_px=0.3, seed=2)


def test_a_principal_point_off_the_centre_is_freed_by_held_out_error(shifted):
    rig, obs = shifted
    base = CalibrationConfig(intrinsics=IntrinsicsConfig(max_views=15))
    config, choice = choose_intrinsics(obs, base, candidates=(HELD, FREE), holdout=HoldoutConfig(folds=2))
    assert choice.candidates == (HELD.label, FREE.label) and choice.failures == {}
    for name in obs.camera_names:
        held, free = choice.held_out_rms_px[name]
        assert free < 0.9 * held, (name, held, free)
        assert choice.chosen[name] == "k1, principal point free"
        assert choice.reasons[name] == (f"intrinsics k1, principal point free chosen by held-out error (2 folds in "
                                        f"time): {free:.3f} px; k1, principal point held {held:.3f} px")
        assert config.intrinsics_of(name).principal_point is PrincipalPoint.FREE
    result = calibrate_from_observations(obs, config=config)
    for q, cam, true in zip(result.report.cameras, result.rig, rig, strict=True):
        assert choice.reasons[q.name] in q.notes and q.ok
        assert np.linalg.norm(cam.matrix_px[:2, 2] - true.matrix_px[:2, 2]) < 10, (cam.name, cam.matrix_px)
    assert choice.fallback == "" and len(choice.rig_rms_px) == 2
    assert choice.combined_rms_px == choice.rig_rms_px[1] < choice.rig_rms_px[0]


def test_the_best_single_candidate_replaces_choices_that_hold_out_worse_together():
    cands = (HELD, FREE)
    picks, rms, why = best_single_fallback([0, 1], np.array([1.10, 1.05]), 1.20, cands)
    assert picks == [1, 1] and rms == 1.05
    assert why == ("each camera's own choice together held out 1.200 px over the rig, the best single candidate "
                   "(k1, principal point free) 1.050 px: it is taken for every camera")
    assert best_single_fallback([0, 1], np.array([1.10, 1.05]), 1.00, cands) == ([0, 1], 1.00, "")
    assert best_single_fallback([0, 1], np.array([np.nan, 1.05]), np.nan, cands)[0] == [1, 1]  # the mix failed
    assert best_single_fallback([1, 1], np.array([1.10, 1.05]), 1.05, cands) == ([1, 1], 1.05, "")


def test_the_fit_is_chosen_by_held_out_error_among_the_losses_and_the_given_intrinsics(shifted):
    rig, obs = shifted
    known = CalibrationConfig(known_intrinsics={c.name: (c.matrix_px, c.dist) for c in rig})
    assert list(fit_candidates(CalibrationConfig())) == ["soft-L1 (1 px)", "least squares"]
    candidates = fit_candidates(known)
    assert list(candidates) == ["given intrinsics held, soft-L1 (1 px)", "given intrinsics held, least squares",
                                "intrinsics from the clip, soft-L1 (1 px)", "intrinsics from the clip, least squares"]
    assert candidates["intrinsics from the clip, least squares"].known_intrinsics is None
    assert candidates["given intrinsics held, least squares"].bundle.loss == "linear"
    config, fit = choose_fit(obs, known, holdout=HoldoutConfig(folds=3))
    # the true intrinsics held explain unseen views at the noise, better than the clip's estimates
    assert fit.chosen.startswith("given intrinsics held") and config.known_intrinsics is not None
    assert np.all(np.isfinite(fit.rig_rms_px)) and min(fit.rig_rms_px[:2]) <= min(fit.rig_rms_px[2:])
    assert fit.rig_rms_px[0] < 1.2 * 0.3 * np.sqrt(2) and fit.reason.startswith(f"fit {fit.chosen} chosen")
    assert "intrinsics from the clip, least squares" in fit.reason and fit.to_dict()["chosen"] == fit.chosen
