"""Benchmark: calibrate the live simulated rig the way the clinic page does, and compare with the truth.

Starts the whole stack as real processes (simulated 10-camera rig rendering live, recorder, API; Zenoh
peers on loopback; SQLite), then does what the page's **Calibrate** button does over the same REST
routes: start a board recording (the cameras switch to the board clip: 60 s with the floor board first,
laid down at three more spots, close-ups of every camera, the board carried through the room), wait
while the clip plays (plus a margin for cameras that run late), stop; the calibration job detects the
board in the recorded MCAP and calibrates. The downloaded calibration is compared with the simulated rig
at the recorded image size: camera centres (target 5 mm) and rotations (target 0.2 deg), the rig's own
shape, the world frame's tilt, heading and shift.

    python bench/calibration_live.py                 # table (10 cameras at 960x600, 10 frames/s)
    python bench/calibration_live.py --json          # exactly one JSON object on stdout
    python bench/calibration_live.py --size 1920x1200 --record-s 75
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench._common import jsonable  # noqa: E402

TARGET_CENTRE_MM, TARGET_ROTATION_DEG = 5.0, 0.2
TOKEN = "calibration-live-bench"  # the demo account's password


def _calibrate_over_rest(client, record_s: float, timeout_s: float) -> tuple[str, dict, float]:
    """Start and stop a board recording as the page does; wait for the job. Returns the id, the final
    run and the seconds from Stop to done."""
    cal_id = client.post("/calibrations/record/start").raise_for_status().json()["id"]
    time.sleep(record_s)
    client.post("/calibrations/record/stop").raise_for_status()
    t_stop = time.monotonic()
    while time.monotonic() - t_stop < timeout_s:
        run = client.get(f"/calibrations/{cal_id}").raise_for_status().json()
        if run["state"] in ("done", "failed"):
            return cal_id, run, time.monotonic() - t_stop
        time.sleep(2.0)
    raise TimeoutError(f"calibration {cal_id} not finished {timeout_s:.0f} s after Stop")


def run(cameras: int, size: tuple[int, int], record_s: float, timeout_s: float) -> dict:
    from gaitcap.acquisition.drivers.simulated import SimTrialSpec
    from gaitcap.acquisition.readers import load_rig
    from gaitcap.reconstruction.calibration.compare import compare_rigs
    from gaitcap.reconstruction.camera import Rig
    from gaitcap.services.bus.session import free_loopback_ports
    from gaitcap.services.ops.stack import Stack, StackConfig
    from gaitcap.simulator.board_render import camera_resized

    fps = 10.0
    with tempfile.TemporaryDirectory() as tmp:
        base = free_loopback_ports(16)[0]
        # sim_seconds: the simulated walk must not end during the recording (its camera node restarts)
        cfg = StackConfig(data_dir=Path(tmp), token=TOKEN, port=base, bus_base_port=base + 1, cameras=cameras,
                          size=f"{size[0]}x{size[1]}", fps=fps, sim_seconds=600.0, refine=False, board_clip="full")
        with Stack(cfg) as stack, stack.client(timeout_s=60) as client:
            cal_id, final, job_s = _calibrate_over_rest(client, record_s, timeout_s)
            if final["state"] != "done":
                return {"state": final["state"], "error": final.get("error"), "meets_targets": False}
            toml = client.get(f"/calibrations/{cal_id}/toml").raise_for_status().text
            (Path(tmp) / "got.toml").write_text(toml)
            got = load_rig(Path(tmp) / "got.toml")
    rig = SimTrialSpec(cameras=cameras, fps=fps, seconds=5.0).make().rig
    truth = Rig(tuple(camera_resized(cam, size) for cam in rig))
    cmp = compare_rigs(truth, got)
    report = final["report"]
    return {
        "state": "done", "cameras": cameras, "image_px": list(size), "fps": fps, "record_s": record_s,
        "views": sum(c["n_detections"] for c in report["cameras"]), "stop_to_done_s": job_s,
        "reprojection_rms_px": report["reprojection_rms_px"], "failed_cameras": report["failed_cameras"],
        "centre_err_mm_max": cmp.centre_mm_max, "rotation_err_deg_max": cmp.rotation_deg_max,
        "rig_shape_err_mm_max": cmp.aligned_centre_mm_max, "world_tilt_deg": cmp.world_tilt_deg,
        "world_heading_deg": cmp.world_heading_deg, "world_shift_mm": cmp.world_shift_mm,
        "focal_err_pct_max": max(abs(c.focal_pct) for c in cmp.cameras),
        "meets_targets": bool(cmp.centre_mm_max < TARGET_CENTRE_MM and cmp.rotation_deg_max < TARGET_ROTATION_DEG),
    }


def _table(r: dict) -> str:
    if r["state"] != "done":
        return f"calibration {r['state']}: {r.get('error')}"
    rows = [
        ("cameras, image, frame rate", f"{r['cameras']} at {r['image_px'][0]}x{r['image_px'][1]}, {r['fps']:g} frames/s", ""),
        ("board recorded / views used", f"{r['record_s']:.0f} s / {r['views']}", ""),
        ("Stop -> calibration done", f"{r['stop_to_done_s']:.0f} s", "2 shared cores"),
        ("camera centre error max", f"{r['centre_err_mm_max']:.2f} mm", f"< {TARGET_CENTRE_MM} mm"),
        ("rotation error max", f"{r['rotation_err_deg_max']:.3f} deg", f"< {TARGET_ROTATION_DEG} deg"),
        ("rig shape error max", f"{r['rig_shape_err_mm_max']:.2f} mm", "world change taken out"),
        ("world tilt / heading / shift", f"{r['world_tilt_deg']:.3f} / {r['world_heading_deg']:.3f} deg / "
         f"{r['world_shift_mm']:.2f} mm", "from the floor board"),
        ("focal error max, reprojection RMS", f"{r['focal_err_pct_max']:.3f} %, {r['reprojection_rms_px']:.3f} px", ""),
        ("failed cameras", ", ".join(r["failed_cameras"]) or "none", ""),
        ("meets targets", str(r["meets_targets"]), ""),
    ]
    width = max(len(k) for k, _, _ in rows)
    return "\n".join(f"{k:<{width}}  {v:<34} {t}" for k, v, t in rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--size", default="960x600", help="camera image size WIDTHxHEIGHT px")
    ap.add_argument("--record-s", type=float, default=70.0, help="board recording length, s (the clip: 60 s)")
    ap.add_argument("--timeout-s", type=float, default=1800.0, help="longest wait for the job after Stop, s")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    w, h = (int(v) for v in args.size.lower().split("x"))
    result = run(args.cameras, (w, h), args.record_s, args.timeout_s)
    print(json.dumps(jsonable(result)) if args.json else _table(result))


if __name__ == "__main__":
    main()
