import time

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.drivers.base import CaptureSettings
from gaitcap.acquisition.drivers.sources import VideoSource
from gaitcap.acquisition.drivers.video import VideoCamera
from gaitcap.acquisition.recording.reader import iter_frames, read_summary
from gaitcap.services.bus.control import RecorderClient
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.camera import CameraNode
from gaitcap.services.nodes.recorder import RecorderNode


def write_video(path, frames=12, fps=25.0, size=(64, 48)):
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert out.isOpened()
    for i in range(frames):
        img = np.full((size[1], size[0], 3), 10 * i, np.uint8)
        out.write(img)
    out.release()
    return path


def test_video_file_frames_and_timestamps(tmp_path):
    cam = VideoCamera(write_video(tmp_path / "left.avi"), realtime=False)
    assert cam.name == "left"
    cam.open()
    cam.configure(CaptureSettings(fps=30, exposure_us=None))
    assert cam.file_fps == pytest.approx(25.0)
    cam.start(1_000_000_000)
    frames = list(cam.frames())
    assert [f.frame_id for f in frames] == list(range(12))
    assert frames[3].timestamp_ns == 1_000_000_000 + 3 * 40_000_000  # the file's 25 fps
    assert abs(int(frames[5].image.mean()) - 50) <= 3
    assert cam.status().frames == 12 and cam.status().state == "stopped"
    cam.close()


def test_bad_video_sources(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.avi"):
        VideoCamera(tmp_path / "nope.avi")
    (tmp_path / "junk.avi").write_bytes(b"not a video")
    with pytest.raises(ValueError, match="junk.avi"):
        VideoCamera(tmp_path / "junk.avi").open()
    with pytest.raises(ValueError, match="--video"):
        VideoSource().build()


def test_video_files_feed_the_live_pipeline_into_an_mcap(tmp_path):
    files = [write_video(tmp_path / f"cam{i}.avi", frames=10) for i in range(2)]
    drivers = VideoSource(files=tuple(str(f) for f in files), fps=25, realtime=False).build()
    bus = BusConfig.free_local(["recorder", "camera-0"], prefix="gaitcap/vid")
    srec, scam = open_session(bus, "recorder"), open_session(bus, "camera-0")
    rec = RecorderNode(srec, bus, data_root=tmp_path)
    try:
        deadline = time.monotonic() + 10
        while "recorder" not in alive_nodes(scam, bus) and time.monotonic() < deadline:
            time.sleep(0.05)
        client = RecorderClient(scam, bus.keys)
        client.start(trial_id="v", path=str(tmp_path / "v.mcap"))
        node = CameraNode(scam, bus, "camera-0", drivers)
        node.run(start_at_ns=time.time_ns())
        time.sleep(0.5)
        out = client.stop("v")
        assert out.summary["frames"] == 20
        frames = list(iter_frames(out.path, "cam1"))
        assert [f.frame_id for f in frames] == list(range(10)) and frames[0].image().shape == (48, 64, 3)
        assert read_summary(out.path)["cameras"]["cam0"]["gaps"] == []
        node.close()
    finally:
        rec.close()
        srec.close()
        scam.close()
