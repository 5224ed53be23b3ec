"""Gait from a ``gaitcap reconstruct`` result file vs the worker's gait (``gaitcap process``'s gait.json) on one
synthetic recording: with the fit's dense samples in the file (the current format) and without them (older
files: events found on the frames).

    python bench/result_file.py [--json] [--seconds 6 --cameras 4 --seed 3]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_trial_args, emit  # noqa: E402


def _run(args: list[str]) -> str:
    from gaitcap.services.cli import app
    from typer.testing import CliRunner

    res = CliRunner().invoke(app, args)
    if res.exit_code != 0:
        raise RuntimeError(f"gaitcap {args[0]} failed: {res.output[-500:]}")
    return res.stdout


def _gait(npz: Path) -> dict:
    return json.loads(_run(["gait", str(npz), "--json"]).strip().splitlines()[-1])


def _matched_steps(worker: list[dict], other: list[dict], *, within_s: float = 0.3) -> list[tuple[dict, dict]]:
    """Each worker step with the other file's step of the same foot whose heel strike is nearest, if within
    ``within_s`` (pairing by position would compare different steps as soon as one side finds one more)."""
    pairs = []
    for a in worker:
        same = [b for b in other if b["foot"] == a["foot"] and b["heel_strike_s"] is not None]
        if a["heel_strike_s"] is None or not same:
            continue
        b = min(same, key=lambda b: abs(b["heel_strike_s"] - a["heel_strike_s"]))
        if abs(b["heel_strike_s"] - a["heel_strike_s"]) <= within_s:
            pairs.append((a, b))
    return pairs


def _differences(worker: dict, other: dict) -> dict:
    """Largest differences (file minus worker) over matching steps, and of the summary figures."""
    out = {"steps_worker": len(worker["steps"]), "steps_file": len(other["steps"])}
    pairs = _matched_steps(worker["steps"], other["steps"])
    out["steps_matched"] = len(pairs)
    for key, scale, name in (("heel_strike_s", 1000, "heel_strike_ms"), ("toe_off_s", 1000, "toe_off_ms"),
                             ("step_length_mm", 1, "step_length_mm"), ("stance_pct", 1, "stance_pct")):
        d = [scale * (b[key] - a[key]) for a, b in pairs if a[key] is not None and b[key] is not None]
        out[f"max_abs_d_{name}"] = float(np.nanmax(np.abs(d))) if d else float("nan")
    for key in ("cadence_steps_min", "gait_speed_m_s"):
        out[f"d_{key}"] = other["summary"][key] - worker["summary"][key]
    return out


def measure(args) -> dict:
    from gaitcap.acquisition.writers import save_detections_npz, save_rig
    from gaitcap.simulator import make_trial

    trial = make_trial(preset=args.preset, seconds=args.seconds, cameras=args.cameras, seed=args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        save_detections_npz(trial.detections, root / "kp.npz")
        save_rig(trial.rig, root / "calib.json")
        common = ["--calibration", str(root / "calib.json")]
        _run(["process", str(root / "kp.npz"), *common, "--out", str(root / "proc"), "--no-kinematics"])
        _run(["reconstruct", "--keypoints", str(root / "kp.npz"), *common, "--out", str(root / "rec.npz")])
        worker = json.loads((root / "proc" / "refined" / "gait.json").read_text())
        with np.load(root / "rec.npz") as rec:
            np.savez(root / "frames.npz", **{k: rec[k] for k in rec.files if not k.startswith("dense_")})
        return {"trial": {"preset": args.preset, "seconds": args.seconds, "cameras": args.cameras, "seed": args.seed},
                "with_dense_samples": _differences(worker, _gait(root / "rec.npz")),
                "frames_only": _differences(worker, _gait(root / "frames.npz"))}


def table(result: dict) -> str:
    rows = ["steps_worker", "steps_file", "steps_matched", "max_abs_d_heel_strike_ms", "max_abs_d_toe_off_ms",
            "max_abs_d_step_length_mm", "max_abs_d_stance_pct", "d_cadence_steps_min", "d_gait_speed_m_s"]
    lines = [f"reconstruct + gait vs the worker's gait.json ({result['trial']})",
             f"{'':<28}{'dense samples':>15}{'frames only':>15}"]
    for r in rows:
        a, b = result["with_dense_samples"][r], result["frames_only"][r]
        lines.append(f"{r:<28}{a:>15.4g}{b:>15.4g}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_args(ap, seconds=6.0)
    ap.set_defaults(cameras=4, seed=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    emit(measure(args), as_json=args.json, table=table)


if __name__ == "__main__":
    main()
