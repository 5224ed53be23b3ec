"""The Foxglove layout that opens a trial MCAP and its results MCAP together: a grid of the cameras'
images with their keypoint overlays, the 3D panel (skeleton, rig, camera frustums), step parameter
plots and the gait event log.

``foxglove_layout.json`` beside this module is the layout for the ten cameras ``cam01`` .. ``cam10``
(shipped with the package; :func:`shipped_layout_path`); :func:`layout_for` makes one for any camera
names (``gaitcap view TRIAL --foxglove-layout`` writes the trial's own). Import it in Foxglove with
Layouts -> Import from file.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from gaitcap.services.processing.viewers.results_mcap import (
    EVENTS_TOPIC,
    RIG_TOPIC,
    ROOM_FRAME,
    SKELETON_TOPIC,
    STEPS_TOPIC,
)

SHIPPED_CAMERAS = tuple(f"cam{i:02d}" for i in range(1, 11))
STEP_PLOT_FIELDS = ("step_length_mm", "step_width_mm")


def shipped_layout_path() -> Path:
    return Path(__file__).with_name("foxglove_layout.json")


def _image_panel(camera: str) -> dict[str, Any]:
    return {"imageMode": {"imageTopic": f"/camera/{camera}/image",
                          "calibrationTopic": f"/camera/{camera}/calibration",
                          "annotations": {f"/camera/{camera}/annotations": {"visible": True}}}}


def _scene_panel(cameras: list[str]) -> dict[str, Any]:
    topics = {t: {"visible": True} for t in (SKELETON_TOPIC, RIG_TOPIC)}
    topics.update({f"/camera/{c}/calibration": {"visible": True} for c in cameras})
    return {"followTf": ROOM_FRAME, "topics": topics, "layers": {
        "grid": {"layerId": "foxglove.Grid", "frameId": ROOM_FRAME, "size": 10, "divisions": 10, "visible": True}}}


def _plot_panel() -> dict[str, Any]:
    paths = [{"value": f'{STEPS_TOPIC}{{foot=="{foot}"}}.{field}', "enabled": True,
              "timestampMethod": "receiveTime", "label": f"{foot} {field}"}
             for field in STEP_PLOT_FIELDS for foot in ("left", "right")]
    return {"paths": paths, "showLegend": True, "legendDisplay": "floating", "isSynced": True,
            "xAxisVal": "timestamp"}


def _tree(ids: list[str], direction: str = "row") -> Any:
    """A balanced mosaic of panels, alternating row and column splits."""
    if len(ids) == 1:
        return ids[0]
    half = (len(ids) + 1) // 2
    other = "column" if direction == "row" else "row"
    return {"direction": direction, "first": _tree(ids[:half], other), "second": _tree(ids[half:], other),
            "splitPercentage": 100.0 * half / len(ids)}


def layout_for(cameras: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """A Foxglove layout (dict, JSON-ready) for these camera names."""
    cameras = list(cameras)
    if not cameras:
        raise ValueError("cameras: a layout needs at least one camera name")
    images = {f"Image!{c}": _image_panel(c) for c in cameras}
    config = {**images, "3D!scene": _scene_panel(cameras), "Plot!steps": _plot_panel(),
              "RosOut!gait": {"topicToRender": EVENTS_TOPIC, "searchTerms": [], "minLogLevel": 1}}
    right = {"direction": "column", "first": "3D!scene",
             "second": {"direction": "column", "first": "Plot!steps", "second": "RosOut!gait",
                        "splitPercentage": 60.0}, "splitPercentage": 55.0}
    return {"configById": config, "globalVariables": {}, "userNodes": {}, "linkedGlobalVariables": [],
            "playbackConfig": {"speed": 1.0},
            "layout": {"direction": "row", "first": _tree(list(images)), "second": right,
                       "splitPercentage": 60.0}}


def layout_json(cameras: list[str] | tuple[str, ...]) -> str:
    return json.dumps(layout_for(cameras), indent=2) + "\n"
