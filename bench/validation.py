"""Benchmark: ``gaitcap validate-study`` on the real Plug-in-Gait walks and on the simulator.

Each real walk of the shared data (``../shared/data/c3d/``: FunctionalWalk, PiG_Motion3_FF,
PiG_Motion-FlatFoot-Full) is filmed by the simulated 10-camera rig at 30 fps (keypoints at Plug-in-Gait's
joint centres, heel and toe markers, the ``paper`` detector noise; from 0.25 s into the recording, placed on
the room's diagonal turned by 10 degrees), run through ``gaitcap process`` (joint kinematics on; the implicit
refinement with ``--refine``) and validated against its own C3D: the lag and rigid transform found, heel
strikes and toe offs against the force-plate-confirmed events, step parameters, and the joint angles
against the walk's Plug-in-Gait angles. The simulator's walker (8 s, seed 3) is validated against a C3D of
its ground truth (joints and true events; no model angles). The study table pools every pair.

    python bench/validation.py            # a table
    python bench/validation.py --json     # one JSON object
    python bench/validation.py --refine   # also the implicit fit (slower)
    python bench/validation.py --refine --foot-hz 15   # its feet (with the knees) on a 15 Hz knot grid (process_input in-process)
"""

from __future__ import annotations

import argparse
import logging
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from _common import add_foot_arg, emit  # noqa: E402
from gait_real import PLATE_MATCH_S, plate_onsets_s  # noqa: E402

C3D_DIR = ROOT.parent / "shared" / "data" / "c3d"
WALKS = ("FunctionalWalk", "PiG_Motion3_FF", "PiG_Motion-FlatFoot-Full")
START_S = 0.25
GAITCAP = str(Path(sys.executable).parent / "gaitcap")


def _process(folder: Path, refine: bool, foot_hz: float | None = None) -> float:
    t0 = time.perf_counter()
    if foot_hz is not None:
        _process_feet(folder, foot_hz)
        return time.perf_counter() - t0
    cmd = [GAITCAP, "process", str(folder / "kp.npz"), "--calibration", str(folder / "calib.json"), "--out",
           str(folder / "proc"), "--refine" if refine else "--no-refine", "--json"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"gaitcap process {folder.name}: {run.stderr[-2000:]}")
    return time.perf_counter() - t0


def _process_feet(folder: Path, foot_hz: float) -> None:
    """What ``gaitcap process --refine`` does (``process_input``, in this process), with the refined stage's
    feet on a knot grid of their own at ``foot_hz`` (``BSplineBasis.fast_max_freq_hz``)."""
    from dataclasses import dataclass, replace

    from _common import implicit_method
    from gaitcap.services.processing.offline import OfflineOptions, load_input, process_input

    @dataclass(frozen=True)
    class FeetOptions(OfflineOptions):
        def trial_options(self):
            options = super().trial_options()
            return replace(options, stages=tuple(replace(s, method=implicit_method(foot_hz)) if s.name == "refined"
                                                 else s for s in options.stages))

    options = FeetOptions(refine=True)
    data = load_input(folder / "kp.npz", calibration=folder / "calib.json", options=options)
    process_input(data, folder / "proc", options=options)


def _real_pair(name: str, work: Path) -> tuple[str, str, str]:
    from gaitcap.acquisition.references import read_reference
    from gaitcap.acquisition.writers import save_detections_npz, save_rig
    from gaitcap.simulator.reference_film import film_reference

    ref_path = C3D_DIR / f"{name}.c3d"
    ref = read_reference(ref_path)
    film = film_reference(ref, start_s=START_S, duration_s=ref.times_s[-1] - START_S - 0.1, yaw_deg=10.0, seed=1)
    folder = work / name
    folder.mkdir()
    save_detections_npz(film.detections, folder / "kp.npz")
    save_rig(film.rig, folder / "calib.json")
    return name, str(folder), str(ref_path)


def _simulator_pair(work: Path) -> tuple[str, str, str]:
    """The simulated walker and a C3D of its ground truth (joints, true events), starting 0.3 s later."""
    from gaitcap.acquisition.writers import save_detections_npz, save_rig
    from gaitcap.reconstruction.kinematics.c3d import C3DContent
    from gaitcap.services.kinematics.c3d_file import write_c3d
    from gaitcap.simulator import make_trial

    trial = make_trial(preset="paper", seconds=8.0, seed=3)
    folder = work / "simulator"
    folder.mkdir()
    save_detections_npz(trial.detections, folder / "kp.npz")
    save_rig(trial.rig, folder / "calib.json")
    k0 = 9
    events = sorted([(side.capitalize(), label, float(t)) for side in ("left", "right")
                     for label, times in (("Foot Strike", trial.truth.heel_strike_s[side]),
                                          ("Foot Off", trial.truth.toe_off_s[side]))
                     for t in times if np.isfinite(t) and t >= trial.times_s[k0]], key=lambda e: e[2])
    content = C3DContent(tuple(trial.skeleton.joint_names), trial.points_mm[k0:], trial.fps, float(trial.times_s[k0]),
                         tuple(events))
    write_c3d(folder / "truth.c3d", content)
    return "simulator", str(folder), str(folder / "truth.c3d")


def _pooled(result: dict, kind: str, onsets_s: np.ndarray | None = None, *, vs_onset: bool = False) -> dict:
    """Both sides' matched errors of one event kind (frames at the trial's rate): n, signed and |e| median.
    ``onsets_s``: only the events whose reference lies within ``PLATE_MATCH_S`` of one of these force-plate
    onsets (s, on the trial's clock as the events' reference times are), measured against that onset when
    ``vs_onset``."""
    pairs = [(t, r) for x in result["events"] if x["kind"] == kind
             for t, r in zip(x["trial_s"], x["reference_s"], strict=True)]
    if onsets_s is not None:
        near = [(t, r, float(onsets_s[np.argmin(np.abs(onsets_s - r))])) for t, r in pairs if len(onsets_s)]
        pairs = [(t, on if vs_onset else r) for t, r, on in near if abs(on - r) <= PLATE_MATCH_S]
    e = np.array([(t - r) * result["fps"] for t, r in pairs])
    return {"n": len(e), "signed_median_frames": float(np.median(e)) if len(e) else None,
            "abs_median_frames": float(np.median(np.abs(e))) if len(e) else None,
            "errors_frames": [round(float(x), 2) for x in e]}


def run(refine: bool, foot_hz: float | None = None) -> dict:
    from gaitcap.services.validation.study import Pair, run_study

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        pairs = [_real_pair(n, work) for n in WALKS if (C3D_DIR / f"{n}.c3d").is_file()] + [_simulator_pair(work)]
        seconds = {name: _process(Path(folder), refine, foot_hz) for name, folder, _ in pairs}
        items = [Pair(name, str(Path(folder) / "proc"), ref) for name, folder, ref in pairs]
        study = run_study(items, work / "study", executor="inline")
        import json

        per_pair = {p.name: json.loads((work / "study" / p.name / "validation.json").read_text())
                    for p in items if (work / "study" / p.name / "validation.json").is_file()}
    pairs_out = {}
    for name, r in per_pair.items():
        # the plates' onsets on the trial's clock, as the events' reference times are (reference - lag)
        onsets = plate_onsets_s(C3D_DIR / f"{name}.c3d") - r["alignment"]["lag_s"] if name != "simulator" else None
        a = r["alignment"]
        pairs_out[name] = {"lag_s": a["lag_s"], "true_lag_s": START_S if name != "simulator" else -0.3,
                           "residual_mm": a["residual_mm"], "rotation_deg": a["rotation_deg"],
                           "events": [{k: e[k] for k in ("side", "kind", "n", "signed_median_frames",
                                                         "abs_median_frames", "missed", "extra")} for e in r["events"]],
                           "angles": [{k: x[k] for k in ("variable", "side", "n", "rmse_deg", "offset_deg",
                                                         "rmse_after_offset_deg", "r", "trial_min_deg",
                                                         "reference_min_deg", "trial_max_deg", "reference_max_deg")}
                                      for x in r["angles"]],
                           "not_compared": r["not_compared"], "process_s": seconds[name],
                           "heel_strike": _pooled(r, "heel_strike"), "toe_off": _pooled(r, "toe_off")}
        if onsets is not None:
            pairs_out[name]["heel_strike_plates"] = _pooled(r, "heel_strike", onsets)
            pairs_out[name]["heel_strike_vs_onset"] = _pooled(r, "heel_strike", onsets, vs_onset=True)
    return {"refine": refine, "foot_hz": foot_hz, "start_s": START_S, "fps": 30.0, "study": study, "pairs": pairs_out}


def _f(x, spec=".2f") -> str:
    return "-" if x is None else format(x, spec)


def _table(r: dict) -> str:
    s = r["study"]
    lines = [f"validate-study: {s['pairs_ok']} pairs ({', '.join(r['pairs'])}), gaitcap process "
             f"{'with' if r['refine'] else 'without'} the implicit refinement"
             + (f" (its feet at {r['foot_hz']:g} Hz)" if r.get("foot_hz") else "") + f"; {s['icc_form']}",
             f"{'parameter':<20}{'n':>4}{'pairs':>6}{'bias':>9}{'LoA low':>9}{'LoA high':>9}{'ICC':>6}{'MAE':>8}  dominant"]
    for row in s["table"]:
        lines.append(f"{row['parameter']:<20}{row['n']:>4}{row['pairs']:>6}{_f(row['bias']):>9}{_f(row['loa_low']):>9}"
                     f"{_f(row['loa_high']):>9}{_f(row['icc']):>6}{_f(row['mae']):>8}  {' '.join(row['dominant_pairs'])}")
    for f in s["failed"]:
        lines.append(f"not compared: {f['name']}: {f['error']}")
    lines.append("events per pair and side, trial - reference (frames at 30 fps): n, signed median, |e| median, "
                 "missed, extra")
    for name, p in r["pairs"].items():
        lines.append(f"  {name}: lag {p['lag_s']:+.3f} s (given {p['true_lag_s']:+.3f}), rotation "
                     f"{p['rotation_deg']:.1f} deg, residual {p['residual_mm']:.1f} mm, process {p['process_s']:.0f} s")
        for e in p["events"]:
            lines.append(f"    {e['side']:<6}{e['kind']:<12}{e['n']:>3}{_f(e['signed_median_frames']):>7}"
                         f"{_f(e['abs_median_frames']):>6}{e['missed']:>3}{e['extra']:>3}")
    lines.append("per walk, both sides (frames at 30 fps): n, signed median, |e| median (target +-0.3 / 0.5 for "
                 "heel strikes), each error; heel_strike_plates: the strikes whose Foot Strike lies within "
                 f"{1000 * PLATE_MATCH_S:.0f} ms of a force plate's onset, vs that Foot Strike; heel_strike_vs_onset: "
                 "the same strikes vs the plate's onset")
    for name, p in r["pairs"].items():
        for kind in ("heel_strike", "toe_off", "heel_strike_plates", "heel_strike_vs_onset"):
            if kind not in p:
                continue
            e = p[kind]
            lines.append(f"  {name:<26}{kind:<21}{e['n']:>3}{_f(e['signed_median_frames']):>7}"
                         f"{_f(e['abs_median_frames']):>6}   " + " ".join(f"{x:+.2f}" for x in e["errors_frames"]))
    lines.append("joint angles vs Plug-in-Gait (deg): RMSE, offset (gaitcap - PiG), RMSE after offset, r, "
                 "min gaitcap / min PiG (ankle: peak plantarflexion)")
    for name, p in r["pairs"].items():
        for x in p["angles"]:
            lines.append(f"  {name:<26}{x['side']:<6}{x['variable']:<19}{_f(x['rmse_deg'], '.1f'):>6}"
                         f"{_f(x['offset_deg'], '+.1f'):>7}{_f(x['rmse_after_offset_deg'], '.1f'):>6}"
                         f"{_f(x['r'], '.3f'):>7}{_f(x['trial_min_deg'], '.1f'):>8} / {_f(x['reference_min_deg'], '.1f')}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", action="store_true", help="also run the implicit fit (slower)")
    add_foot_arg(ap)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.foot_hz is not None and not args.refine:
        ap.error("--foot-hz: the feet's knot grid is the implicit refinement's; give --refine too")
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    emit(run(args.refine, args.foot_hz), as_json=args.json, table=_table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
