"""The one results store: the clinic's stage rows and research's rows read through one key (trial, method,
parameters); each writer keeps its write rule (the clinic replaces a stage, research's first write wins)."""

import pytest
from gaitcap.reconstruction.methods import Implicit, Robust
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import method_results as store
from gaitcap.services.catalog.method_keys import params_key

SUMMARY = {"cadence_steps_per_min": {"mean": 110.0, "unit": "steps/min"},
           "step_length_mm": {"mean": 600.0, "sd": 20.0, "unit": "mm"}}
STEPS = [{"side": "left", "time_s": 1.0, "step_length_mm": 600.0}, {"side": "right", "time_s": 1.5}]


@pytest.fixture
def db(catalog_url):
    db = cat.open_catalog(catalog_url)
    for tid in ("T1", "T2"):
        cat.start_trial(db, subject_id="P1", session="s1", trial_id=tid, recording_path_for=lambda t: f"/d/{t}.mcap")
        cat.set_state(db, tid, "recorded")
    yield db
    db.close()


def _clinic(db, tid, stage, config, summary=SUMMARY):
    cat.store_result(db, trial_id=tid, stage=stage, method=f"{config.name} in words", steps=STEPS, summary=summary,
                     report={"problem": ""}, quality={"GC_10": 0.9}, method_name=config.name,
                     params_key=params_key(config))


def test_the_key_hashes_the_full_config_and_what_else_the_result_came_from():
    assert params_key(Robust()) == params_key(Robust(gamma=0.5)) != params_key(Robust(gamma=0.3))
    assert params_key(Robust()) != params_key(Robust(), inputs={"calibration": "C2"})
    assert params_key(Robust(), inputs={"a": "1", "b": "2"}) == params_key(Robust(), inputs={"b": "2", "a": "1"})


def test_a_clinic_stage_is_read_under_its_method_and_parameters(db):
    _clinic(db, "T1", "preliminary", Robust())
    got = store.get_result(db, "T1", "robust", params_key(Robust()))
    assert (got.stage, got.ok, got.metrics, got.spec["label"]) == ("preliminary", True, {"GC_10": 0.9}, "robust in words")
    assert got.gait == {"problem": "", "steps": 2, "summary": {**SUMMARY, "cadence_steps_per_min": {
        **SUMMARY["cadence_steps_per_min"], "sd": None}}}
    assert store.get_result(db, "T1", "robust", params_key(Robust(gamma=0.3))) is None
    assert store.get_result(db, "T2", "robust", params_key(Robust())) is None
    assert not store.is_done(db, "T1", "robust", params_key(Robust()))  # research has still to compute it
    _clinic(db, "T1", "preliminary", Robust(), summary={"steps_count": {"mean": 3.0, "unit": ""}})  # replaced
    assert store.get_result(db, "T1", "robust", params_key(Robust())).gait["summary"]["steps_count"]["mean"] == 3.0
    assert [r.key for r in store.list_results(db)] == [("T1", "robust", params_key(Robust()))]


def test_research_rows_come_first_and_the_first_research_write_wins(db):
    robust, implicit = params_key(Robust()), params_key(Implicit())
    _clinic(db, "T1", "preliminary", Robust())
    _clinic(db, "T1", "refined", Implicit())
    mine = store.MethodResult("T1", "robust", robust, {"method": "robust"}, "ok", residuals={"reference": "walkway"},
                              gait={"steps": 2, "summary": SUMMARY})
    assert store.put_result(db, mine, config={})
    assert not store.put_result(db, store.MethodResult("T1", "robust", robust, {}, "failed", "x"), config={})
    got = store.get_result(db, "T1", "robust", robust)
    assert (got.stage, got.residuals) == ("", {"reference": "walkway"})
    assert store.done_keys(db) == {("T1", "robust", robust)}
    listed = store.list_results(db)
    assert [(r.method, r.stage) for r in listed] == [("robust", ""), ("implicit", "refined")]  # one row per key
    assert [r.key for r in store.list_results(db, params_keys=[implicit])] == [("T1", "implicit", implicit)]
    assert store.list_results(db, trial_ids=["T2"]) == []
    cat.clear_results(db, "T1")  # the clinic's rows go, research's stay
    assert [r.stage for r in store.list_results(db)] == [""]
    assert store.get_result(db, "T1", "implicit", implicit) is None


def test_only_research_failures_are_forgotten(db):
    _clinic(db, "T1", "preliminary", Robust())
    store.put_result(db, store.MethodResult("T1", "dlt", "k1", {}, "failed", "too few views"), config={})
    store.put_result(db, store.MethodResult("T2", "dlt", "k1", {}, "failed", "too few views"), config={})
    assert store.delete_failed(db, ["T1"]) == 1
    assert {r.key for r in store.list_results(db)} == {("T2", "dlt", "k1"), ("T1", "robust", params_key(Robust()))}
