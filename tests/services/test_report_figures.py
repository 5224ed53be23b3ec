"""The page's heel-height curve never draws a heel no walking heel can be: the preliminary robust
triangulation's spikes (points below the floor, points that not even two views agree on) are left out and
counted, and they are the frames far from the truth."""

import numpy as np
from gaitcap.services.processing.outputs import write_npz
from gaitcap.services.processing.pipeline import preliminary
from gaitcap.services.reports.figures import heel_traces
from gaitcap.simulator import make_trial


def test_preliminary_heel_spikes_are_left_out_of_the_trace_and_counted(tmp_path):
    trial = make_trial("paper", seconds=10.0, cameras=10, seed=0)
    traj = preliminary(trial.detections, trial.rig)
    names = list(traj.joint_names)
    raw = {side: traj.points_mm[:, names.index(f"{side}_heel"), 2] for side in ("left", "right")}
    assert min(np.nanmin(z) for z in raw.values()) < -150  # the spikes: a heel far below the floor
    write_npz(tmp_path / "trajectory.npz", traj)
    traces = heel_traces(tmp_path / "trajectory.npz", None)
    for side, z in raw.items():
        shown = np.array([np.nan if v is None else v for v in traces[f"{side}_heel_z_mm"]])
        assert shown.shape == z.shape and np.nanmin(shown) >= -50 and np.nanmax(shown) <= 800
        removed = np.isfinite(z) & np.isnan(shown)
        assert traces["implausible"][side] == removed.sum() > 0
        error = np.abs(z - trial.points_mm[:, names.index(f"{side}_heel"), 2])
        kept = np.isfinite(shown)
        # measured (10 cameras, 10 s): the removed frames are off by a median 77-152 mm, the kept ones by 7 mm
        assert np.median(error[removed]) > 5 * np.median(error[kept])
        assert np.all(np.abs(shown[kept] - np.round(z[kept], 1)) < 1e-6)  # the others as they are
