"""The board shown by live simulated cameras: every camera switches at the same frame id, the clip
starts with the board on the floor where the detector finds it, the walker comes back."""

import dataclasses

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.drivers.simulated import SimTrialSpec, simulated_rig
from gaitcap.simulator.board_scene import BoardScene, BoardSceneConfig, SceneSwitch

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


def test_board_at_another_aspect_ratio_is_the_sensor_image_resized():
    from gaitcap.reconstruction.camera import Rig
    from gaitcap.simulator.board import observe_board
    from gaitcap.simulator.board_render import camera_resized

    trial = SimTrialSpec(cameras=2, seconds=5.0, fps=10.0).make()
    scene = BoardScene(trial.rig, SHORT)
    image = scene.render_gray("cam01", 0, (640, 480))  # 4:3 from a 16:10 sensor
    assert image.shape == (480, 640)
    cam = Rig((camera_resized(trial.rig["cam01"], (640, 480)),))
    truth = observe_board(cam, scene.board.geometry, scene.rot[:1], scene.tvec[:1], noise_px=0.0).corners_px[0, 0]
    found = make_board(BoardConfig()).detect(image)
    assert found is not None
    assert min(np.abs(found - truth[list(p)]).max() for p in scene.board.geometry.symmetries) < 0.5


def test_clip_loops():
    """Frame 6 of a 5-frame clip is frame 1 again (up to the image noise, 2 grey levels per image)."""
    trial = SimTrialSpec(cameras=2, seconds=5.0, fps=10.0).make()
    scene = BoardScene(trial.rig, SHORT)

    def spread(a: int, b: int) -> float:
        return float(np.std(scene.render_gray("cam01", a, (384, 240)).astype(float)
                            - scene.render_gray("cam01", b, (384, 240))))

    assert spread(1, 6) < 3.2  # noise only: 2 * sqrt(2)
    assert spread(3, 4) > 5.0  # the board moved


def test_board_clips_are_named():
    from gaitcap.simulator.board_scene import board_scene_config

    assert board_scene_config("full").motion.n_frames == 600 and len(board_scene_config("full").motion.floor_spots_mm) == 3
    with pytest.raises(ValueError, match=r"'nope' is unknown; choose one of \['full', 'short'\]"):
        board_scene_config("nope")
