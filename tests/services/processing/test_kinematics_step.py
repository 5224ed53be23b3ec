"""The worker's kinematics step: the model is fitted in a child process, so OpenSim's memory never stays in the
worker (it keeps about 1.5 kB per frame fitted: docs/benchmarks.md), and the files and warnings are the same."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def test_the_angles_are_fitted_in_a_child_and_opensim_never_loads_in_the_worker(tmp_path):
    code = (
        "import sys\n"
        "from pathlib import Path\n"
        "from gaitcap.reconstruction.result import Reconstruction\n"
        "from gaitcap.services.processing.artifacts import TrialFiles\n"
        "from gaitcap.services.processing.kinematics_step import kinematics_step\n"
        "from gaitcap.simulator import make_trial\n"
        "walk = make_trial('paper', seconds=4.0, cameras=2, people=1, seed=0, fps=30.0)\n"
        "traj = Reconstruction('truth', walk.points_mm, walk.times_s, tuple(walk.skeleton.joint_names))\n"
        f"files = TrialFiles(Path({str(tmp_path)!r}) / 't1')\n"
        "print('computed:', kinematics_step(files, 'refined', traj))\n"
        "print('opensim loaded here:', 'opensim' in sys.modules)\n"
        "print('file:', files.stage_file('refined', 'kinematics_json'))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr[-3000:]
    assert "computed: True" in r.stdout and "opensim loaded here: False" in r.stdout, r.stdout[-2000:]
    path = Path(r.stdout.split("file: ", 1)[1].split()[0])
    report = json.loads(path.read_text())
    assert report["model"]["engine"] == "opensim" and report["model"]["frames_fitted"] == 120
