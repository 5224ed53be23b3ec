"""One Rerun recording (.rrd) per processed trial: the rig, images, 2D keypoints, 3D skeleton, per-joint
confidence and gait events on one timeline, with a blueprint that lays them out.

Entities (3D in mm, ``world`` z up; timeline ``time`` = s since the trial's first frame set):

- ``world/cameras/<cam>``: Transform3D (camera -> world); ``world/cameras/<cam>/image``: Pinhole
  (K, size px, x right y down z forward), the recorded JPEG frames (``EncodedImage``) at
  ``RerunSettings.image_rate_hz``, and ``.../keypoints/person_<p>``: everyone's 2D keypoints (Points2D
  with keypoint ids, so the skeleton's annotation context draws the bones).
- ``world/skeleton/joints`` (Points3D, coloured by confidence) and ``world/skeleton/bones`` (LineStrips3D).
- ``confidence/<joint>``: per-joint confidence 0..1 (Scalars).
- ``gait/events``: heel strikes and toe offs (TextLog); ``gait/steps/<param>/<foot>``: step parameters
  (Scalars at each heel strike).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_path
from gaitcap.services.processing.viewers.results_mcap import gait_logs
from gaitcap.services.processing.viewers.trial_view import TrialView

log = logging.getLogger(__name__)

STEP_PLOTS = ("step_length_mm", "step_width_mm", "step_time_s")
JOINT_RADIUS_MM = 20.0
KEYPOINT_RADIUS_PX = 3.0


@dataclass(frozen=True)
class RerunSettings:
    """image_rate_hz: recorded frames per second and camera copied into the .rrd (0: no images);
    image_plane_mm: distance at which the viewer draws each camera's image plane, mm."""

    image_rate_hz: float = 5.0
    image_plane_mm: float = 400.0

    def __post_init__(self) -> None:
        if not self.image_rate_hz >= 0:
            raise ValueError(f"image_rate_hz: must be >= 0, got {self.image_rate_hz}")
        if not self.image_plane_mm > 0:
            raise ValueError(f"image_plane_mm: must be > 0, got {self.image_plane_mm}")


def _rgba_u8(confidence: np.ndarray) -> np.ndarray:
    from gaitcap.acquisition.recording.foxglove_messages import confidence_rgba

    return np.round(confidence_rgba(confidence) * 255).astype(np.uint8)


def image_entity(camera: str) -> str:
    return f"world/cameras/{camera}/image"


def blueprint(cameras: list[str]):
    """3D view, confidence and gait plots, event log beside a grid of the cameras' images."""
    import rerun.blueprint as rrb

    images = rrb.Grid(*[rrb.Spatial2DView(origin=image_entity(c), name=c) for c in cameras], name="cameras")
    side = rrb.Vertical(
        rrb.Spatial3DView(origin="world", name="3D"),
        rrb.TimeSeriesView(origin="confidence", name="joint confidence"),
        rrb.TimeSeriesView(origin="gait/steps", name="steps"),
        rrb.TextLogView(origin="gait/events", name="gait events"),
        row_shares=[3, 1, 1, 1],
    )
    return rrb.Blueprint(rrb.Horizontal(side, images, column_shares=[2, 3]), collapse_panels=True)


def _log_rig(rec, view: TrialView, settings: RerunSettings) -> None:
    import rerun as rr

    for cam in view.rig:
        rec.log(f"world/cameras/{cam.name}", rr.Transform3D(translation=cam.center_mm, mat3x3=cam.rotation.T),
                static=True)
        rec.log(image_entity(cam.name), rr.Pinhole(image_from_camera=cam.matrix_px, resolution=cam.size_px,
                                                   camera_xyz=rr.ViewCoordinates.RDF,
                                                   image_plane_distance=settings.image_plane_mm), static=True)


def _log_images(rec, view: TrialView, rate_hz: float) -> int:
    """The recorded JPEGs, at most ``rate_hz`` per camera; returns how many were copied."""
    import rerun as rr
    from gaitcap.acquisition.encoding import parse_image_message
    from gaitcap.acquisition.recording import layout
    from gaitcap.acquisition.recording.reader import iter_messages

    period_ns, last, count = int(1e9 / rate_hz), {}, 0
    known = set(view.rig.names)
    for topic, message in iter_messages(view.recording, layout.is_image_topic):
        camera = layout.camera_of_topic(topic)  # log time = camera timestamp: skip before parsing
        if camera not in known or message.log_time - last.get(camera, -period_ns) < period_ns:
            continue
        last[camera] = message.log_time
        frame = parse_image_message(message.data)
        rec.set_time("time", duration=(frame.timestamp_ns - view.start_ns) / 1e9)
        rec.log(image_entity(camera), rr.EncodedImage(contents=frame.jpeg, media_type="image/jpeg"))
        count += 1
    return count


def _log_keypoints_2d(rec, view: TrialView) -> None:
    import rerun as rr

    kp = view.keypoints
    index = [rr.TimeColumn("time", duration=np.asarray(kp.times_s, dtype=np.float64))]
    for c, camera in enumerate(kp.camera_names):
        for p in range(kp.shape[2]):
            person = kp.keypoints[c, :, p]  # (T, J, 3)
            shown = np.isfinite(person).all(axis=2) & (person[..., 2] > 0)
            if not shown.any():
                continue
            ids = np.broadcast_to(np.arange(person.shape[1]), shown.shape)[shown]
            columns = rr.Points2D.columns(
                positions=person[shown][:, :2].astype(np.float32), keypoint_ids=ids,
                class_ids=np.zeros(ids.size, dtype=np.uint16), colors=_rgba_u8(person[shown][:, 2]),
                radii=np.full(ids.size, -KEYPOINT_RADIUS_PX, dtype=np.float32),  # negative: screen px
            ).partition(shown.sum(axis=1))
            rec.send_columns(f"{image_entity(camera)}/keypoints/person_{p}", indexes=index, columns=columns)


def _log_skeleton(rec, view: TrialView) -> None:
    import rerun as rr

    t, j, _ = view.points_mm.shape
    index = [rr.TimeColumn("time", duration=view.times_s)]
    pts = np.nan_to_num(view.points_mm.astype(np.float32))
    conf = np.ones((t, j)) if view.confidence is None else view.confidence
    conf = np.where(np.isfinite(view.points_mm).all(axis=2), conf, 0.0)
    rec.send_columns("world/skeleton/joints", indexes=index, columns=rr.Points3D.columns(
        positions=pts.reshape(-1, 3), colors=_rgba_u8(conf.reshape(-1)),
        radii=np.full(t * j, JOINT_RADIUS_MM, dtype=np.float32)).partition([j] * t))
    if view.bones.size:
        strips = pts[:, view.bones].reshape(-1, 2, 3)
        rec.send_columns("world/skeleton/bones", indexes=index, columns=rr.LineStrips3D.columns(
            strips=strips).partition([len(view.bones)] * t))
    for k, name in enumerate(view.joint_names):
        rec.send_columns(f"confidence/{name}", indexes=index, columns=rr.Scalars.columns(scalars=conf[:, k]))


def _log_gait(rec, view: TrialView) -> None:
    import rerun as rr

    for t, text in gait_logs(view.report):
        rec.set_time("time", duration=t)
        rec.log("gait/events", rr.TextLog(text, level="INFO"))
    for foot in ("left", "right"):
        steps = [s for s in view.report.steps if s.foot == foot]
        if not steps:
            continue
        index = [rr.TimeColumn("time", duration=np.array([s.heel_strike_s for s in steps]))]
        for param in STEP_PLOTS:
            values = np.array([getattr(s, param) for s in steps], dtype=np.float64)
            rec.send_columns(f"gait/steps/{param}/{foot}", indexes=index, columns=rr.Scalars.columns(scalars=values))


def write_trial_rrd(path: Path, view: TrialView, settings: RerunSettings = RerunSettings()) -> Path:
    """Write the trial's .rrd (no viewer, no network) to ``path`` (temporary name, then renamed)."""
    import rerun as rr

    cameras = list(view.rig.names)
    with atomic_path(Path(path)) as tmp:
        rec = rr.RecordingStream("gaitcap", recording_id=view.trial_id)
        rec.save(str(tmp), default_blueprint=blueprint(cameras))
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        keypoints = [rr.AnnotationInfo(id=k, label=n) for k, n in enumerate(view.joint_names)]
        rec.log("world", rr.AnnotationContext([rr.ClassDescription(
            info=rr.AnnotationInfo(id=0, label="skeleton"), keypoint_annotations=keypoints,
            keypoint_connections=[tuple(b) for b in view.bones.tolist()])]), static=True)
        _log_rig(rec, view, settings)
        if view.recording is not None and settings.image_rate_hz > 0:
            log.debug("trial %s: %d images in the .rrd", view.trial_id,
                      _log_images(rec, view, settings.image_rate_hz))
        if view.keypoints is not None:
            _log_keypoints_2d(rec, view)
        _log_skeleton(rec, view)
        if view.report is not None:
            _log_gait(rec, view)
        rec.flush()
        rec.disconnect()
    return Path(path)
