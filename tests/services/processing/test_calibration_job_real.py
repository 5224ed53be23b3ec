"""The calibrate job on real webcam frames (caliscope's four 1280x720 webcams filming a hand-held 10 x 7
checkerboard; frames from the caliscope 0.7.5 sdist, installed by deploy/bootstrap.sh): one view per camera
is too few, and the failed calibration says so per camera, from what the board finder saw in real images."""

import cv2
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig
from gaitcap.acquisition.installed import share_path
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.processing.calibration_job import run_calibration
from gaitcap.simulator.board import write_board_mcap

FRAMES = share_path("testdata", "calibration", "caliscope-chessboard")
pytestmark = pytest.mark.skipif(not (FRAMES / "cam_0_frame_1070.jpg").exists(),
                                reason=f"caliscope checkerboard frames not installed in {FRAMES} (run deploy/bootstrap.sh)")


def test_one_real_view_per_camera_fails_naming_every_camera(tmp_path):
    frames = {f"cam{c:02d}": [cv2.cvtColor(cv2.imread(str(FRAMES / f"cam_{c}_frame_1070.jpg")), cv2.COLOR_BGR2RGB)]
              for c in range(4)}
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    try:
        mcap = write_board_mcap(tmp_path / "board.mcap", frames)
        c = cals.start_board_recording(db, recording_path_for=lambda _id: mcap, started_by="alice")
        cals.queue_calibration(db, c.id, frames=4)
        run_calibration(db, c.id, board=BoardConfig.checkerboard(10, 7, 25.0))
        got = cals.get_calibration(db, c.id)
        assert got.state == "failed" and got.error.startswith("too few board views of checkerboard 10 x 7"), got
        for cam in frames:
            # the board was found in each real image: the diagnosis counts it, it does not say "no board"
            assert f"camera '{cam}': 1 usable views, need 6" in got.error, got.error
        assert cat.latest_calibration(db) is None
    finally:
        db.close()
