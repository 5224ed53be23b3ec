"""Heel strikes of the event detector on real Plug-in-Gait walks (../shared/data/c3d/) against the laboratory's
force-plate-confirmed Foot Strikes, at 30 fps, per walk (see docs/gait.md, "Heel-first landings")."""

import numpy as np
import pytest
from gaitcap.reconstruction.gait import analyze_gait
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.simulator.mocap import SKELETON, halpe26_points
from gaitcap.simulator.pig_walks import C3D_DIR, load_pig_walk

FPS = 30.0
FRAME_MS = 1000.0 / FPS
MATCH_S = 0.25


def _heel_strike_errors_ms(name: str, config: GaitConfig = GaitConfig(), *, references=None) -> np.ndarray:
    """Detected minus annotated heel strikes (ms) of one C3D walk's keypoints (its markers and joint
    centres) sampled at 30 fps from each of its sampling phases (120 Hz / 4), both feet. ``references``:
    annotated time -> the time to measure against instead (s), only those annotations."""
    walk = load_pig_walk(C3D_DIR / f"{name}.c3d").walk
    step = int(round(walk.rate_hz / FPS))
    points = halpe26_points(walk)
    errors = []
    for phase in range(step):
        report = analyze_gait(points[phase::step], walk.times_s[phase::step], SKELETON.joint_names, config=config)
        for side in ("left", "right"):
            found = np.array([c.heel_strike_s for c in report.contacts if c.foot == side])
            found = found[np.isfinite(found)]
            for t in walk.heel_strike_s[side]:
                if references is not None and (t := references(t)) is None:
                    continue
                if len(found) and np.min(np.abs(found - t)) <= MATCH_S:
                    errors.append(1000.0 * (found[np.argmin(np.abs(found - t))] - t))
    return np.array(errors)


def _plate_onsets_s(name: str) -> np.ndarray:
    """Where each force plate's vertical force first rises 20 N above its unloaded level (s, the file's clock;
    ``bench/gait_real.py``'s ``plate_onsets_s``): the physical instant of contact the annotations stand for."""
    ezc3d = pytest.importorskip("ezc3d")
    c = ezc3d.c3d(str(C3D_DIR / f"{name}.c3d"))
    params = c["parameters"]
    rate = float(np.ravel(params["ANALOG"]["RATE"]["value"])[0])
    analogs = np.asarray(c["data"]["analogs"])[0]
    channels = np.asarray(params["FORCE_PLATFORM"]["CHANNEL"]["value"]).T  # plates x (Fx, Fy, Fz, ...)
    quiet = int(0.05 * rate)
    onsets = []
    for plate in channels:
        fz = analogs[int(plate[2]) - 1]
        loaded = np.abs(fz - np.median(fz)) > 20.0
        rises = np.flatnonzero(loaded[1:] & ~loaded[:-1]) + 1
        onsets += [k / rate for k in rises if k >= quiet and not loaded[k - quiet:k].any()]  # not a bounce
    return np.array(onsets)


@pytest.fixture(scope="module")
def errors_ms():
    return {name: _heel_strike_errors_ms(name) for name in ("FunctionalWalk", "PiG_Motion-FlatFoot-Full",
                                                            "PiG_Motion3_FF")}


@pytest.mark.parametrize("name", ["FunctionalWalk", "PiG_Motion-FlatFoot-Full"])
def test_heel_strikes_meet_the_force_plates_on_each_walk(errors_ms, name):
    """Signed median within 0.3 frame and median |e| at most half a frame at 30 fps (measured, ground-truth
    frames: FunctionalWalk -7 / 7 ms, FlatFoot +4 / 14 ms; before the heel-landing rule -58 / 58 and
    -32 / 37 ms)."""
    e = errors_ms[name]
    assert len(e) >= 20, f"{name}: only {len(e)} annotated heel strikes matched"
    signed, absolute = np.median(e) / FRAME_MS, np.median(np.abs(e)) / FRAME_MS
    assert abs(signed) <= 0.3, f"{name}: signed median {signed:+.2f} frame"
    assert absolute <= 0.5, f"{name}: median |e| {absolute:.2f} frame"


def test_a_heel_that_still_descends_at_the_plates_onset_is_found_within_half_a_frame(errors_ms):
    """PiG_Motion3_FF: its heels still descend at 60-140 mm/s when the plate's force rises and reach their
    lowest point 10-15 ms later, so the heel landing is late by that (measured +12 / 12 ms: the +-0.3 frame
    target on the signed median is missed by 0.07 frame, see docs/gait.md); before the rule -38 / 38 ms."""
    e = errors_ms["PiG_Motion3_FF"]
    assert len(e) >= 20
    assert 0.0 <= np.median(e) / FRAME_MS <= 0.45 and np.median(np.abs(e)) / FRAME_MS <= 0.5


def test_without_the_heel_landing_rule_the_strikes_are_early():
    """The contact-distance rule alone (``heel_landing_window_s=0``) finds FunctionalWalk's strikes 1.75
    frames early: at the plates' onset its heels are only 12-24 mm from their rest points, having dropped
    10-20 mm almost vertically in the last 40 ms."""
    e = _heel_strike_errors_ms("FunctionalWalk", GaitConfig(heel_landing_window_s=0.0))
    assert np.median(e) / FRAME_MS < -1.0


@pytest.mark.parametrize(("name", "signed_frames"), [("FunctionalWalk", (-0.3, 0.3)),
                                                    ("PiG_Motion-FlatFoot-Full", (-0.3, 0.3)),
                                                    ("PiG_Motion3_FF", (0.0, 0.35))])
def test_heel_strikes_at_the_force_plates_onset(name, signed_frames):
    """At the 8 Foot Strikes a force plate confirms (annotated within 15 ms of its 20 N onset; the others are
    the laboratory's own processing), ground-truth frames, 4 sampling phases: every detection within 15 ms of
    the plate's force onset itself (measured -9 to +12 ms). Signed medians FunctionalWalk -0 ms, FlatFoot
    -5 ms, Motion3 +10 ms (+0.31 frame: its heels still sink 7-10 ms after the onset, docs/gait.md)."""
    onsets = _plate_onsets_s(name)

    def onset(t: float) -> float | None:
        k = int(np.argmin(np.abs(onsets - t)))
        return float(onsets[k]) if abs(onsets[k] - t) <= 0.015 else None

    e = _heel_strike_errors_ms(name, references=onset)
    assert len(e) >= 8, f"{name}: only {len(e)} plate-confirmed strikes matched"
    assert np.all(np.abs(e) <= 15.0), f"{name}: {np.round(e)} ms from the plates' onsets"
    lo, hi = signed_frames
    assert lo <= np.median(e) / FRAME_MS <= hi, f"{name}: signed median {np.median(e) / FRAME_MS:+.2f} frame"


def test_a_foot_still_arriving_at_its_run_has_its_crossing_after_it_never_extrapolated():
    """The distance crossing is interpolated between two samples that bracket the level. A foot still
    farther than the level from its rest point at the first at-rest frame (a turn's pivot on the soak's
    walker) once had its crossing extrapolated from two samples above it: heel strikes 4 s before the
    contact and at -174 s, each making a step no walker takes."""
    from gaitcap.reconstruction.gait.events import _first_below

    grid = np.arange(0.0, 1.0005, 0.001)
    dist = 100.0 * (1.0 - grid)  # mm from the rest point, falling to 0 at 1 s
    anchor = 500  # the run's first frame: still 50 mm away, above a level of 20 mm
    assert _first_below(grid, dist, 20.0, anchor) == pytest.approx(0.8, abs=1e-6)
    assert np.isnan(_first_below(grid, np.full_like(grid, 50.0), 20.0, anchor))  # it never arrives
    assert np.isnan(_first_below(grid, np.full_like(grid, 5.0), 20.0, anchor))  # at rest over the window
    arriving = np.where(grid < 0.3, 100.0 - 300.0 * grid, 10.0)  # below from 0.2667 s, before the anchor
    assert _first_below(grid, arriving, 20.0, anchor) == pytest.approx(80.0 / 300.0, abs=1e-6)
    # toe off: the same search on the reversed window (the last time the toe is near its rest point)
    leaving = np.maximum(0.0, 200.0 * (grid - 0.2))  # mm, leaving at 0.2 s: 20 mm at 0.3 s
    back = _first_below(grid[::-1], leaving[::-1], 20.0, len(grid) - 1 - 100)  # anchored at 0.1 s
    assert back == pytest.approx(0.3, abs=1e-6)
    for level in (20.0, 60.0, 99.0):  # every crossing lies inside the window
        assert grid[0] <= _first_below(grid, dist, level, anchor) <= grid[-1]
