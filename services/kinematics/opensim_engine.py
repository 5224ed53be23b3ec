"""The OpenSim engine: Pose2Sim's full-body model (pelvis, hips, knees, ankles, subtalar, lumbar, shoulders,
elbows) scaled to the patient's segment lengths, then inverse kinematics frame by frame.

Scaling: for every measurement of the layout's scaling setup (e.g. thigh = hip-knee of both sides), the
ratio of the median distance between the two keypoints over the trial's frames (robust to outlier frames,
and valid on walking frames, which averaging marker positions like OpenSim's ScaleTool is not) to the
same distance on the unscaled model; the ratio scales the measurement's bodies on its axes (the pelvis:
its width only, ``model_setup``). The hip and ankle markers sit on the hip and ankle joint centres
(``model_setup``); the heel and toe markers are placed on the calcanei in the shape of the keypoints' feet
(``foot_markers``). Inverse kinematics: OpenSim's InverseKinematicsSolver with the setup's marker
weights (the upper body's scaled by ``UPPER_BODY_WEIGHT``: the pelvis and legs follow their own keypoints)
times the reconstruction's confidence in each marker, and the coordinate priors of ``PRIORS``
(pelvis tilt held near neutral; the lumbar joint free; the toes held at 0 and the subtalar joints near 0);
frames without both hips, knees and ankles are not fitted (NaN). A coordinate that rests on the bound of
its range is named in the fit's warnings (``bounds``).
"""

from __future__ import annotations

import logging
import math
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_path, atomic_write_text
from gaitcap.reconstruction.kinematics.bounds import bound_hits
from gaitcap.reconstruction.kinematics.frames import opensim_to_room, room_to_opensim
from gaitcap.reconstruction.kinematics.geometric import model_zero_offsets
from gaitcap.reconstruction.kinematics.mot import to_mot
from gaitcap.reconstruction.kinematics.outliers import OUTLIER_MM, gross_outliers
from gaitcap.reconstruction.kinematics.walkway import coordinates_in_room, turned_points, walkway_heading_rad
from gaitcap.reconstruction.trc import to_trc
from gaitcap.services.kinematics.base import FitRequest, KinematicsUnavailable, ModelFit
from gaitcap.services.kinematics.files import MODEL_FILE, setup_dir, setup_files
from gaitcap.services.kinematics.foot_markers import place_foot_markers
from gaitcap.services.kinematics.model_setup import model_with_markers, pelvis_width_only

log = logging.getLogger(__name__)
LEG_MARKERS = ("LHip", "RHip", "LKnee", "RKnee", "LAnkle", "RAnkle")
# the subtalar joint held near 0 by a weak prior: with the knee straight in stance, turning the hip and turning
# the subtalar joint both point the foot, and without the prior the fit drifted along that valley to the
# joint's -20 deg bound (real walks, docs/kinematics.md); 0.01 per squared radian: 10 deg cost as much as a
# marker 17 mm off
SUBTALAR_WEIGHT = 0.01
# The pelvis and legs are set by their own keypoints; the upper body's (head, neck, shoulders, arms) only
# pose the trunk, head and arms. At Pose2Sim's weights the shoulders weigh as much as the hips (2), and
# what the rigid trunk and arms cannot follow (a shoulder girdle that moves with the arms, a neck placed from
# the shoulders) moved the pelvis and with it the legs: on a real walk's joint centres (FunctionalWalk)
# the thigh pointed 2-3 deg too far forward and the knee bent 2-4 deg too far at each heel strike, and the
# ankle read 4-6 deg of dorsiflexion too many there (r 0.962 / 0.976 with Plug-in-Gait; 0.978 / 0.991 with
# the legs' keypoints alone). The upper body's weights are scaled by this factor: the lumbar, shoulder and
# neck joints still follow them (nothing else competes for those), the pelvis no longer does.
UPPER_BODY_WEIGHT = 0.1
PELVIS_AND_LEG_MARKERS = frozenset({"Hip", "CHip", *(f"{s}{p}" for s in "LR" for p in
                                              ("Hip", "Knee", "Ankle", "Heel", "BigToe", "SmallToe"))})
# The solver's accuracy: at 1e-3 it stopped before it converged, each frame tracked from the last one, so
# the angles lagged the keypoints (on real walks' joint centres the ankle read 4-6 deg too dorsiflexed at
# heel strike and the knee 2-4 deg too bent: ankle r 0.975 -> 0.984, knee RMSE 1.07 -> 0.63 deg on
# FunctionalWalk's left with 1e-4, docs/kinematics.md); 1e-5 changes nothing further (0.01-0.02 deg)
IK_ACCURACY = 1e-4


def _import_opensim():
    try:
        import opensim
    except ImportError as exc:
        raise KinematicsUnavailable(f"the 'opensim' package is not installed ({exc}); install gaitcap with "
                                    "its 'kinematics' extra") from None
    return opensim


def scale_factors(setup_xml: Path, markers_m: np.ndarray, names: tuple[str, ...],
                  model_markers_m: dict[str, np.ndarray]) -> dict[str, tuple[float, float, float]]:
    """body -> (x, y, z) scale factors from the setup's measurements (see the module docstring)."""
    col = {n: i for i, n in enumerate(names)}
    out: dict[str, tuple[float, float, float]] = {}
    for meas in ET.parse(setup_xml).getroot().iter("Measurement"):
        if (meas.findtext("apply") or "").strip().lower() != "true":
            continue
        ratios = []
        for pair in meas.iter("MarkerPair"):
            a, b = (pair.findtext("markers") or "").split()
            if not all(m in col and m in model_markers_m for m in (a, b)):
                continue
            d = np.linalg.norm(markers_m[:, col[a]] - markers_m[:, col[b]], axis=-1)
            d = d[np.isfinite(d)]
            model_d = float(np.linalg.norm(model_markers_m[a] - model_markers_m[b]))
            if d.size >= 3 and model_d > 1e-6:
                ratios.append(float(np.median(d)) / model_d)
        if not ratios:
            log.info("scaling: no keypoints for measurement %s; its bodies keep the model's size", meas.get("name"))
            continue
        r = float(np.mean(ratios))
        for body in meas.iter("BodyScale"):
            axes = (body.findtext("axes") or "X Y Z").split()
            out[body.get("name")] = tuple(r if ax in axes else 1.0 for ax in "XYZ")
    return out


def _ik_weights(ik_xml: Path) -> dict[str, float]:
    out = {}
    for task in ET.parse(ik_xml).getroot().iter("IKMarkerTask"):
        if (task.findtext("apply") or "true").strip().lower() == "true":
            out[task.get("name")] = float(task.findtext("weight") or 1.0)
    return out


def _initial_pose(model, state, frame_mm: np.ndarray, names: tuple[str, ...]) -> None:
    """Start the solver from the patient's place and heading (pelvis between the hips, facing forward) and
    the model's default joint angles, so that assembly does not fall into a twisted local minimum."""
    cs = model.getCoordinateSet()
    for i in range(cs.getSize()):
        c = cs.get(i)
        c.setValue(state, c.getDefaultValue(), False)
    hips = room_to_opensim(frame_mm[[names.index("LHip"), names.index("RHip")]]) / 1000.0
    right = hips[1] - hips[0]
    forward = np.cross([0.0, 1.0, 0.0], right)
    centre = hips.mean(axis=0)
    for name, value in (("pelvis_rotation", math.atan2(-forward[2], forward[0])), ("pelvis_tx", centre[0]),
                        ("pelvis_tz", centre[2])):
        if cs.contains(name):
            cs.get(name).setValue(state, float(value), False)
    model.assemble(state)


def _coordinate_tasks(ik_xml: Path) -> list[tuple[str, float, str, float]]:
    """(coordinate, weight, value_type, value) of the setup's applied coordinate tasks."""
    out = []
    for task in ET.parse(ik_xml).getroot().iter("IKCoordinateTask"):
        if (task.findtext("apply") or "true").strip().lower() == "true":
            out.append((task.get("name"), float(task.findtext("weight") or 0.0),
                        (task.findtext("value_type") or "default_value").strip(), float(task.findtext("value") or 0.0)))
    return out


@dataclass(frozen=True)
class CoordinatePrior:
    """An IK coordinate task added to the setup's: ``coordinate`` held near ``target_deg`` (degrees) with
    ``weight`` (the setup's weights' scale: marker weights times squared metres, coordinates times squared
    radians); ``held``: why the prior, not the keypoints, sets the coordinate (empty for a weak prior that
    only keeps it from drifting where the keypoints leave it free)."""

    coordinate: str
    weight: float
    target_deg: float
    held: str = "the keypoints do not determine it"


# The keypoints do not determine the pelvis's tilt: its markers (both hip joint centres and their midpoint)
# lie on one line, and rotating the pelvis about it moves no leg marker. Held near the model's neutral
# (0 deg: the anatomical standing posture); the trunk's lean goes to the lumbar joint instead of tilting the
# pelvis (which moved hip flexion by the trunk's lean, 8 deg on the synthetic walker; docs/kinematics.md).
# The toes' joint carries no marker once the foot markers are placed on the calcaneus (``foot_markers``):
# held at 0, the foot one rigid segment as the keypoints see it.
_TOES = "no marker on the toes: the keypoints' foot is one rigid segment"
PRIORS = (CoordinatePrior("pelvis_tilt", 1.0, 0.0), CoordinatePrior("L5_S1_Flex_Ext", 0.0, 0.0),
          CoordinatePrior("mtp_angle_l", 1.0, 0.0, _TOES), CoordinatePrior("mtp_angle_r", 1.0, 0.0, _TOES),
          CoordinatePrior("subtalar_angle_l", SUBTALAR_WEIGHT, 0.0, ""),
          CoordinatePrior("subtalar_angle_r", SUBTALAR_WEIGHT, 0.0, ""))


@dataclass(frozen=True, eq=False)
class IKJob:
    """Inverse kinematics of some frames: the scaled model, the marker
    file, the IK setup (its coordinate tasks), marker -> weight, all times (s), the frames' points (n, M, 3)
    mm and their indices (n,), the marker names (M,)."""

    osim_path: str
    trc_path: str
    ik_setup: str
    weights: dict[str, float]
    times_s: np.ndarray
    points_mm: np.ndarray
    frames: np.ndarray
    marker_names: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class IKResult:
    """coordinates (C,) names; values (n, C) degrees / m; distances_m: marker -> its error per frame (m)."""

    coordinates: tuple[str, ...]
    values: np.ndarray
    distances_m: dict[str, list[float]]


def solve_ik(job: IKJob, on_frame=None) -> IKResult:
    """Track the frames with OpenSim's InverseKinematicsSolver; a new assembly from the patient's pose
    wherever a frame does not follow the previous one. ``on_frame(model, state, k)`` is called after each
    frame's solution."""
    osim = _import_opensim()
    osim.Logger.setLevelString("Error")
    model = osim.Model(job.osim_path)
    state = model.initSystem()
    weights = osim.SetMarkerWeights()
    for name, w in job.weights.items():
        if model.getMarkerSet().contains(name):
            weights.cloneAndAppend(osim.MarkerWeight(name, w))
    mref = osim.MarkersReference(job.trc_path, weights)
    coord_refs = osim.SimTKArrayCoordinateReference()
    cset = model.getCoordinateSet()
    tasks = {name: (weight, cset.get(name).getDefaultValue() if kind == "default_value" else value)
             for name, weight, kind, value in _coordinate_tasks(Path(job.ik_setup)) if cset.contains(name)}
    tasks.update({p.coordinate: (p.weight, math.radians(p.target_deg)) for p in PRIORS if cset.contains(p.coordinate)})
    for name, (weight, target) in tasks.items():
        if weight > 0:
            coord_refs.push_back(osim.CoordinateReference(name, osim.Constant(target)))
            coord_refs.back().setWeight(weight)
    solver = osim.InverseKinematicsSolver(model, mref, coord_refs, math.inf)
    solver.setAccuracy(IK_ACCURACY)
    coords = [cset.get(i) for i in range(cset.getSize())]
    rot = np.array([c.getMotionType() == 1 for c in coords])  # 1 = Rotational
    values = np.full((len(job.frames), len(coords)), np.nan)
    dist_m: dict[str, list[float]] = {}
    errs = osim.SimTKArrayDouble()
    column = {n: i for i, n in enumerate(job.marker_names)}
    previous = -2
    for k, f in enumerate(job.frames):
        state.setTime(float(job.times_s[f]))
        if previous != f - 1:
            _initial_pose(model, state, job.points_mm[k], job.marker_names)
            solver.assemble(state)
        else:
            solver.track(state)
        previous = f
        values[k] = [c.getValue(state) for c in coords]
        if on_frame is not None:
            on_frame(model, state, k)
        solver.computeCurrentMarkerErrors(errs)
        for i in range(errs.size()):
            name = solver.getMarkerNameForIndex(i)
            if name in column and np.isfinite(job.points_mm[k, column[name]]).all():  # not a missing marker's 0
                dist_m.setdefault(name, []).append(errs.getElt(i))
    values[:, rot] = np.degrees(values[:, rot])
    return IKResult(tuple(c.getName() for c in coords), values, dist_m)


class OpenSimEngine:
    name = "opensim"

    def __init__(self) -> None:
        # the model's file first: importing OpenSim costs seconds (10-18 s a process on a loaded machine),
        # wasted where the model is not installed
        if not (setup_dir() / MODEL_FILE).is_file():
            raise KinematicsUnavailable(f"the OpenSim model {setup_dir() / MODEL_FILE} is not installed (run "
                                        "deploy/bootstrap.sh)")
        self.osim = _import_opensim()
        self.osim.Logger.setLevelString("Error")

    def zero_pose_markers_mm(self, setup: str) -> dict[str, np.ndarray]:
        """marker -> (3,) mm in the room frame (z up) of the unscaled model in its zero pose."""
        files = setup_files(setup)
        model = model_with_markers(self.osim, files)
        state = model.initSystem()
        ms = model.getMarkerSet()
        return {ms.get(i).getName(): opensim_to_room(ms.get(i).getLocationInGround(state).to_numpy()) * 1000.0
                for i in range(ms.getSize())}

    def zero_offsets_deg(self, osim_path: Path) -> dict[str, dict[str, float]]:
        """variable -> side -> degrees: the keypoint angles (``geometric``) of a model file's markers with
        every rotational coordinate at 0 (the scaled, placed model of a fit)."""
        model = self.osim.Model(str(osim_path))
        state = model.initSystem()
        cs = model.getCoordinateSet()
        for i in range(cs.getSize()):
            if cs.get(i).getMotionType() == 1:  # rotational
                cs.get(i).setValue(state, 0.0, False)
        model.realizePosition(state)
        ms = model.getMarkerSet()
        markers = {ms.get(i).getName(): opensim_to_room(ms.get(i).getLocationInGround(state).to_numpy()) * 1000.0
                   for i in range(ms.getSize())}
        return model_zero_offsets(markers)

    def fit(self, request: FitRequest) -> ModelFit:
        req = request
        pts = np.asarray(req.points_mm, dtype=np.float64)
        if pts.ndim != 3 or pts.shape[1:] != (len(req.marker_names), 3) or pts.shape[0] != len(req.times_s):
            raise ValueError(f"points_mm: expected ({len(req.times_s)}, {len(req.marker_names)}, 3), got {pts.shape}")
        try:
            files = setup_files(req.setup)
        except FileNotFoundError as exc:
            raise KinematicsUnavailable(str(exc)) from None
        pts = self._without_outliers(pts, req.marker_names)
        out = Path(req.out_dir)
        paths = {k: out / f"{req.stem}.{k}" for k in ("trc", "osim", "mot")}
        times = np.round(np.asarray(req.times_s, dtype=np.float64), 6)
        atomic_write_text(paths["trc"], to_trc(pts, times, req.marker_names, filename=paths["trc"].name, units="m"))
        t0 = time.perf_counter()
        factors, feet = self._scale(files, pts, req, paths["osim"])
        log.info("foot markers placed in the keypoints' foot shape (m, calcaneus): %s", feet)
        zero = self.zero_offsets_deg(paths["osim"])
        log.info("the fitted model's zero pose, measured like the keypoints (deg): %s", zero)
        t1 = time.perf_counter()
        coords, errors = self._ik(files, paths, req, times, pts)
        t2 = time.perf_counter()
        atomic_write_text(paths["mot"], to_mot(times, coords, name=req.stem))
        held = {p.coordinate: f"held near {p.target_deg:g} deg by the fit: {p.held}"
                for p in PRIORS if p.weight > 0 and p.held and p.coordinate in coords}
        hits = tuple(bound_hits(coords, self.coordinate_ranges(paths["osim"])))
        for hit in hits:
            log.warning("kinematics: %s", hit.message())
        return ModelFit(times, coords, errors, paths, {b: f[0] for b, f in factors.items()},
                        {"scale": round(t1 - t0, 3), "ik": round(t2 - t1, 3)}, held, zero, hits)

    def coordinate_ranges(self, osim_path: Path) -> dict[str, tuple[float, float, bool]]:
        """coordinate -> (lower, upper, rotational) of a model file's clamped coordinates (degrees for
        rotations, m for translations)."""
        model = self.osim.Model(str(osim_path))  # kept: the set belongs to it
        cs = model.getCoordinateSet()
        out = {}
        for i in range(cs.getSize()):
            c = cs.get(i)
            if c.get_clamped():
                rot = c.getMotionType() == 1
                lo, hi = (math.degrees(v) if rot else v for v in (c.getRangeMin(), c.getRangeMax()))
                out[c.getName()] = (lo, hi, rot)
        return out

    @staticmethod
    def _without_outliers(pts: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
        """The markers with gross outliers (``gross_outliers`` from the hips' centre) made missing."""
        if not {"LHip", "RHip"} <= set(names):
            return pts
        bad = gross_outliers(pts, names, centre=("LHip", "RHip"))
        for m in np.nonzero(bad.any(axis=0))[0]:
            log.warning("kinematics: %s left out in %d frames, over %.0f mm from where the body puts it",
                        names[m], int(bad[:, m].sum()), OUTLIER_MM)
        return np.where(bad[..., None], np.nan, pts)

    def _scale(self, files, pts: np.ndarray, req: FitRequest, out_path: Path) -> tuple[dict, dict]:
        """Scale the model to the keypoints and place its foot markers in their foot's shape
        (``foot_markers``); write it to ``out_path``. Returns (body -> factors, foot marker -> location)."""
        osim = self.osim
        markers_m = room_to_opensim(pts) / 1000.0
        model = model_with_markers(osim, files)
        state = model.initSystem()
        ms = model.getMarkerSet()
        model_markers = {ms.get(i).getName(): ms.get(i).getLocationInGround(state).to_numpy()
                         for i in range(ms.getSize())}
        factors = pelvis_width_only(scale_factors(files["scaling"], markers_m, req.marker_names, model_markers))
        if not factors:
            raise ValueError("scaling: no segment could be measured (every keypoint pair is missing)")
        scale_set = osim.ScaleSet()
        bodies = model.getBodySet()
        for body, f in factors.items():
            if not bodies.contains(body):
                continue
            s = osim.Scale()
            s.setSegmentName(body)
            s.setScaleFactors(osim.Vec3(*f))
            s.setApply(True)
            scale_set.cloneAndAppend(s)
        model.scale(state, scale_set, True, float(req.mass_kg))
        feet = place_foot_markers(osim, model, pts, req.marker_names)
        model.setName(req.stem)
        out_path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out_path) as tmp:
            model.printToXML(str(tmp))
        return factors, feet

    def _ik_inputs(self, files, req: FitRequest, pts: np.ndarray) -> tuple[dict[str, float], np.ndarray]:
        """(marker -> IK weight, the frames with both hips, knees and ankles)."""
        setup_w = {m: w * (1.0 if m in PELVIS_AND_LEG_MARKERS else UPPER_BODY_WEIGHT)
                   for m, w in _ik_weights(files["ik"]).items()}
        weights = {name: setup_w[name] * float(conf)
                   for name, conf in zip(req.marker_names, np.asarray(req.weights, dtype=float), strict=True)
                   if setup_w.get(name, 0.0) > 0 and conf > 0}
        legs = [req.marker_names.index(m) for m in LEG_MARKERS if m in req.marker_names]
        ok = np.isfinite(pts[:, legs]).all(axis=(1, 2)) if legs else np.zeros(len(pts), bool)
        if not ok.any():
            raise ValueError("inverse kinematics: no frame has both hips, knees and ankles")
        return weights, np.nonzero(ok)[0]

    def _ik(self, files, paths, req: FitRequest, times: np.ndarray, pts: np.ndarray):
        weights, frames = self._ik_inputs(files, req, pts)
        names = req.marker_names
        # fitted with the walkway along the model's x, so that the tilt held is the pelvis's own (``walkway``)
        heading = walkway_heading_rad(pts[:, names.index("LHip")], pts[:, names.index("RHip")])
        turned = turned_points(pts, heading)
        log.info("IK with the walkway along the model's x axis (it runs %.1f deg from the room's x)",
                 math.degrees(heading))
        # (one process: splitting the frames over two processes was slower on the shared 2-core machine and
        # each chunk's fresh assembly moved the knee by up to 2 deg at the seams)
        with tempfile.TemporaryDirectory(dir=paths["trc"].parent) as tmp:
            trc = Path(tmp) / paths["trc"].name
            trc.write_text(to_trc(turned, times, names, filename=trc.name, units="m"))
            part = solve_ik(IKJob(str(paths["osim"]), str(trc), str(files["ik"]), weights, times, turned[frames],
                                  frames, names))
        values = np.full((len(times), len(part.coordinates)), np.nan)
        values[frames] = part.values
        errors = {m: {"rms": round(1000 * float(np.sqrt(np.mean(np.square(e)))), 2),
                      "max": round(1000 * float(np.max(e)), 2)} for m, e in part.distances_m.items() if e}
        log.info("IK: %d of %d frames fitted with %d markers", len(frames), len(times), len(weights))
        return coordinates_in_room({c: values[:, i] for i, c in enumerate(part.coordinates)}, heading), errors
