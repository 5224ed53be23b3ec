"""One results store: a trial processed by the clinic's worker, then reprocessed by research with the
clinic's methods and parameters. Research reads the clinic's rows under its own keys before it computes
them, and its results under the same keys carry the same gait summaries, exactly."""

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import method_results as store
from gaitcap.services.processing.worker import Worker, WorkerConfig
from gaitcap.services.research.executors import Inline
from gaitcap.services.research.method_specs import parse_method
from gaitcap.services.research.reprocess import TrialSelection, plan_reprocess, run_plan

from ..conftest import write_trial_mcap

CLINIC = {"preliminary": parse_method("robust"), "refined": parse_method("implicit")}  # the worker's stages


@pytest.fixture(scope="module")
def walk():
    from gaitcap.simulator import make_trial

    return make_trial("clean", seconds=8, cameras=4, people=1, seed=3, fps=30)


def _gait(summary: dict) -> dict:
    """name -> (mean, sd, unit); a summary item without an SD has None."""
    return {name: (item["mean"], item.get("sd"), item["unit"]) for name, item in summary.items()}


def test_research_reads_the_clinics_rows_under_its_keys_and_computes_the_same_gait(tmp_path, walk):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    write_trial_mcap(walk, tmp_path / f"{t.id}.mcap")
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=True, lease_s=30), db=db).run_once()
    assert cat.get_trial(db, t.id).state == "done"
    clinic = {stage: cat.get_result(db, t.id, stage) for stage in CLINIC}
    for stage, spec in CLINIC.items():  # the research read finds the clinic's row under the same key
        row = store.get_result(db, t.id, spec.method, spec.key)
        assert row is not None and row.stage == stage, (stage, row)
        assert row.gait["summary"] == clinic[stage].summary and row.gait["steps"] == len(clinic[stage].steps) > 4
    assert {r.stage for r in store.list_results(db, trial_ids=[t.id])} == set(CLINIC)

    plan = plan_reprocess(db, tmp_path, TrialSelection(), list(CLINIC.values()), write_files=False)
    assert len(plan.tasks) == 2  # research computes them again, with its references
    with Inline().open() as ex:
        assert run_plan(plan, ex).computed == 2
    for stage, spec in CLINIC.items():
        mine = store.get_result(db, t.id, spec.method, spec.key)
        assert mine.stage == "" and mine.ok, mine.error
        assert _gait(mine.gait["summary"]) == _gait(clinic[stage].summary), stage
        assert mine.gait["steps"] == len(clinic[stage].steps)
    assert {r.stage for r in store.list_results(db, trial_ids=[t.id])} == {""}  # one row per key: research's
    db.close()
