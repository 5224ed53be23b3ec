"""Makes ``data/catalog_v4.sql``: a catalog written by the previous release (schema version 4), as that
release's own code wrote it. Run from the checkout (it needs the git history):

    python tests/services/catalog/make_catalog_v4.py

It takes ``services/catalog/`` and ``services/research/store.py`` as they were at ``RELEASE`` (the commit
before schema 5, when schema 4 was current) and ``reconstruction/jsonable.py`` out of git into a temporary
package, runs them in a separate Python that sees only that package and the venv's libraries, records a
clinic's worth of rows with that code (a patient with details, a calibration with a version, trials done,
done with warnings, failed and still recording, their stage results with steps, summaries, quality and
files, jobs, research rows, audit rows), and dumps the database as SQL text. The test loads the SQL into
a file and opens it with this gaitcap (tests/services/catalog/test_upgrade_v4.py).
"""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

RELEASE = "b949fb4^"  # schema 4: b949fb4 made schema 5
HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
OUT = HERE / "data" / "catalog_v4.sql"
DATA_DIR = "/srv/gaitcap-v4"  # where the old clinic kept its files (paths stored in the catalog)

WRITE = r'''
import sys
sys.path[:0] = [sys.argv[1], sys.argv[3]]
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_versions as versions, patients
from gaitcap.services.catalog.models import SCHEMA_VERSION
from gaitcap.services.research import store
assert SCHEMA_VERSION == 4, SCHEMA_VERSION
db = cat.open_catalog(sys.argv[2])
data = "''' + DATA_DIR + r'''"
old = cat.add_calibration(db, toml="[cam_01]\nname = 'cam_01'\n", source="uploaded by anna")
new = versions.add_version(db, toml="[cam_01]\nname = 'cam_01'\n# refined\n", replaces_id=old, made_by="refine-rig",
                           trials=[], comparison={"cam_01": {"centre_mm": 3.0, "rotation_deg": 0.4, "focal_pct": 0.1}})
patients.ensure_patient(db, "P0042")
patients.update_patient(db, "P0042", sex="female", birth_year=1961)
ids = []
for k, final in enumerate(["done", "done_with_warnings", "failed", "recording"]):
    t = cat.start_trial(db, subject_id="P0042", session="visit1", calibration_id=old,
                        recording_path_for=lambda tid: f"{data}/trials/{tid}/recording.mcap")
    ids.append(t.id)
    cat.audit(db, actor="anna", action="start", trial_id=t.id, detail="subject P0042")
    if final == "recording":
        continue
    cat.set_quality(db, t.id, "recorder", {"frames": 600 + k, "warnings": [] if k != 1 else ["cam_03: 12 frames missing"]})
    cat.set_state(db, t.id, "stopping")
    cat.set_state(db, t.id, "recorded", enqueue=True)
    cat.audit(db, actor="anna", action="stop", trial_id=t.id)
    job = cat.lease_job(db, "host-1", lease_s=30)
    cat.set_state(db, t.id, "processing", stage="starting", progress=0.0)
    if final == "failed":
        cat.fail_job(db, job.id, "host-1", "no keypoints recorded")
        cat.set_state(db, t.id, "failed", error="no keypoints recorded", stage="")
        continue
    for stage, method in (("preliminary", "robust triangulation"), ("refined", "implicit trajectory fit")):
        steps = [{"side": side, "time_s": 1.0 + 0.55 * i, "step_length_mm": 600.0 + i, "step_width_mm": 110.0 - i}
                 for i, side in enumerate(["left", "right", "left", "right"])]
        cat.store_result(db, trial_id=t.id, stage=stage, method=method, steps=steps,
                         summary={"step_length_mm": {"mean": 601.5, "sd": 1.3, "unit": "mm"},
                                  "cadence_steps_per_min": {"mean": 109.0 + k, "unit": "steps/min"}},
                         report={"warnings": [], "data_quality": {"serious": k == 1}}, quality={"gc_10": 0.97},
                         elapsed_s=2.5)
        cat.add_artifacts(db, t.id, stage, {"gait_json": f"{data}/trials/{t.id}/{stage}/gait.json",
                                            "trajectory_npz": f"{data}/trials/{t.id}/{stage}/trajectory.npz"})
    cat.complete_job(db, job.id, "host-1")
    cat.set_state(db, t.id, final, stage="done", progress=1.0)
    cat.audit(db, actor="ben", action="view", trial_id=t.id)
store.put_result(db, store.MethodResult(ids[0], "robust", "0123456789abcdef", {"method": "robust"}, "ok",
                                       elapsed_s=1.5, worker="host-1", skeleton="halpe26", metrics={"GC_10": 0.8},
                                       gait={"steps": 4}, residuals={"reference": "walkway"}),
                 config={"method": "robust"})
patients.correct_trial(db, ids[1], session="visit2", walking_aid="cane", notes="walked slowly")
cat.audit(db, actor="anna", action="correct", trial_id=ids[1], detail="session visit2")
db.close()
'''


def _package(tmp: Path) -> Path:
    """The release's catalog code as a package of its own under ``tmp``."""
    pkg = tmp / "pkg"
    files = subprocess.run(["git", "ls-tree", "-r", "--name-only", RELEASE, "services/catalog"], cwd=ROOT,
                           capture_output=True, text=True, check=True).stdout.split()
    for name in [*files, "services/research/store.py", "reconstruction/jsonable.py"]:
        target = pkg / "gaitcap" / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(subprocess.run(["git", "show", f"{RELEASE}:{name}"], cwd=ROOT, capture_output=True,
                                          check=True).stdout)
    for folder in ("gaitcap", "gaitcap/services", "gaitcap/services/research", "gaitcap/reconstruction"):
        (pkg / folder / "__init__.py").touch()
    return pkg


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        pkg, db = _package(Path(tmp)), Path(tmp) / "v4.sqlite"
        # -S: no site (the installed gaitcap stays out of sight); the venv's libraries by path
        subprocess.run([sys.executable, "-S", "-c", WRITE, str(pkg), str(db), sysconfig.get_paths()["purelib"]],
                       check=True)
        with sqlite3.connect(db) as con:
            lines = list(con.iterdump())
        con.close()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("-- a gaitcap catalog of schema version 4, written by release " + RELEASE
                   + " (tests/services/catalog/make_catalog_v4.py)\n" + "\n".join(lines) + "\n")
    print(f"wrote {OUT} ({len(lines)} statements)")


if __name__ == "__main__":
    main()
