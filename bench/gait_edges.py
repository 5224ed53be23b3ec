"""Benchmark: the steps check on short recordings with a turn, as the demo makes them, against the truth.

The demo's rig (6 cameras, 15 fps, paper preset) films a long simulated walk; each recording is a window
of it. Each window is fitted with the refined stage's method (the implicit trajectory fit) and analysed;
the table counts, over all windows of each seed, the steps the steps check names (excluded, missed
contacts, dropped steps), the windows with any of them, and the events the truth shows wrong
(``gaitcap.simulator.event_check``). It also sets the exclusions beside the truth: the excluded steps none
of whose values lies off the truth (every time within :data:`NEAR` s, every length within :data:`NEAR` mm:
nothing wrong to exclude), and the counted steps some value of which lies :data:`FAR` off it (a wrong value
in the summary). The simulated walk's steps are all alike, so every difference between steps is measurement.

    python bench/gait_edges.py                          # seeds 0-3, 12 s windows every 6 s of a 60 s walk
    python bench/gait_edges.py --seeds 0,1 --json       # one JSON object on stdout
"""

from __future__ import annotations

import argparse
import logging
import sys
import time

import numpy as np
from _common import emit

FIELDS = ("steps", "counted", "excluded", "missed_contacts", "dropped_steps", "missed_in_pass", "made_up",
          "toe_off_outside_stance", "negative_steps")
#: Within this of the truth (s for times, mm for lengths) a value is right; this far off it, wrong.
NEAR = {"s": 0.05, "mm": 20.0}
FAR = {"s": 0.10, "mm": 40.0}
TIMES = ("step_time_s", "stride_time_s", "stance_time_s", "swing_time_s")
LENGTHS = ("step_length_mm", "stride_length_mm", "step_width_mm")


def versus_truth(report, truth) -> dict[str, int]:
    """``excluded_near``: excluded steps whose every value is within :data:`NEAR` of the truth (an edge
    step's own events are judged too); ``counted_far``: steady steps counted in the summary with a value
    :data:`FAR` or more off it."""
    from gaitcap.reconstruction.gait.parameters import cycle_timing

    out = {"excluded_near": 0, "counted_far": 0}
    table = truth.steps
    for s in report.steps:
        if not (s.excluded or s.steady):
            continue  # an edge step: not in the summary, not judged
        errors = {"s": [], "mm": []}
        timing = cycle_timing(s.foot, s.heel_strike_s, truth.heel_strike_s, truth.toe_off_s, match_s=0.25) or {}
        errors["s"] = [abs(getattr(s, n) - timing[n]) for n in TIMES if n in timing]
        mine = np.flatnonzero(table.foot == s.foot)
        k = mine[np.argmin(np.abs(table.heel_strike_s[mine] - s.heel_strike_s))] if len(mine) else None
        if k is not None and abs(table.heel_strike_s[k] - s.heel_strike_s) <= 0.25:
            errors["mm"] = [abs(getattr(s, n) - getattr(table, n)[k]) for n in LENGTHS]
        errors = {u: [e for e in v if np.isfinite(e)] for u, v in errors.items()}
        if s.excluded:
            out["excluded_near"] += any(errors.values()) and all(e < NEAR[u] for u, v in errors.items() for e in v)
        else:
            out["counted_far"] += any(e >= FAR[u] for u, v in errors.items() for e in v)
    return out


def run(*, seeds: list[int], seconds: float, window_s: float, every_s: float, cameras: int, fps: float,
        preset: str) -> dict:
    from gaitcap.reconstruction.gait import TrajectoryQuality, analyze_gait
    from gaitcap.reconstruction.methods import Implicit, reconstruct
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.event_check import check_events

    rows, t0 = [], time.perf_counter()
    for seed in seeds:
        trial = make_trial(preset, seconds=seconds, cameras=cameras, fps=fps, seed=seed)
        totals = dict.fromkeys(FIELDS, 0) | {"windows": 0, "with_warnings": 0, "no_analysis": 0,
                                             "excluded_near": 0, "counted_far": 0}
        for start in np.arange(0.0, seconds - window_s + 1e-9, every_s):
            a = int(round(start * fps))
            rec = reconstruct(trial.detections.frames(slice(a, a + int(round(window_s * fps)))), trial.rig,
                              method=Implicit())
            quality = TrajectoryQuality(rec.quality, np.full(rec.quality.shape, np.nan))
            totals["windows"] += 1
            try:
                report = analyze_gait(rec.points_mm, rec.times_s, list(rec.joint_names), sample=rec.trajectory,
                                      quality=quality)
            except ValueError:
                totals["no_analysis"] += 1
                continue
            check = check_events(report, trial.truth)
            for name in FIELDS:
                totals[name] += getattr(check, name)
            totals["with_warnings"] += check.steps_check_items > 0
            for name, n in versus_truth(report, trial.truth).items():
                totals[name] += n
        rows.append({"seed": seed, **totals})
    return {"preset": preset, "cameras": cameras, "fps": fps, "seconds": seconds, "window_s": window_s,
            "every_s": every_s, "seeds": rows, "total": {k: sum(r[k] for r in rows) for k in rows[0] if k != "seed"},
            "seconds_total": time.perf_counter() - t0}


def _table(r: dict) -> str:
    cols = ("windows", "with_warnings", *FIELDS, "excluded_near", "counted_far")
    head = ("windows", "warned", "steps", "counted", "excluded", "missed", "dropped", "miss/pass", "made up",
            "TO out", "neg", "excl ok", "count off")
    lines = [f"steps check on {r['window_s']:.0f} s windows every {r['every_s']:.0f} s of a {r['seconds']:.0f} s walk "
             f"({r['preset']} preset, {r['cameras']} cameras, {r['fps']:.0f} fps, implicit fit)",
             f"{'seed':<7}" + "".join(f"{h:>10}" for h in head)]
    for row in [*r["seeds"], {"seed": "all", **r["total"]}]:
        lines.append(f"{row['seed']!s:<7}" + "".join(f"{row[c]:>10}" for c in cols))
    lines.append("warned: windows whose steps check names something; missed: missed contacts; miss/pass: true "
                 "contacts inside a pass not found; TO out: steps on a toe off outside its stance; neg: steps "
                 "of negative length (kept or dropped); excl ok: excluded steps every value of which is within "
                 f"{NEAR['s'] * 1000:.0f} ms / {NEAR['mm']:.0f} mm of the truth; count off: counted steps with a "
                 f"value {FAR['s'] * 1000:.0f} ms / {FAR['mm']:.0f} mm or more off it")
    lines.append(f"time {r['seconds_total']:.0f} s")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2,3")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--window", type=float, default=12.0)
    ap.add_argument("--every", type=float, default=6.0)
    ap.add_argument("--cameras", type=int, default=6)
    ap.add_argument("--fps", type=float, default=15.0)
    ap.add_argument("--preset", default="paper", choices=["clean", "paper", "hard"])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    result = run(seeds=[int(s) for s in args.seeds.split(",")], seconds=args.seconds, window_s=args.window,
                 every_s=args.every, cameras=args.cameras, fps=args.fps, preset=args.preset)
    emit(result, as_json=args.json, table=_table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
