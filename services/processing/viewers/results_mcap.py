"""The results MCAP of a processed trial, in Foxglove's own types (opened next to the trial MCAP).

Topics (log time = publish time = camera clock, ns, as the trial MCAP's images):

===========================  ========  ==============================  ==================================
topic                        encoding  schema                          content
===========================  ========  ==============================  ==================================
``/tf``                      protobuf  ``foxglove.FrameTransform``     ``room`` -> each camera, at start
``/rig``                     protobuf  ``foxglove.SceneUpdate``        a frustum and label per camera
``/camera/<cam>/calibration`` protobuf ``foxglove.CameraCalibration``  K, distortion, size, at start
``/skeleton``                protobuf  ``foxglove.SceneUpdate``        joints (spheres) + bones, per frame
``/gait/events``             protobuf  ``foxglove.Log``                heel strikes and toe offs
``/gait/steps``              json      ``gaitcap.GaitStep``            one message per step (plot them)
===========================  ========  ==============================  ==================================

Foxglove works in metres: positions are the trajectory's mm / 1000, in the frame ``room`` (the
calibration's world frame, z up). A camera's frame is its optical frame (x right, y down, z forward),
named like the ``frame_id`` of its images. Joints are coloured by confidence (red 0 .. green 1).
The gait summary is the metadata record ``gait_summary``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from gaitcap.acquisition.fileio import atomic_path
from gaitcap.acquisition.recording.foxglove_messages import (
    camera_calibration,
    confidence_rgba,
    schema_data,
    set_time,
)
from gaitcap.reconstruction.camera import Camera
from gaitcap.reconstruction.jsonable import finite_or_none
from gaitcap.services.processing.viewers.trial_view import TrialView
from mcap.writer import CompressionType, Writer
from scipy.spatial.transform import Rotation

ROOM_FRAME = "room"
M_PER_MM = 1e-3
JOINT_DIAMETER_M = 0.05
BONE_THICKNESS_M = 0.015
FRUSTUM_DEPTH_M = 0.4
TF_TOPIC, RIG_TOPIC, SKELETON_TOPIC = "/tf", "/rig", "/skeleton"
EVENTS_TOPIC, STEPS_TOPIC = "/gait/events", "/gait/steps"
STEP_FIELDS = ("step_length_mm", "stride_length_mm", "step_width_mm", "step_time_s", "stride_time_s",
               "stance_pct", "swing_pct", "double_support_pct", "confidence")
STEP_SCHEMA = {
    "title": "gaitcap.GaitStep", "type": "object",
    "description": "one step, ending at this foot's heel strike; lengths mm, times s, % of the cycle",
    "properties": {"index": {"type": "integer"}, "pass": {"type": "integer"}, "foot": {"type": "string"},
                   "heel_strike_s": {"type": "number"},
                   **{f: {"type": ["number", "null"]} for f in STEP_FIELDS}},
}


JSON_SCHEMAS = {"gaitcap.GaitStep": STEP_SCHEMA}


class _Results:
    """Channels registered on first use; every message's log time = publish time."""

    def __init__(self, mcap: Writer) -> None:
        self.mcap, self.schemas, self.channels = mcap, {}, {}

    def add(self, topic: str, schema: str, data: bytes, time_ns: int) -> None:
        """``schema``: a JSON schema of :data:`JSON_SCHEMAS` or a Foxglove protobuf type."""
        is_json = schema in JSON_SCHEMAS
        if schema not in self.schemas:
            self.schemas[schema] = self.mcap.register_schema(
                schema, "jsonschema" if is_json else "protobuf",
                json.dumps(JSON_SCHEMAS[schema]).encode() if is_json else schema_data(schema))
        if topic not in self.channels:
            self.channels[topic] = self.mcap.register_channel(topic, "json" if is_json else "protobuf",
                                                              self.schemas[schema])
        self.mcap.add_message(self.channels[topic], int(time_ns), data, int(time_ns))


def _color(rgba) -> Color:
    r, g, b, a = (float(v) for v in rgba)
    return Color(r=r, g=g, b=b, a=a)


def camera_transform(camera: Camera, *, time_ns: int) -> bytes:
    """``room`` -> camera optical frame: the camera's centre (m) and its camera-to-room rotation."""
    x, y, z, w = Rotation.from_matrix(camera.rotation.T).as_quat()
    msg = FrameTransform(parent_frame_id=ROOM_FRAME, child_frame_id=camera.name)
    set_time(msg.timestamp, time_ns)
    msg.translation.x, msg.translation.y, msg.translation.z = (camera.center_mm * M_PER_MM).tolist()
    msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w = float(x), float(y), float(z), float(w)
    return msg.SerializeToString()


def frustum_corners_m(camera: Camera, depth_m: float = FRUSTUM_DEPTH_M) -> np.ndarray:
    """(4, 3) image corners unprojected to ``depth_m`` in the camera frame (m), ignoring distortion."""
    w, h = camera.size_px
    pixels = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=np.float64)
    return (np.linalg.solve(camera.matrix_px, pixels.T).T) * depth_m


def rig_update(cameras, *, time_ns: int) -> bytes:
    """One entity per camera in its own frame: a wire frustum and the camera's name."""
    update = SceneUpdate()
    for camera in cameras:
        entity = update.entities.add(frame_id=camera.name, id=f"camera {camera.name}", frame_locked=True)
        set_time(entity.timestamp, time_ns)
        corners = frustum_corners_m(camera)
        segments = [p for c in corners for p in (np.zeros(3), c)]
        segments += [p for i in range(4) for p in (corners[i], corners[(i + 1) % 4])]
        line = entity.lines.add(type=LinePrimitive.LINE_LIST, thickness=2.0, scale_invariant=True,
                                color=_color((0.3, 0.7, 1.0, 1.0)))
        line.pose.orientation.w = 1.0
        for p in segments:
            line.points.add(x=float(p[0]), y=float(p[1]), z=float(p[2]))
        text = entity.texts.add(text=camera.name, font_size=14.0, scale_invariant=True, billboard=True,
                                color=_color((1, 1, 1, 1)))
        text.pose.orientation.w = 1.0
    return update.SerializeToString()


def skeleton_update(points_mm: np.ndarray, confidence: np.ndarray | None, bones: np.ndarray, *,
                    time_ns: int) -> bytes:
    """One frame's skeleton: a sphere per known joint (coloured by confidence) and a line list of bones."""
    update = SceneUpdate()
    entity = update.entities.add(frame_id=ROOM_FRAME, id="skeleton")
    set_time(entity.timestamp, time_ns)
    known = np.isfinite(points_mm).all(axis=1)
    pts = points_mm * M_PER_MM
    conf = np.ones(len(pts)) if confidence is None else confidence
    for p, rgba in zip(pts[known].tolist(), confidence_rgba(conf[known]).tolist(), strict=True):
        sphere = entity.spheres.add(color=_color(rgba))
        sphere.pose.position.x, sphere.pose.position.y, sphere.pose.position.z = p
        sphere.pose.orientation.w = 1.0
        sphere.size.x = sphere.size.y = sphere.size.z = JOINT_DIAMETER_M
    drawn = bones[known[bones].all(axis=1)] if bones.size else bones
    if drawn.size:
        line = entity.lines.add(type=LinePrimitive.LINE_LIST, thickness=BONE_THICKNESS_M,
                                color=_color((0.9, 0.9, 0.9, 1.0)))
        line.pose.orientation.w = 1.0
        for x, y, z in pts[drawn.reshape(-1)].tolist():
            line.points.add(x=x, y=y, z=z)
    return update.SerializeToString()


def gait_logs(report) -> list[tuple[float, str]]:
    """(time s, text) of every heel strike and toe off, in time order."""
    out = []
    for n, c in enumerate(report.contacts):
        note = "" if c.valid else " (not used: uncertain)"
        if math.isfinite(c.heel_strike_s):
            out.append((float(c.heel_strike_s), f"{c.foot} heel strike, contact {n + 1}{note}"))
        if math.isfinite(c.toe_off_s):
            out.append((float(c.toe_off_s), f"{c.foot} toe off, contact {n + 1}{note}"))
    return sorted(out)


def step_message(step) -> dict:
    return {"index": int(step.index), "pass": int(step.pass_index) + 1, "foot": step.foot,
            "heel_strike_s": float(step.heel_strike_s), **{f: finite_or_none(getattr(step, f)) for f in STEP_FIELDS}}


def _write_gait(out: _Results, view: TrialView) -> None:
    for t, text in gait_logs(view.report):
        time_ns = int(view.time_ns(t))
        msg = Log(level=Log.INFO, message=text, name="gait")
        set_time(msg.timestamp, time_ns)
        out.add(EVENTS_TOPIC, "foxglove.Log", msg.SerializeToString(), time_ns)
    for step in sorted(view.report.steps, key=lambda s: s.heel_strike_s):
        out.add(STEPS_TOPIC, "gaitcap.GaitStep", json.dumps(step_message(step)).encode(),
                int(view.time_ns(step.heel_strike_s)))


def write_results_mcap(path: Path, view: TrialView) -> Path:
    """Write the results MCAP of ``view`` to ``path`` (temporary name, then renamed)."""
    with atomic_path(Path(path)) as tmp, open(tmp, "wb") as f:
        mcap = Writer(f, compression=CompressionType.LZ4)
        mcap.start(profile="gaitcap-results", library="gaitcap")
        out = _Results(mcap)
        start = int(view.start_ns)
        for camera in view.rig:
            out.add(TF_TOPIC, "foxglove.FrameTransform", camera_transform(camera, time_ns=start), start)
            out.add(f"/camera/{camera.name}/calibration", "foxglove.CameraCalibration",
                    camera_calibration(camera, time_ns=start), start)
        out.add(RIG_TOPIC, "foxglove.SceneUpdate", rig_update(view.rig, time_ns=start), start)
        for i, time_ns in enumerate(view.time_ns(view.times_s).tolist()):
            conf = None if view.confidence is None else view.confidence[i]
            out.add(SKELETON_TOPIC, "foxglove.SceneUpdate",
                    skeleton_update(view.points_mm[i], conf, view.bones, time_ns=time_ns), time_ns)
        if view.report is not None:
            _write_gait(out, view)
            mcap.add_metadata("gait_summary", {"json": json.dumps(view.report.to_dict()["summary"])})
        mcap.add_metadata("trial", {"trial_id": view.trial_id, "start_ns": str(start)})
        mcap.finish()
    return Path(path)
