"""Benchmark: the steps check on short recordings with a turn, as the demo makes them, against the truth.

The demo's rig (6 cameras, 15 fps, paper preset) films a long simulated walk; each recording is a window
of it. Each window is fitted with the refined stage's method (the implicit trajectory fit) and analysed;
the table counts, over all windows of each seed, the steps the steps check names (excluded, missed
contacts, dropped steps), the windows with any of them, and the events the truth shows wrong
(``gaitcap.simulator.event_check``).

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


def run(*, seeds: list[int], seconds: float, window_s: float, every_s: float, cameras: int, fps: float,
        preset: str) -> dict:
    from gaitcap.reconstruction.gait import TrajectoryQuality, analyze_gait
    from gaitcap.reconstruction.methods import Implicit, reconstruct
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.event_check import check_events

    rows, t0 = [], time.perf_counter()
    for seed in seeds:
        trial = make_trial(preset, seconds=seconds, cameras=cameras, fps=fps, seed=seed)
        totals = dict.fromkeys(FIELDS, 0) | {"windows": 0, "with_warnings": 0, "no_analysis": 0}
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
        rows.append({"seed": seed, **totals})
    return {"preset": preset, "cameras": cameras, "fps": fps, "seconds": seconds, "window_s": window_s,
            "every_s": every_s, "seeds": rows, "total": {k: sum(r[k] for r in rows) for k in rows[0] if k != "seed"},
            "seconds_total": time.perf_counter() - t0}


def _table(r: dict) -> str:
    cols = ("windows", "with_warnings", *FIELDS)
    head = ("windows", "warned", "steps", "counted", "excluded", "missed", "dropped", "miss/pass", "made up",
            "TO out", "neg")
    lines = [f"steps check on {r['window_s']:.0f} s windows every {r['every_s']:.0f} s of a {r['seconds']:.0f} s walk "
             f"({r['preset']} preset, {r['cameras']} cameras, {r['fps']:.0f} fps, implicit fit)",
             f"{'seed':<7}" + "".join(f"{h:>10}" for h in head)]
    for row in [*r["seeds"], {"seed": "all", **r["total"]}]:
        lines.append(f"{row['seed']!s:<7}" + "".join(f"{row[c]:>10}" for c in cols))
    lines.append("warned: windows whose steps check names something; missed: missed contacts; miss/pass: true "
                 "contacts inside a pass not found; TO out: steps on a toe off outside its stance; neg: steps "
                 "of negative length (kept or dropped)")
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
