"""Data quality of a trial, measured from its recording and its reconstruction, with plain-word warnings.

Measured per camera from the images the recorder wrote (its per-camera summary: which frame ids arrived)
when known, else from the keypoint messages (one per processed frame, with the camera's timestamp): frames
expected over the trial, received, lost, skips (gaps), frame rate (Hz), when a camera stopped or started
late. A recording without the recorder's summary (recovered after a crash) is judged by the images the
file holds (their timestamps from the MCAP index, placed on the keypoints' frame grid by time, as are the
images of a camera whose counter restarted). Recorded frames the detector produced no keypoints for are
counted apart and reported as the detector falling behind, not as the camera stopping; images the recorder
itself dropped (its queue full) are named as the recorder's, not as the camera losing frames. Also: the sync spread (ms) between cameras per frame; the patient's
detection coverage (share of frames seen by >= 2 cameras); after the fit, the reprojection error per
camera (px), flagging a camera far above the others (often a bumped camera). Judged against
:class:`QualityCriteria` (the project's sync criteria: >= 28 fps at 30 fps nominal, 0 skips, spread
<= 30 ms; configurable). ``serious`` warnings make a trial ``done_with_warnings``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints

CONFIDENT = 0.3  # a keypoint above this confidence counts as detected
TAIL_S = 1.0  # the trial's last second is not judged per camera (keypoints still on their way at Stop)
NO_IMAGES_S = 2.5  # Start to Stop longer than the images by more than this: the cameras stopped early
EDGE_S = 0.5  # a camera whose frames end (begin) more than this before the end (after the start) stopped (started late)


@dataclass(frozen=True)
class QualityCriteria:
    """min_fps_fraction: a camera must deliver this share of the nominal rate (28 of 30 Hz); max_skips:
    gaps per camera; max_spread_ms: timestamp spread between cameras of one
    frame; max_lost_fraction: lost frames per camera before it is serious; min_coverage: share of frames
    the patient must be seen by >= 2 cameras; bumped_ratio / bumped_min_px: a camera whose median
    reprojection error is that many times the median of the others and above that many px is flagged;
    min_duration_s: shorter recordings are flagged."""

    min_fps_fraction: float = 28.0 / 30.0
    max_skips: int = 0
    max_spread_ms: float = 30.0
    max_lost_fraction: float = 0.02
    min_coverage: float = 0.6
    bumped_ratio: float = 3.0
    bumped_min_px: float = 4.0
    min_duration_s: float = 4.0

    def min_fps_at(self, nominal_fps: float) -> float:
        """The least frame rate (Hz) accepted from cameras running at ``nominal_fps``."""
        return round(self.min_fps_fraction * nominal_fps, 1)

    def __post_init__(self) -> None:
        for name in ("min_fps_fraction", "max_spread_ms", "bumped_ratio", "bumped_min_px", "min_duration_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: must be > 0, got {getattr(self, name)}")
        if self.min_fps_fraction > 1:
            raise ValueError(f"min_fps_fraction: must be in (0, 1], got {self.min_fps_fraction}")
        if not 0 <= self.max_lost_fraction <= 1 or not 0 <= self.min_coverage <= 1:
            raise ValueError("max_lost_fraction and min_coverage: must be in [0, 1]")


@dataclass(frozen=True)
class CameraQuality:
    """One camera over the trial but its last :data:`TAIL_S`: frames expected / received / lost, skips (gaps), fps (Hz, while it
    delivered: from its first to its last frame), first and last frame times (s from the trial's first frame), reprojection error median (px, None before the
    fit or without detections). ``source``: what the frame counts come from, ``"images"`` (the recorder's
    summary) or ``"keypoints"`` (no summary: a recording cut short, a restarted camera);
    ``without_keypoints``: recorded frames the detector gave no keypoints for (None when images unknown);
    ``recorder_dropped``: images of this camera the recorder dropped (queue full: disk or CPU too slow),
    among ``lost`` when judged by images."""

    name: str
    expected: int
    received: int
    lost: int
    skips: int
    fps: float
    first_s: float | None
    last_s: float | None
    reprojection_px: float | None = None
    source: str = "keypoints"
    without_keypoints: int | None = None
    recorder_dropped: int = 0

    @property
    def camera_lost(self) -> int:
        """Frames the camera itself lost (the lost ones less those the recorder dropped)."""
        return max(0, self.lost - self.recorder_dropped)


@dataclass(frozen=True)
class DataQuality:
    """The trial's measures and warnings (plain words); ``serious``: the results may be less accurate."""

    duration_s: float
    nominal_fps: float
    cameras: tuple[CameraQuality, ...]
    spread_ms_max: float | None
    spread_ms_p95: float | None
    coverage: float | None
    recorded_s: float | None = None  # wall time from Start to Stop (the recorder's), None when unknown
    restarts: dict[str, int] = field(default_factory=dict)  # camera -> frame counter restarts within the trial
    absent: dict[str, int] = field(default_factory=dict)  # expected camera without keypoints -> images recorded
    # camera -> its keypoint messages the reader ignored (stray frame ids, timestamps far off, unreadable)
    ignored_keypoints: dict[str, IgnoredKeypoints] = field(default_factory=dict)
    recovered: bool = False  # the recording was cut by a recorder crash and recovered (no recorder summary)
    # the trial's checks of its results, by name (one person, the rig, completion): each a JSON-ready dict
    # whose "warnings" (plain words) join the trial's and make it serious, and whose "notes" do not
    checks: dict[str, dict] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    serious: bool = False
    criteria: QualityCriteria = field(default_factory=QualityCriteria)

    def to_dict(self) -> dict:
        return {**asdict(self), "ignored_keypoints": {n: i.to_dict() for n, i in self.ignored_keypoints.items()}}

    def _with(self, **changes) -> DataQuality:
        """A copy with ``changes``; the nested records kept as records (``asdict`` makes them dicts)."""
        return DataQuality(**{**asdict(self), "cameras": self.cameras, "criteria": self.criteria,
                              "ignored_keypoints": self.ignored_keypoints, **changes})


def _gaps(present: np.ndarray) -> int:
    """Runs of missing frames between the first and the last received frame."""
    idx = np.flatnonzero(present)
    if idx.size < 2:
        return 0
    return int(np.count_nonzero(np.diff(idx) > 1))


def _camera(name: str, present: np.ndarray, times_s: np.ndarray, nominal_fps: float, **extra) -> CameraQuality:
    """Measures of one camera from which frames of the judged window it delivered and their times (s)."""
    received, expected = int(present.sum()), int(present.size)
    idx = np.flatnonzero(present)
    first = float(times_s[idx[0]]) if idx.size else None
    last = float(times_s[idx[-1]]) if idx.size else None
    active_s = (idx[-1] - idx[0] + 1) / nominal_fps if idx.size else 0.0  # while it delivered
    return CameraQuality(name, expected, received, expected - received, _gaps(present),
                         round(received / active_s, 2) if active_s > 0 else 0.0, first, last, **extra)


def recorded_frame_ids(summary: dict) -> dict[str, np.ndarray]:
    """{camera: sorted frame ids of the images the recorder wrote} from its summary
    (:func:`gaitcap.acquisition.recording.reader.read_summary`): first to last frame id less the gaps; {}
    without a summary (a recording cut short). A camera whose counter restarted is left out: its ids are
    another count (place its images by time, :func:`images_on_grid`)."""
    out = {}
    for cam, tally in (summary.get("cameras") or {}).items():
        if tally.get("restarts"):
            continue
        first, last = tally.get("first_frame_id"), tally.get("last_frame_id")
        if first is None or last is None:
            out[cam] = np.zeros(0, dtype=np.int64)
            continue
        present = np.ones(int(last) - int(first) + 1, dtype=bool)
        for a, b in tally.get("gaps") or ():
            present[max(int(a), first) - first : min(int(b), last) - first + 1] = False
        out[cam] = int(first) + np.flatnonzero(present)
    return out


def images_on_grid(image_times_ns: dict[str, np.ndarray], *, camera_names, timestamps_ns: np.ndarray,
                   frame_ids: np.ndarray) -> dict[str, np.ndarray]:
    """{camera: sorted frame ids of its recorded images} from their camera timestamps (ns), on the keypoints'
    frame grid (``timestamps_ns`` (C, T), -1 where missing, ``frame_ids`` (T,)): frame id = round((t -
    offset) / period), the camera's offset from its own keypoints (the other cameras' median for a camera
    without any), the period from the cameras' frame rate. A restarted camera's images land where the
    reader placed its keypoints; images falling on one frame id count once."""
    stamps = np.asarray(timestamps_ns, dtype=np.int64)
    fids = np.asarray(frame_ids, dtype=np.int64)
    if not (stamps >= 0).any():
        raise ValueError("the recording holds no detections with camera timestamps (no keypoints were recorded), "
                         "so its images cannot be placed on the frame grid")
    period = 1e9 / nominal_fps_of(stamps)
    ref = int(stamps[stamps >= 0].min())
    offsets = {n: float(np.median((row[row >= 0] - ref) - fids[row >= 0] * period))
               for n, row in zip(camera_names, stamps, strict=True) if (row >= 0).any()}
    typical = float(np.median(list(offsets.values())))
    out = {}
    for cam, times in image_times_ns.items():
        rel = np.asarray(times, dtype=np.int64) - ref
        out[cam] = np.unique(np.round((rel - offsets.get(cam, typical)) / period).astype(np.int64))
    return out


def nominal_fps_of(stamps_ns: np.ndarray) -> float:
    """The cameras' frame rate (Hz): per camera, time between its first and last frame over the frame ids
    between them; the median over the cameras (30 Hz when no camera has two frames)."""
    rates = []
    for row in stamps_ns:
        idx = np.flatnonzero(row >= 0)
        if idx.size >= 2 and row[idx[-1]] > row[idx[0]]:
            rates.append(1e9 * (idx[-1] - idx[0]) / (row[idx[-1]] - row[idx[0]]))
    return float(np.median(rates)) if rates else 30.0


def sync_spread_ms(stamps_ns: np.ndarray) -> np.ndarray:
    """Per frame seen by >= 2 cameras: latest minus earliest camera timestamp (ms)."""
    ts = np.where(stamps_ns >= 0, stamps_ns, np.nan).astype(np.float64)
    both = np.isfinite(ts).sum(0) >= 2
    if not both.any():
        return np.zeros(0)
    return (np.nanmax(ts[:, both], 0) - np.nanmin(ts[:, both], 0)) / 1e6


def recording_quality(*, camera_names, timestamps_ns: np.ndarray, patient_confidence: np.ndarray | None,
                      expected_cameras=(), recorded_s: float | None = None, restarts=None, frame_ids=None,
                      recorded_frames: dict[str, np.ndarray] | None = None, recovered: bool = False,
                      recorder_dropped: dict[str, int] | None = None,
                      ignored: dict[str, IgnoredKeypoints] | None = None,
                      criteria: QualityCriteria = QualityCriteria()) -> DataQuality:
    """Measures and warnings from a recording's (C, T) camera timestamps (-1 where missing) and the
    patient's (C, T, J) detection confidences; ``expected_cameras``: the calibration's cameras (one
    missing from the recording entirely is reported); ``recorded_s``: Start to Stop (s) as the recorder
    timed it (images ending long before Stop: every camera stopped); ``restarts``: {camera: times its
    frame counter started again within the trial} (the reader's, a camera or camera node restarted);
    ``recorded_frames``: {camera: frame ids of its recorded images} (:func:`recorded_frame_ids`) with
    ``frame_ids`` (T,) the keypoints' frame ids: cameras are then judged by their images and keypoints
    missing for recorded frames are the detector's; ``recovered``: the recording was recovered after a
    recorder crash; ``recorder_dropped``: {camera: images the recorder dropped, its queue full};
    ``ignored``: {camera: its keypoint messages the reader ignored} (the reader's
    :class:`~gaitcap.reconstruction.ignored_keypoints.IgnoredKeypoints`: frame ids far outside the recording,
    timestamps far from their frame's, messages that could not be read; a camera with only such messages
    is not in ``camera_names`` and is named for that, not as absent)."""
    stamps = np.asarray(timestamps_ns, dtype=np.int64)
    restarts = dict(restarts or {})
    images = {n: np.asarray(ids, dtype=np.int64) for n, ids in (recorded_frames or {}).items()}
    if images and frame_ids is None:
        raise ValueError("recording_quality: recorded_frames needs the keypoints' frame_ids")
    nominal = nominal_fps_of(stamps)
    first_id = int(frame_ids[0]) if frame_ids is not None and len(frame_ids) else 0
    bounds = [(int(f[0]), int(f[-1])) for f in images.values() if f.size]
    # the recording's frames: from the first recorded image (keypoints of frames before Start do not count)
    lo = min(b[0] for b in bounds) if bounds else first_id
    hi = max([first_id + stamps.shape[1] - 1] + [b[1] for b in bounds])
    grid = np.full((stamps.shape[0], max(1, hi - lo + 1)), -1, dtype=np.int64)  # keypoint stamps on the grid
    kept = stamps[:, max(0, lo - first_id) :]
    at = max(0, first_id - lo)
    grid[:, at : at + kept.shape[1]] = kept[:, : grid.shape[1] - at]
    t0 = float(stamps[stamps >= 0].min()) - (first_id - lo) * 1e9 / nominal if (stamps >= 0).any() else 0.0
    # the last TAIL_S are not judged per camera: keypoints of the frames just before Stop may still have
    # been on their way (detector latency differs between cameras)
    window = max(1, grid.shape[1] - int(round(TAIL_S * nominal)))
    dropped = {n: int(k) for n, k in (recorder_dropped or {}).items() if k}
    cams = [_judged_camera(n, grid[c], images.get(n), lo, t0, nominal, window, dropped.get(n, 0))
            for c, n in enumerate(camera_names)]
    spread = sync_spread_ms(stamps)
    coverage = None
    if patient_confidence is not None and patient_confidence.size:
        seen = (np.nan_to_num(patient_confidence) > CONFIDENT).any(-1)  # (C, T)
        coverage = float(np.mean(seen.sum(0) >= 2))
    ignored = {n: i for n, i in (ignored or {}).items() if i.strays or i.unreadable}
    absent = {n: int((recorded_frames or {}).get(n, np.zeros(0)).size) for n in expected_cameras
              if n not in camera_names and n not in ignored}
    quality = DataQuality(duration_s=round(grid.shape[1] / nominal, 3), nominal_fps=round(nominal, 2),
                          cameras=tuple(cams),
                          spread_ms_max=round(float(spread.max()), 2) if spread.size else None,
                          spread_ms_p95=round(float(np.percentile(spread, 95)), 2) if spread.size else None,
                          coverage=None if coverage is None else round(coverage, 3), criteria=criteria,
                          recorded_s=None if recorded_s is None else round(float(recorded_s), 3),
                          restarts=restarts, absent=absent, recovered=recovered, ignored_keypoints=ignored)
    return judged(quality)


def _judged_camera(name: str, stamps: np.ndarray, image_ids: np.ndarray | None, lo: int, t0_ns: float,
                   nominal: float, window: int, recorder_dropped: int) -> CameraQuality:
    """One camera's measures over the judged window of the frame grid (first frame id ``lo``): from its
    recorded images when known (and the recorded frames without keypoints), else from its keypoints."""
    with_keypoints = stamps[:window] >= 0
    if image_ids is None:
        return _camera(name, with_keypoints, (stamps[:window] - t0_ns) / 1e9, nominal,
                       recorder_dropped=recorder_dropped)
    recorded = np.zeros(stamps.size, dtype=bool)
    recorded[image_ids[(image_ids >= lo) & (image_ids < lo + stamps.size)] - lo] = True
    recorded = recorded[:window]
    return _camera(name, recorded, np.arange(window) / nominal, nominal, source="images",
                   without_keypoints=int(np.count_nonzero(recorded & ~with_keypoints)),
                   recorder_dropped=recorder_dropped)


def with_check(quality: DataQuality, name: str, check: dict) -> DataQuality:
    """The quality with the trial's check ``name`` (a JSON-ready dict with ``warnings`` and ``notes`` lists
    of plain words), judged again: its warnings join the trial's."""
    return judged(quality._with(checks={**quality.checks, name: check}, warnings=(), serious=False))


def with_reprojection(quality: DataQuality, errors_px: dict[str, float | None]) -> DataQuality:
    """The quality with each camera's median reprojection error (px) after the fit, judged again."""
    cams = tuple(CameraQuality(**{**asdict(c), "reprojection_px": errors_px.get(c.name)}) for c in quality.cameras)
    return judged(quality._with(cameras=cams, warnings=(), serious=False))


def reprojection_px(points_mm: np.ndarray, keypoints: np.ndarray, rig) -> dict[str, float | None]:
    """Median distance (px) per camera between the reconstruction (T, J, 3) mm projected through the
    rig and the confident detections (C, T, J, 3); None for a camera without any."""
    out: dict[str, float | None] = {}
    finite = np.isfinite(points_mm).all(-1)
    for c, cam in enumerate(rig.cameras):
        ok = finite & (np.nan_to_num(keypoints[c, ..., 2]) > CONFIDENT) & np.isfinite(keypoints[c, ..., :2]).all(-1)
        if not ok.any():
            out[cam.name] = None
            continue
        err = np.linalg.norm(cam.project(points_mm[ok]) - keypoints[c, ..., :2][ok], axis=-1)
        out[cam.name] = round(float(np.median(err)), 2)
    return out


def judged(q: DataQuality) -> DataQuality:
    """``q`` with its warnings (plain words, most important first) and ``serious`` set."""
    cr, warn = q.criteria, []
    late_s = max(EDGE_S, 2.0 / q.nominal_fps)
    judged_s = max((c.expected for c in q.cameras), default=0) / q.nominal_fps  # the window judged per camera
    end = judged_s - 1.0 / q.nominal_fps - late_s
    warn += [f"Camera {n} recorded nothing" if not k else f"The detector produced no keypoints for camera {n} "
             f"(its {k} frames were recorded)" for n, k in sorted(q.absent.items())]
    if q.recovered:
        warn.append("The recording was recovered after the recorder stopped unexpectedly: the cameras are "
                    "judged by the images the file holds, up to the cut")
    warn += [f"Camera {n} restarted during the trial ({k} time{'s' if k > 1 else ''}); its frames after the "
             "restart are placed by their timestamps" for n, k in sorted(q.restarts.items())]
    warn += _strays(q) + _unreadable(q)
    for c in q.cameras:
        if c.received == 0:
            warn.append(f"Camera {c.name} recorded nothing")
        elif c.last_s is not None and c.last_s < end:
            warn.append(f"Camera {c.name} stopped at {c.last_s:.1f} s")
        elif c.first_s is not None and c.first_s > late_s:
            warn.append(f"Camera {c.name} started late, at {c.first_s:.1f} s")
    min_fps = cr.min_fps_at(q.nominal_fps)
    slow = [c for c in q.cameras if c.received and c.fps < min_fps]
    if slow:
        names = ", ".join(f"{c.name} {c.fps:.0f} fps" for c in slow)
        warn.append(f"{len(slow)} of {len(q.cameras)} cameras below {min_fps:.0f} fps ({names})")
    lossy = [c for c in q.cameras if c.received and c.camera_lost / max(c.expected, 1) > cr.max_lost_fraction]
    if lossy:
        warn.append(f"{len(lossy)} of {len(q.cameras)} cameras lost frames ("
                    + ", ".join(f"{c.name} {c.camera_lost} of {c.expected}" for c in lossy) + ")")
    warn += [f"The recorder dropped {c.recorder_dropped} images of camera {c.name} (disk or CPU too slow)"
             for c in q.cameras if c.recorder_dropped]
    skipping = [c for c in q.cameras if c.skips > cr.max_skips and c not in lossy and c.camera_lost]
    if skipping:
        warn.append(f"{len(skipping)} of {len(q.cameras)} cameras skipped frames ("
                    + ", ".join(f"{c.name} {c.skips} gaps" for c in skipping) + ")")
    warn += _detector_behind(q.cameras, cr)
    if q.spread_ms_max is not None and q.spread_ms_max > cr.max_spread_ms:
        warn.append(f"Cameras out of sync: up to {q.spread_ms_max:.0f} ms between cameras "
                    f"(limit {cr.max_spread_ms:.0f} ms)")
    warn += _bumped(q.cameras, cr)
    if q.coverage is not None and q.coverage < cr.min_coverage:
        warn.append(f"The patient was seen by 2 or more cameras in only {100 * q.coverage:.0f} % of the frames")
    if q.recorded_s is not None and q.recorded_s - q.duration_s > NO_IMAGES_S:
        warn.append(f"No camera images for {q.recorded_s - q.duration_s:.1f} s of the {q.recorded_s:.1f} s "
                    "between Start and Stop (the cameras stopped or fell behind)")
    if q.duration_s < cr.min_duration_s:
        warn.append(f"Only {q.duration_s:.1f} s recorded")
    warn += [w for _, check in sorted(q.checks.items()) for w in check.get("warnings", ())]
    return q._with(warnings=tuple(warn), serious=bool(warn))


def _strays(q: DataQuality) -> list[str]:
    """Keypoint messages ignored for a frame id far outside the recording or a timestamp far from that of
    their frame, per camera, with their ids."""
    out, judged_cameras = [], {c.name for c in q.cameras}
    for name, ign in sorted(q.ignored_keypoints.items()):
        count = ign.strays
        if not count or (ign.unreadable and name not in judged_cameras):
            continue  # none, or said with the messages that could not be read (:func:`_unreadable`)
        what, named = _stray_what(count, ign.mistimed), _named(ign)
        if name not in judged_cameras:
            which = f"all its {count} keypoint messages" if count > 1 else "its only keypoint message"
            out.append(f"Camera {name}: {which} had {what}{named} and {'were' if count > 1 else 'was'} "
                       "ignored: the camera has no keypoints")
        else:
            out.append(f"Camera {name}: {count} keypoint message{'s' if count > 1 else ''} with {what}{named} "
                       f"{'were' if count > 1 else 'was'} ignored")
    return out


def _named(ign: IgnoredKeypoints) -> str:
    """" (id, id, ...)" naming the first stray frame ids (", ..." when there were more), or ""."""
    ids = ign.stray_frame_ids
    return f" ({', '.join(map(str, ids))}{', ...' if ign.strays > len(ids) else ''})" if ids else ""


def _stray_what(count: int, mistimed: int) -> str:
    """What was wrong with ``count`` ignored keypoint messages, ``mistimed`` of them for their timestamp."""
    if not mistimed:
        return "frame ids far outside the recording" if count > 1 else "a frame id far outside the recording"
    if mistimed == count:
        return "timestamps far from their frames'" if count > 1 else "a timestamp far from its frame's"
    return (f"frame ids far outside the recording ({count - mistimed}) or timestamps far from their frames' "
            f"({mistimed})")


def _unreadable(q: DataQuality) -> list[str]:
    """Keypoint messages the reader could not read and ignored, per camera, with why; a camera left with
    no keypoints says so (with its stray frame ids, if it had those too)."""
    out, judged_cameras = [], {c.name for c in q.cameras}
    for name, ign in sorted(q.ignored_keypoints.items()):
        whys, count = ign.unreadable, ign.unread
        if not count:
            continue
        why = next(iter(whys)) if len(whys) == 1 else ", ".join(f"{k} {w}" for w, k in sorted(whys.items()))
        if name in judged_cameras:
            out.append(f"Camera {name}: {count} keypoint message{'s' if count > 1 else ''} could not be read and "
                       f"{'were' if count > 1 else 'was'} ignored ({why})")
            continue
        unread, tail = (f"all its {count} keypoint messages" if count > 1 else "its only keypoint message"), ""
        if ign.strays:
            far = ign.strays
            unread = f"{count} keypoint message{'s' if count > 1 else ''}"
            tail = f", and the other {far} had {_stray_what(far, ign.mistimed)}{_named(ign)}"
        out.append(f"Camera {name}: {unread} could not be read ({why}){tail}: the camera has no keypoints")
    return out


def _detector_behind(cameras, cr: QualityCriteria) -> list[str]:
    """Cameras whose recorded frames lack keypoints beyond the lost-frame criterion: the detector's doing."""
    behind = [c for c in cameras if c.without_keypoints and c.without_keypoints / max(c.received, 1) > cr.max_lost_fraction]
    if not behind:
        return []
    return [f"The detector fell behind on {len(behind)} of {len(cameras)} cameras: no keypoints for frames the "
            "cameras delivered and the recording holds (" + ", ".join(
                f"{c.name} {c.without_keypoints} of {c.received} frames" for c in behind) + ")"]


def _bumped(cameras, cr: QualityCriteria) -> list[str]:
    errs = {c.name: c.reprojection_px for c in cameras if c.reprojection_px is not None}
    out = []
    for name, err in errs.items():
        others = [e for n, e in errs.items() if n != name]
        if len(others) < 2:
            continue
        typical = float(np.median(others))
        if err > cr.bumped_min_px and err > cr.bumped_ratio * typical:
            out.append(f"Camera {name}: reprojection error {err:.1f} px, far above the others "
                       f"({typical:.1f} px); it may have been moved, recalibrate")
    return out


def summary_sentence(warnings) -> str:
    """The warnings as one sentence for the page: "...; ...; results may be less accurate"."""
    return "; ".join(warnings) + "; results may be less accurate" if warnings else ""
