"""A processed trial's viewer files, read back with the official readers: the results MCAP (mcap +
foxglove-schemas-protobuf), the .rrd (the ``rerun rrd`` commands) and the Foxglove layout."""

import json
import re
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.encoding import image_message
from gaitcap.acquisition.recording.foxglove_messages import image_annotations
from gaitcap.acquisition.recording.reader import read_keypoints
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.reconstruction.gait import analyze_gait
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.viewers.files import trial_view, write_viewer_files
from gaitcap.services.processing.viewers.foxglove_layout import SHIPPED_CAMERAS, layout_for, layout_json
from gaitcap.services.processing.viewers.rerun_trial import RerunSettings
from gaitcap.services.processing.viewers.results_mcap import gait_logs
from gaitcap.simulator import make_trial
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from scipy.spatial.transform import Rotation

T0_NS = 1_700_000_000_000_000_000
JPEG = cv2.imencode(".jpg", np.full((24, 32, 3), 90, np.uint8))[1].tobytes()


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    """A 6 s synthetic trial recorded as the recorder writes it, 'processed' with its true 3D joints."""
    root = tmp_path_factory.mktemp("data") / "trials" / "t1"
    trial = make_trial("paper", seconds=6.0, cameras=3, people=1, seed=2, fps=30.0)
    files = TrialFiles(root)
    root.mkdir(parents=True)
    w = TrialWriter(files.recording)
    w.start(metadata={"trial_id": "t1"}, calibration_toml=rig_to_toml_text(trial.rig), time_ns=T0_NS - 1000)
    kp = trial.detections.one_person
    for i, t in enumerate(trial.times_s):
        for c, cam in enumerate(trial.rig.names):
            ts = T0_NS + int(round(t * 1e9)) + 100 * c
            w.add_frame(cam, image_message(JPEG, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=i,
                        receive_ns=ts)
            msg = {"camera": cam, "frame_id": i, "timestamp_ns": ts, "skeleton": trial.skeleton.name,
                   "people": [np.nan_to_num(kp[c, i]).round(2).tolist()]}
            w.add_keypoints(cam, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=i)
            w.add_annotations(cam, image_annotations(msg), timestamp_ns=ts, frame_id=i)
    w.finish({})
    keypoints = read_keypoints(files.recording)
    traj = Reconstruction("truth", trial.points_mm, keypoints.times_s, trial.skeleton.joint_names)
    report = analyze_gait(traj.points_mm, traj.times_s, list(traj.joint_names))
    view = trial_view("t1", traj, detections=keypoints.patient(), keypoints=keypoints, rig=trial.rig,
                      report=report, recording=files.recording, bones=trial.skeleton.bone_indices)
    paths = write_viewer_files(files, "refined", view, RerunSettings(image_rate_hz=5.0))
    return trial, view, files, paths


def _protobuf(path):
    """topic -> (schema name, [(log time ns, decoded)]) of a results/trial MCAP's protobuf channels."""
    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        topics = [c.topic for c in reader.get_summary().channels.values() if c.message_encoding == "protobuf"]
        for schema, channel, message, decoded in reader.iter_decoded_messages(topics, log_time_order=False):
            out.setdefault(channel.topic, (schema.name, []))[1].append((message.log_time, decoded))
    return out


def _json_messages(path, topic):
    with open(path, "rb") as f:
        return [(m.log_time, json.loads(m.data), s.name) for s, _, m in make_reader(f).iter_messages([topic])]


def _topics(path) -> set[str]:
    with open(path, "rb") as f:
        return {c.topic for c in make_reader(f).get_summary().channels.values()}


def test_results_mcap_reads_back_in_foxglove_types_on_the_recordings_clock(processed):
    trial, view, files, paths = processed
    got = _protobuf(paths["results_mcap"])
    schemas = {topic: name for topic, (name, _) in got.items()}
    assert schemas["/tf"] == "foxglove.FrameTransform" and schemas["/rig"] == "foxglove.SceneUpdate"
    assert schemas["/skeleton"] == "foxglove.SceneUpdate" and schemas["/gait/events"] == "foxglove.Log"
    assert all(schemas[f"/camera/{c}/calibration"] == "foxglove.CameraCalibration" for c in trial.rig.names)
    for _, messages in got.values():
        times = [t for t, _ in messages]
        assert times == sorted(times)
    # Each camera's frame: its centre (m) and its optical axis in the room.
    tfs = {m.child_frame_id: m for _, m in got["/tf"][1]}
    assert set(tfs) == set(trial.rig.names) and {m.parent_frame_id for m in tfs.values()} == {"room"}
    for cam in trial.rig:
        tf = tfs[cam.name]
        np.testing.assert_allclose([tf.translation.x, tf.translation.y, tf.translation.z], cam.center_mm / 1000,
                                   atol=1e-9)
        q = Rotation.from_quat([tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w])
        np.testing.assert_allclose(q.apply([0, 0, 1]), cam.rotation[2], atol=1e-9)
    assert {e.frame_id for _, m in got["/rig"][1] for e in m.entities} == set(trial.rig.names)
    # The skeleton: one update per frame, at the frame's images' log time, joints in m.
    skeleton = got["/skeleton"][1]
    assert len(skeleton) == len(view.times_s)
    images = {m.log_time for m in _messages(files.recording, f"/camera/{trial.rig.names[1]}/image")}
    assert all(t in images for t, _ in skeleton)  # camera 1 (+100 ns) is the median of the three clocks
    k = len(skeleton) // 2
    entity = skeleton[k][1].entities[0]
    assert entity.frame_id == "room" and len(entity.spheres) == len(view.joint_names)
    spheres = np.array([[s.pose.position.x, s.pose.position.y, s.pose.position.z] for s in entity.spheres])
    np.testing.assert_allclose(spheres, trial.points_mm[k] / 1000, atol=1e-9)
    assert len(entity.lines[0].points) == 2 * len(view.bones)


def _messages(path, topic):
    with open(path, "rb") as f:
        return [m for _, _, m in make_reader(f).iter_messages([topic])]


def test_gait_events_and_steps_are_on_the_timeline(processed):
    _, view, _, paths = processed
    report = view.report
    assert len(report.steps) >= 3
    events = _protobuf(paths["results_mcap"])["/gait/events"][1]
    want = gait_logs(report)
    assert [m.message for _, m in events] == [text for _, text in want]
    assert [t for t, _ in events] == [int(view.start_ns + round(s * 1e9)) for s, _ in want]
    steps = _json_messages(paths["results_mcap"], "/gait/steps")
    assert {name for _, _, name in steps} == {"gaitcap.GaitStep"}
    by_index = {msg["index"]: (t, msg) for t, msg, _ in steps}
    for step in report.steps:
        t, msg = by_index[step.index]
        assert t == int(view.start_ns + round(step.heel_strike_s * 1e9)) and msg["foot"] == step.foot
        assert msg["step_length_mm"] == pytest.approx(step.step_length_mm)


def test_the_layout_opens_topics_that_exist(processed):
    trial, _, files, paths = processed
    layout = layout_for(trial.rig.names)
    topics = _topics(files.recording) | _topics(paths["results_mcap"])
    referenced = set()
    for panel in layout["configById"].values():
        mode = panel.get("imageMode", {})
        referenced |= {mode.get("imageTopic"), mode.get("calibrationTopic"), *mode.get("annotations", {})}
        referenced |= set(panel.get("topics", {})) | {panel.get("topicToRender")}
        referenced |= {re.match(r"(/[^{.]+)", p["value"]).group(1) for p in panel.get("paths", [])}
    referenced.discard(None)
    assert referenced and referenced <= topics, referenced - topics
    shipped = resources.files("gaitcap.services.processing.viewers") / "foxglove_layout.json"
    assert shipped.read_text() == layout_json(SHIPPED_CAMERAS)


def _rerun(*args) -> str:
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    done = subprocess.run([exe, *args], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_rrd_reads_back_with_reruns_own_reader(processed):
    trial, view, _, paths = processed
    rrd = str(paths["rerun_rrd"])
    _rerun("rrd", "verify", rrd)
    rows: dict[str, int] = {}
    columns: dict[str, str] = {}
    for line in _rerun("rrd", "print", rrd).splitlines():
        m = re.search(r"with (\d+) rows .* - (/\S+) - data columns: \[(.*)\]", line)
        if m:
            rows[m.group(2)] = rows.get(m.group(2), 0) + int(m.group(1))
            columns[m.group(2)] = columns.get(m.group(2), "") + m.group(3)
    frames = len(view.times_s)
    images_per_camera = int(np.ceil(6.0 * 5.0))  # 6 s at 5 images/s
    for cam in trial.rig.names:
        assert "Transform3D:mat3x3" in columns[f"/world/cameras/{cam}"]
        assert "Pinhole:image_from_camera" in columns[f"/world/cameras/{cam}/image"]
        assert "EncodedImage:blob" in columns[f"/world/cameras/{cam}/image"]
        assert abs(rows[f"/world/cameras/{cam}/image"] - 1 - images_per_camera) <= 1  # + the static Pinhole
        assert rows[f"/world/cameras/{cam}/image/keypoints/person_0"] == frames
    assert rows["/world/skeleton/joints"] == frames and rows["/world/skeleton/bones"] == frames
    assert all(rows[f"/confidence/{j}"] == frames for j in view.joint_names)
    assert rows["/gait/events"] == len(gait_logs(view.report))
    assert any(path.startswith("/viewport") for path in rows)  # the blueprint travels with the file


def test_gaitcap_view_lists_the_files_and_says_how_to_open_them(processed, monkeypatch):
    from gaitcap.services.cli import app
    from typer.testing import CliRunner

    trial, _, files, paths = processed
    data_dir = files.root.parent.parent
    runner = CliRunner()
    out = runner.invoke(app, ["view", "t1", "--data-dir", str(data_dir), "--no-open", "--foxglove-layout"])
    assert out.exit_code == 0, out.output
    assert str(paths["rerun_rrd"]) in out.output and str(paths["results_mcap"]) in out.output
    assert json.loads((files.root / "foxglove_layout.json").read_text()) == layout_for(trial.rig.names)
    out = runner.invoke(app, ["view", "t1", "--data-dir", str(data_dir), "--no-open"])
    assert f"layout {files.root / 'foxglove_layout.json'}" in out.output  # the trial's own layout, once written
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    out = runner.invoke(app, ["view", "t1", "--data-dir", str(data_dir)])
    assert out.exit_code == 1 and "No display here" in out.output and "rerun trajectory.rrd" in out.output
    out = runner.invoke(app, ["view", "t1", "--data-dir", str(data_dir), "--stage", "preliminary"])
    assert out.exit_code == 2 and "no Rerun file for stage preliminary" in out.output
    out = runner.invoke(app, ["view", "nope", "--data-dir", str(data_dir)])
    assert out.exit_code == 2 and "trial nope" in out.output


def test_a_viewer_file_that_cannot_be_written_is_logged_and_the_other_written(processed, tmp_path, caplog):
    import dataclasses

    _, view, _, _ = processed
    gone = tmp_path / "gone.mcap"  # the recording was moved away meanwhile
    files = TrialFiles(tmp_path / "t2")
    out = write_viewer_files(files, "refined", dataclasses.replace(view, recording=gone))
    assert set(out) == {"results_mcap"} and out["results_mcap"].is_file()
    assert not files.stage_file("refined", "rerun_rrd").exists()
    assert "trajectory.rrd not written" in caplog.text and "gone.mcap" in caplog.text


def test_the_rrd_is_written_by_a_child_process_so_reruns_memory_never_stays_in_the_worker(processed, tmp_path):
    import pickle

    _, view, _, _ = processed
    (tmp_path / "view.pkl").write_bytes(pickle.dumps(view))
    out = tmp_path / "apart.rrd"
    code = ("import dataclasses, pickle, sys\n"
            "from gaitcap.services.processing.apart import start_apart_server\n"
            "from gaitcap.services.processing.viewers.apart import write_rrd_apart\n"
            "start_apart_server()\n"  # as a worker's warm-up does: the server is up before the first file
            f"view = pickle.loads(open({str(tmp_path / 'view.pkl')!r}, 'rb').read())\n"
            "def fitted():\n"  # a fit's trajectory carries its continuous function, a closure (not picklable)
            "    def sampled(t): return view.trajectory.points_mm[:len(t)]\n"
            "    return dataclasses.replace(view, trajectory=dataclasses.replace(view.trajectory, trajectory=sampled))\n"
            f"write_rrd_apart({str(out)!r}, fitted())\n"
            "print('rerun loaded here:', 'rerun' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "rerun loaded here: False" in r.stdout  # written, yet Rerun never loaded in the calling process
    _rerun("rrd", "verify", str(out))  # and it is a whole Rerun file
