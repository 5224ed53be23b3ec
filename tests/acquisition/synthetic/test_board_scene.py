"""The board shown by live simulated cameras: every camera switches at the same frame id, the clip
starts with the board on the floor where the detector finds it, the walker comes back."""

import dataclasses

import numpy as np
import pytest

from acquisition.board import BoardConfig, make_board
from acquisition.drivers.simulated import SimTrialSpec, simulated_rig
from acquisition.synthetic.board_scene import BoardScene, BoardSceneConfig, SceneSwitch

SHORT = BoardSceneConfig(motion=dataclasses.replace(BoardSceneConfig().motion, n_frames=5, floor_frames=3))


def test_switch_is_the_same_frame_id_for_every_camera():
    switch = SceneSwitch()
    period, start = 100_000_000, 1_000_000_000
    assert switch.board_index(7, camera_start_ns=start, period_ns=period) is None  # walker
    switch.set("board", start + 250_000_000)  # between frames 2 and 3: from frame 3 on
    assert [switch.board_index(i, camera_start_ns=start, period_ns=period) for i in (2, 3, 9)] == [None, 0, 6]
    switch.set("walker", start)
    assert switch.board_index(9, camera_start_ns=start, period_ns=period) is None
    with pytest.raises(ValueError, match="scene"):
        switch.set("party", 0)


def test_cameras_show_the_floor_board_then_the_walker():
    trial = SimTrialSpec(cameras=3, seconds=5.0, fps=10.0).make()
    scene = BoardScene(trial.rig, SHORT)
    cams = simulated_rig(trial, size_px=(576, 360), fps=10.0, realtime=False, max_frames=4)
    switch = SceneSwitch()
    for cam in cams:
        cam.scene = (switch, scene)
        cam.start(at_ns=0)
    switch.set("board", 150_000_000)  # from frame 2
    frames = list(cams[0].frames())
    detector = make_board(BoardConfig())
    assert [detector.detect(f.image[..., 0]) is None for f in frames] == [True, True, False, False]
    assert frames[2].image.shape == (360, 576, 3)
    with pytest.raises(ValueError, match="aspect ratio"):
        scene.clip("cam01", (640, 480))


def test_clip_loops():
    trial = SimTrialSpec(cameras=2, seconds=5.0, fps=10.0).make()
    scene = BoardScene(trial.rig, SHORT)
    assert np.array_equal(scene.render("cam01", 1, (192, 120)), scene.render("cam01", 6, (192, 120)))
