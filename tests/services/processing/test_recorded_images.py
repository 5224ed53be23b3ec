"""The images a recording holds per camera, for the quality judgement: from the recorder's summary, or from
the file for a recording recovered after a crash and for a camera whose counter restarted."""

import json

from gaitcap.acquisition.encoding import image_message
from gaitcap.acquisition.recording.reader import read_keypoints, read_summary
from gaitcap.acquisition.recording.recovery import recover
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.services.nodes.recorder import CameraTally
from gaitcap.services.processing.recorded_images import recorded_images

T0, PERIOD, N, FIRST = 1_700_000_000_000_000_000, 33_333_333, 40, 500
CAMS = ("cam0", "cam1", "cam2")
DROPPED = {11, 12, 13}  # images of cam2 the recorder dropped


def _frames(cam: str) -> list[tuple[int, int]]:
    """(frame id, timestamp ns) of a camera's images: cam1 restarts at frame 20 (its counter from 0 again)."""
    out = [(k - 20 if cam == "cam1" and k >= 20 else FIRST + k, T0 + k * PERIOD + 1000) for k in range(N)]
    return [f for k, f in enumerate(out) if not (cam == "cam2" and k in DROPPED)]


def _write(path, *, finish: bool):
    w = TrialWriter(path)
    w.start(metadata={"trial_id": "t"}, time_ns=T0)
    for cam in CAMS:
        for fid, ts in _frames(cam):
            w.add_frame(cam, image_message(b"\xff\xd8jpeg", camera=cam, timestamp_ns=ts), timestamp_ns=ts,
                        frame_id=fid, receive_ns=ts)
            kp = {"camera": cam, "frame_id": fid, "timestamp_ns": ts, "skeleton": "halpe26", "people": []}
            w.add_keypoints(cam, json.dumps(kp).encode(), timestamp_ns=ts, frame_id=fid)
    if not finish:
        w.flush()
        return w.abort()
    tallies = {c: CameraTally(frames=len(_frames(c)), frame_ids=[f for f, _ in _frames(c)]) for c in CAMS}
    return w.finish({"cameras": {c: t.summary(FIRST + N - 1) for c, t in tallies.items()}, "dropped_images": {"cam2": 3}})


def test_summary_ids_with_a_restarted_camera_placed_by_time_and_the_recorders_drops(tmp_path):
    path = _write(tmp_path / "t.mcap", finish=True)
    summary = read_summary(path)
    assert summary["cameras"]["cam1"]["restarts"] == 1
    got = recorded_images(path, summary, read_keypoints(path))
    assert not got.recovered and got.dropped == {"cam2": 3}
    assert got.frames["cam0"].tolist() == got.frames["cam1"].tolist() == list(range(FIRST, FIRST + N))
    assert got.frames["cam2"].tolist() == [FIRST + k for k in range(N) if k not in DROPPED]


def test_a_recovered_recording_is_counted_from_the_file(tmp_path):
    part = _write(tmp_path / "t.mcap", finish=False)
    path = recover(part).output
    got = recorded_images(path, read_summary(path), read_keypoints(path))
    assert got.recovered and got.dropped == {}
    assert got.frames["cam1"].tolist() == list(range(FIRST, FIRST + N))
    assert got.frames["cam2"].tolist() == [FIRST + k for k in range(N) if k not in DROPPED]
