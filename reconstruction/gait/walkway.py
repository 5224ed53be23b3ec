"""Comparison with a pressure walkway (GaitRite-like): CSV format, time and space alignment, residuals.

CSV format (UTF-8, comma separated, header row, one row per footfall, extra columns ignored):

    trial,foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm,toe_y_mm

- ``trial`` (optional): name of the trial the footfall belongs to (default "0").
- ``foot``: ``left``/``right`` (``L``/``R`` accepted).
- ``first_contact_s`` / ``last_contact_s``: first and last contact of the footprint, walkway clock (s).
- ``heel_x_mm``, ``heel_y_mm``, ``toe_x_mm``, ``toe_y_mm``: heel and toe centre of the footprint in the
  walkway frame (mm; x along the walkway, y across it).

Alignment (after the paper and its authors' code): the walkway clock is ``t_kinematic = t_walkway +
offset_s``. For each trial, offsets on a 0.05 s grid over +-4 s are scored by the mean foot speed (the
slower of heel and toe) during the walkway's contacts; its local minima are candidates. One scaled rigid
2D transform (scale clipped to 0.9-1.1) maps the kinematic heel and toe points (stationary points over
the shifted contact intervals) onto the walkway's for all trials of a session, the candidate offsets
being chosen jointly; each trial's offset is then refined within +-0.5 s in 0.03 s steps and the
transform refitted. Residuals (kinematic - walkway, in the walkway frame) are reported per parameter
with mean, SD, RMSE and sigma_IQR = 0.7413 IQR. Forward errors are sign-reversed for passes walked in
the descending x direction, so a constant offset between heel keypoint and pressure heel shows as one
bias; lateral errors stay in the walkway's y. Step length, stride length and step width (base of
support) come from the heel points of both systems at the walkway's contacts, with the definitions of
``parameters``, and the walkway pass's direction of progression.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.parameters import progression_direction
from gaitcap.reconstruction.gait.tracks import HEEL, TOE, FootTracks

WALKWAY_COLUMNS = ("trial", "foot", "first_contact_s", "last_contact_s", "heel_x_mm", "heel_y_mm",
                   "toe_x_mm", "toe_y_mm")
RESIDUAL_PARAMETERS = ("heel_forward_mm", "heel_lateral_mm", "toe_forward_mm", "toe_lateral_mm",
                       "step_length_mm", "stride_length_mm", "step_width_mm")
_FEET = {"left": "left", "l": "left", "right": "right", "r": "right"}
_SAMPLES = 15  # samples per contact interval


@dataclass(frozen=True, eq=False)
class WalkwayTrial:
    """Footfalls of one trial on the walkway (N footfalls, walkway frame and clock).

    Attributes:
        name: trial name.
        feet: (N,) "left"/"right".
        first_contact_s, last_contact_s: (N,) contact interval (s, walkway clock).
        heel_xy_mm, toe_xy_mm: (N, 2) footprint heel and toe (mm, walkway frame).
    """

    name: str
    feet: tuple[str, ...]
    first_contact_s: np.ndarray
    last_contact_s: np.ndarray
    heel_xy_mm: np.ndarray
    toe_xy_mm: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.feet)
        for attr, shape in (("first_contact_s", (n,)), ("last_contact_s", (n,)), ("heel_xy_mm", (n, 2)),
                            ("toe_xy_mm", (n, 2))):
            value = np.asarray(getattr(self, attr), dtype=np.float64)
            if value.shape != shape or not np.isfinite(value).all():
                raise ValueError(f"walkway trial {self.name!r}: {attr} must be finite with shape {shape}")
            object.__setattr__(self, attr, value)
        bad = [f for f in self.feet if f not in ("left", "right")]
        if bad:
            raise ValueError(f"walkway trial {self.name!r}: foot must be left/right, got {bad[0]!r}")
        if (self.last_contact_s < self.first_contact_s).any():
            i = int(np.argmax(self.last_contact_s < self.first_contact_s))
            raise ValueError(f"walkway trial {self.name!r}: footfall {i} ends before it starts")
        order = np.argsort(self.first_contact_s, kind="stable")
        if (order != np.arange(n)).any():
            object.__setattr__(self, "feet", tuple(self.feet[i] for i in order))
            for attr in ("first_contact_s", "last_contact_s", "heel_xy_mm", "toe_xy_mm"):
                object.__setattr__(self, attr, getattr(self, attr)[order])


def walkway_from_csv_text(text: str, *, source: str = "<walkway csv>") -> tuple[WalkwayTrial, ...]:
    """Trials of a walkway export's text (format in the module docstring), in order of first appearance;
    errors name ``source`` (the file) and the line. Files are read by
    :func:`gaitcap.acquisition.readers.read_walkway_csv`."""
    rows: dict[str, list[tuple]] = {}
    reader = csv.DictReader(io.StringIO(text, newline=""))
    missing = [c for c in WALKWAY_COLUMNS[1:] if c not in (reader.fieldnames or ())]
    if missing:
        raise ValueError(f"{source}: walkway CSV lacks column(s) {', '.join(missing)}")
    for row in reader:
        foot, values = _footfall(row, where=f"{source}:{reader.line_num}")
        rows.setdefault(str(row.get("trial") or "0"), []).append((foot, *values))
    if not rows:
        raise ValueError(f"{source}: walkway CSV has no footfalls")
    try:
        return tuple(_trial(name, r) for name, r in rows.items())
    except ValueError as exc:  # a footfall ending before it starts
        raise ValueError(f"{source}: {exc}") from None


def _footfall(row: dict[str, str], *, where: str) -> tuple[str, tuple[float, ...]]:
    """Foot and times (s) / positions (mm) of one CSV row; errors name ``where`` (file:line)."""
    foot = _FEET.get(str(row["foot"]).strip().lower())
    if foot is None:
        raise ValueError(f"{where}: foot must be left/right, got {row['foot']!r}")
    try:
        values = tuple(float(row[c]) for c in WALKWAY_COLUMNS[2:])
    except (TypeError, ValueError):
        raise ValueError(f"{where}: a time or position is not a number") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{where}: a time or position is not finite")
    return foot, values


def _trial(name: str, rows: list[tuple]) -> WalkwayTrial:
    a = np.array([r[1:] for r in rows], dtype=np.float64)
    return WalkwayTrial(name, tuple(r[0] for r in rows), a[:, 0], a[:, 1], a[:, 2:4], a[:, 4:6])


def walkway_csv_text(trials: Sequence[WalkwayTrial]) -> str:
    """Trials in the walkway CSV format (written by :func:`gaitcap.acquisition.writers.write_walkway_csv`)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(WALKWAY_COLUMNS)
    for t in trials:
        for i, foot in enumerate(t.feet):
            writer.writerow([t.name, foot, f"{t.first_contact_s[i]:.4f}", f"{t.last_contact_s[i]:.4f}",
                             *(f"{v:.2f}" for v in (*t.heel_xy_mm[i], *t.toe_xy_mm[i]))])
    return buf.getvalue()


@dataclass(frozen=True)
class AlignmentConfig:
    """Search settings of the walkway alignment (s, mm); the forward bias between visual and pressure foot
    points is limited to +-max_bias_mm (else a bias could mimic a whole stride)."""

    coarse_range_s: float = 4.0
    coarse_step_s: float = 0.05
    refine_range_s: float = 0.5
    refine_step_s: float = 0.03
    scale_min: float = 0.9
    scale_max: float = 1.1
    candidates: int = 10
    rounds: int = 3
    outlier_factor: float = 3.0
    min_outlier_mm: float = 30.0
    max_bias_mm: float = 50.0


@dataclass(frozen=True)
class Similarity2D:
    """walkway_xy = scale * R(rotation_rad) @ kinematic_xy + translation_mm (mm)."""

    scale: float
    rotation_rad: float
    translation_mm: tuple[float, float]

    @property
    def matrix(self) -> np.ndarray:
        c, s = math.cos(self.rotation_rad), math.sin(self.rotation_rad)
        return self.scale * np.array([[c, -s], [s, c]])

    def apply(self, xy_mm: np.ndarray) -> np.ndarray:
        return np.asarray(xy_mm) @ self.matrix.T + np.asarray(self.translation_mm)

    def inverse(self, xy_mm: np.ndarray) -> np.ndarray:
        return (np.asarray(xy_mm) - np.asarray(self.translation_mm)) @ np.linalg.inv(self.matrix).T


def fit_similarity(src: np.ndarray, dst: np.ndarray, *, scale_min: float, scale_max: float,
                   weights: np.ndarray | None = None) -> Similarity2D:
    """Weighted Umeyama fit of dst ~ s R src + t for (N, 2) points, scale clipped to [scale_min, scale_max]."""
    w = np.ones(len(src)) if weights is None else np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    mu_s, mu_d = w @ src, w @ dst
    xs, xd = src - mu_s, dst - mu_d
    cov = (xd * w[:, None]).T @ xs
    u, sv, vt = np.linalg.svd(cov)
    flip = np.diag([1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rot = u @ flip @ vt
    var = float(w @ (xs**2).sum(axis=1))
    scale = float(np.clip(np.trace(np.diag(sv) @ flip) / var, scale_min, scale_max)) if var > 0 else 1.0
    t = mu_d - scale * rot @ mu_s
    return Similarity2D(scale, float(math.atan2(rot[1, 0], rot[0, 0])), (float(t[0]), float(t[1])))


class _TrialProbe:
    """Kinematic heel/toe speed and stationary positions at one walkway trial's contacts, per offset."""

    def __init__(self, tracks: FootTracks, walkway: WalkwayTrial, rest_speed_mm_s: float):
        self.tracks, self.walkway, self.v_rest = tracks, walkway, rest_speed_mm_s
        self.heel = np.array([HEEL[f] for f in walkway.feet])
        self.toe = np.array([TOE[f] for f in walkway.feet])
        frac = np.linspace(0.0, 1.0, _SAMPLES)
        self.direction = np.zeros((len(walkway.feet), 2))
        for idx, d in _pass_directions(walkway):
            self.direction[idx] = d
        self.grid = walkway.first_contact_s[:, None] + np.outer(
            walkway.last_contact_s - walkway.first_contact_s, frac)  # (N, S)

    def _sample(self, offsets_s: np.ndarray):
        """inside (O, N, S); heel and toe positions (N, O, S, 3) and speeds (N, O, S) of each contact's foot."""
        times = self.grid[None] + np.asarray(offsets_s)[:, None, None]  # (O, N, S)
        t0, t1 = self.tracks.times_s[0], self.tracks.times_s[-1]
        inside = (times >= t0) & (times <= t1)
        flat = np.clip(times, t0, t1).ravel()
        pos = np.moveaxis(self.tracks.sampler(flat).reshape(*times.shape, -1, 3), 1, 0)
        speed = np.moveaxis(self.tracks.speed_mm_s(flat).reshape(*times.shape, -1), 1, 0)
        n = np.arange(len(self.heel))
        return (inside, pos[n, :, :, self.heel], pos[n, :, :, self.toe],
                speed[n, :, :, self.heel], speed[n, :, :, self.toe])

    def speed_cost(self, offsets_s: np.ndarray) -> np.ndarray:
        """(O,) mean resting-foot speed during the contacts (mm/s); inf with too little overlap."""
        inside, _, _, heel_speed, toe_speed = self._sample(offsets_s)
        foot = np.moveaxis(np.minimum(heel_speed, toe_speed), 0, 1)  # (O, N, S)
        cover = inside.mean(axis=(1, 2))
        cost = np.where(inside, foot, 0.0).sum(axis=(1, 2)) / np.maximum(inside.sum(axis=(1, 2)), 1)
        return np.where(cover >= 0.5, cost, np.inf)

    def points(self, offset_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Kinematic (N, 2) heel and toe xy at the contacts (median over the at-rest samples), and an
        (N,) mask of contacts fully inside the trial."""
        inside, heel, toe, heel_speed, toe_speed = self._sample(np.array([offset_s]))
        out = []
        for p, sp in ((heel[:, 0], heel_speed[:, 0]), (toe[:, 0], toe_speed[:, 0])):  # (N, S, 3), (N, S)
            rest = sp < self.v_rest
            rest[~rest.any(axis=1)] = True
            out.append(np.nanmedian(np.where(rest[..., None], p[..., :2], np.nan), axis=1))
        return out[0], out[1], inside[0].all(axis=1)


def _local_minima(cost: np.ndarray, k: int) -> np.ndarray:
    c = np.r_[np.inf, cost, np.inf]
    idx = np.flatnonzero((c[1:-1] <= c[:-2]) & (c[1:-1] <= c[2:]) & np.isfinite(cost))
    return idx[np.argsort(cost[idx])][:k]


@dataclass(frozen=True)
class ResidualStats:
    """Statistics of one parameter's residuals (mm): count, mean, SD, RMSE, sigma_IQR = 0.7413 IQR."""

    n: int
    mean: float
    sd: float
    rmse: float
    sigma_iqr: float

    @classmethod
    def of(cls, values: Sequence[float]) -> ResidualStats:
        x = np.asarray([v for v in values if np.isfinite(v)], dtype=np.float64)
        if len(x) == 0:
            return cls(0, *([float("nan")] * 4))
        q75, q25 = np.percentile(x, [75, 25])
        sd = float(x.std(ddof=1)) if len(x) > 1 else float("nan")
        return cls(len(x), float(x.mean()), sd, float(np.sqrt(np.mean(x**2))), float(0.7413 * (q75 - q25)))


@dataclass(frozen=True)
class ContactResidual:
    """Kinematic minus walkway errors at one walkway footfall (mm; NaN where not computable), with the
    footfall's heel in the kinematic frame and its first contact on the kinematic clock (for plots)."""

    trial: str
    foot: str
    first_contact_s: float
    kinematic_time_s: float
    walkway_heel_in_kinematic_mm: tuple[float, float]
    descending: bool
    heel_forward_mm: float
    heel_lateral_mm: float
    toe_forward_mm: float
    toe_lateral_mm: float
    step_length_mm: float
    stride_length_mm: float
    step_width_mm: float


@dataclass(frozen=True)
class WalkwayComparison:
    """Result of aligning a session's trials with their walkway exports.

    Attributes:
        transform: kinematic xy (mm) -> walkway xy (mm), shared by the session's trials.
        offsets_s: trial name -> offset (s): t_kinematic = t_walkway + offset.
        residuals: parameter (``RESIDUAL_PARAMETERS``) -> statistics over all footfalls.
        contacts: per-footfall errors.
        fit_median_mm: median heel/toe distance after alignment and bias (mm).
        forward_bias_mm: fitted offset of the kinematic foot points ahead of the walkway's along the
            direction of progression (mm; the paper saw about 13 mm). Fitted with the transform so that it
            does not distort it; it is not removed from the residuals.
    """

    transform: Similarity2D
    offsets_s: dict[str, float]
    residuals: dict[str, ResidualStats]
    contacts: tuple[ContactResidual, ...]
    fit_median_mm: float
    forward_bias_mm: float


def _stack(probes, offsets, points_cache):
    """Kinematic (M, 2) heel and toe points, walkway points and walkway directions of progression."""
    src, dst, dirs = [], [], []
    for probe, off in zip(probes, offsets, strict=True):
        heel, toe, inside = points_cache(probe, off)
        ok = inside & np.isfinite(heel).all(axis=1) & np.isfinite(toe).all(axis=1)
        src += [heel[ok], toe[ok]]
        dst += [probe.walkway.heel_xy_mm[ok], probe.walkway.toe_xy_mm[ok]]
        dirs += [probe.direction[ok]] * 2
    return np.concatenate(src), np.concatenate(dst), np.concatenate(dirs)


def _robust_fit(src, dst, dirs, config: AlignmentConfig) -> tuple[Similarity2D, float, float]:
    """Fit walkway ~ T(kinematic) - bias * direction: a similarity T and a forward bias (mm) between the
    visual and the pressure foot points, with outlier rejection. Returns T, bias, median residual."""
    if len(src) < 3:
        return Similarity2D(1.0, 0.0, (0.0, 0.0)), 0.0, np.inf
    kw = dict(scale_min=config.scale_min, scale_max=config.scale_max)
    keep, bias = np.ones(len(src), bool), 0.0
    for _ in range(8):
        tf = fit_similarity(src[keep], dst[keep] + bias * dirs[keep], **kw)
        err = tf.apply(src) - dst
        bias = float(np.clip(np.median(np.sum(err * dirs, axis=1)[keep]), -config.max_bias_mm, config.max_bias_mm))
        r = np.linalg.norm(err - bias * dirs, axis=1)
        new_keep = r <= max(config.outlier_factor * np.median(r), config.min_outlier_mm)
        keep = new_keep if new_keep.sum() >= 3 else keep
    r = np.linalg.norm(tf.apply(src) - dst - bias * dirs, axis=1)
    return tf, bias, float(np.median(r))


def align_walkway(
    tracks: Sequence[FootTracks],
    walkway: Sequence[WalkwayTrial],
    rest_speed_mm_s: Sequence[float],
    config: AlignmentConfig = AlignmentConfig(),
) -> WalkwayComparison:
    """Align one session's trials (``tracks[i]`` with ``walkway[i]``) and compute the residuals."""
    if not (len(tracks) == len(walkway) == len(rest_speed_mm_s)) or not tracks:
        raise ValueError("align_walkway: need as many walkway trials as kinematic trials (at least one)")
    # The search runs on splines through the frames (cheap even when a trial's sampler is a neural
    # network); the final footfall positions come from each trial's own sampler.
    probes = [_TrialProbe(t.frame_spline(), w, v) for t, w, v in zip(tracks, walkway, rest_speed_mm_s, strict=True)]
    finals = [_TrialProbe(t, w, v) for t, w, v in zip(tracks, walkway, rest_speed_mm_s, strict=True)]
    cache: dict[tuple[int, float], tuple] = {}

    def points(probe, off):
        key = (id(probe), round(float(off), 6))
        if key not in cache:
            cache[key] = probe.points(float(off))
        return cache[key]

    grid = np.arange(-config.coarse_range_s, config.coarse_range_s + 1e-9, config.coarse_step_s)
    candidates = []
    for probe in probes:
        found = grid[_local_minima(probe.speed_cost(grid), config.candidates)]
        if len(found) == 0:
            raise ValueError(f"walkway trial {probe.walkway.name!r}: no time offset within "
                             f"+-{config.coarse_range_s} s puts its footfalls inside the trajectory")
        candidates.append(list(found))
    offsets = [c[0] for c in candidates]
    for _ in range(config.rounds):  # choose the candidate offsets jointly (coordinate descent)
        for i, cands in enumerate(candidates):
            scores = [_robust_fit(*_stack(probes, offsets[:i] + [c] + offsets[i + 1:], points), config)[2]
                      for c in cands]
            offsets[i] = cands[int(np.argmin(scores))]
    tf, bias, _ = _robust_fit(*_stack(probes, offsets, points), config)
    fine = np.arange(-config.refine_range_s, config.refine_range_s + 1e-9, config.refine_step_s)
    for _ in range(config.rounds):  # per-trial refinement, then refit the shared transform
        for i, probe in enumerate(probes):
            trial_offsets = offsets[i] + fine
            speed = probe.speed_cost(trial_offsets)
            scores = [_spatial_cost(tf, bias, probe, points(probe, o)) + 0.01 * s
                      for o, s in zip(trial_offsets, speed, strict=True)]
            offsets[i] = float(trial_offsets[int(np.argmin(scores))])
        tf, bias, fit_median = _robust_fit(*_stack(probes, offsets, points), config)
    if any(t.continuous for t in tracks):
        tf, bias, fit_median = _robust_fit(*_stack(finals, offsets, points), config)
    rows = [r for p, o in zip(finals, offsets, strict=True) for r in _residuals(tf, p, points(p, o), o)]
    residuals = {name: ResidualStats.of([getattr(r, name) for r in rows]) for name in RESIDUAL_PARAMETERS}
    return WalkwayComparison(tf, {p.walkway.name: float(o) for p, o in zip(probes, offsets, strict=True)},
                             residuals, tuple(rows), fit_median, bias)


def _spatial_cost(tf: Similarity2D, bias: float, probe: _TrialProbe, pts) -> float:
    heel, toe, inside = pts
    if inside.sum() == 0:
        return np.inf
    shift = bias * probe.direction[inside]
    r = np.r_[np.linalg.norm(tf.apply(heel[inside]) - probe.walkway.heel_xy_mm[inside] - shift, axis=1),
              np.linalg.norm(tf.apply(toe[inside]) - probe.walkway.toe_xy_mm[inside] - shift, axis=1)]
    r = r[np.isfinite(r)]
    return float(np.mean(np.minimum(r, 100.0))) if len(r) else np.inf


def walkway_passes(trial: WalkwayTrial, max_gap_s: float = 2.0) -> list[np.ndarray]:
    """Index arrays of the footfalls of each pass: split at pauses longer than ``max_gap_s`` and where the
    heel's x progression reverses."""
    n = len(trial.feet)
    groups, current = [], [0] if n else []
    for i in range(1, n):
        gap = trial.first_contact_s[i] - trial.first_contact_s[i - 1] > max_gap_s
        dx = trial.heel_xy_mm[i, 0] - trial.heel_xy_mm[i - 1, 0]
        prev_dx = (trial.heel_xy_mm[current[-1], 0] - trial.heel_xy_mm[current[-2], 0]
                   if len(current) >= 2 else dx)
        if gap or dx * prev_dx < 0:
            groups.append(np.array(current))
            current = []
        current.append(i)
    if current:
        groups.append(np.array(current))
    return groups


def _pass_directions(trial: WalkwayTrial) -> list[tuple[np.ndarray, np.ndarray]]:
    """(footfall indices, (2,) unit direction of progression) of each walkway pass."""
    out = []
    for idx in walkway_passes(trial):
        sign = 1.0 if len(idx) < 2 or trial.heel_xy_mm[idx[-1], 0] >= trial.heel_xy_mm[idx[0], 0] else -1.0
        feet = [trial.feet[i] for i in idx]
        out.append((idx, progression_direction(feet, trial.heel_xy_mm[idx], np.array([sign, 0.0]))))
    return out


def _step_geometry(feet, heels, direction):
    """(N,) step length, stride length, step width (mm) for one pass's heel points (N, 2)."""
    n = len(feet)
    out = np.full((3, n), np.nan)
    for i in range(1, n):
        if feet[i - 1] == feet[i]:
            continue
        out[0, i] = (heels[i] - heels[i - 1]) @ direction
        if i >= 2 and feet[i - 2] == feet[i]:
            out[1, i] = (heels[i] - heels[i - 2]) @ direction
        if i + 1 < n and feet[i + 1] == feet[i - 1]:
            ab, ap = heels[i + 1] - heels[i - 1], heels[i] - heels[i - 1]
            out[2, i] = abs(ab[0] * ap[1] - ab[1] * ap[0]) / max(np.linalg.norm(ab), 1e-9)
    return out


def _residuals(tf: Similarity2D, probe: _TrialProbe, pts, offset_s: float) -> list[ContactResidual]:
    heel_k, toe_k, inside = pts
    heel_back = tf.inverse(probe.walkway.heel_xy_mm)
    w = probe.walkway
    heel_k = np.where(inside[:, None], tf.apply(heel_k), np.nan)
    toe_k = np.where(inside[:, None], tf.apply(toe_k), np.nan)
    rows = []
    for idx, direction in _pass_directions(w):
        feet = [w.feet[i] for i in idx]
        sign = 1.0 if direction[0] >= 0 else -1.0
        geo_w = _step_geometry(feet, w.heel_xy_mm[idx], direction)
        geo_k = _step_geometry(feet, heel_k[idx], direction)
        for j, i in enumerate(idx):
            dh, dt = heel_k[i] - w.heel_xy_mm[i], toe_k[i] - w.toe_xy_mm[i]
            rows.append(ContactResidual(
                w.name, w.feet[i], float(w.first_contact_s[i]), float(w.first_contact_s[i] + offset_s),
                (float(heel_back[i, 0]), float(heel_back[i, 1])), sign < 0, float(sign * dh[0]), float(dh[1]),
                float(sign * dt[0]), float(dt[1]), *(float(geo_k[m, j] - geo_w[m, j]) for m in range(3))))
    return rows
