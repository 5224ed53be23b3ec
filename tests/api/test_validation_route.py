"""GET /trials/{id}/validation: the trial's ``gaitcap validate`` result and files, a 404 naming why without."""

import json

import pytest
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.validation.names import FILES, TRIAL_FOLDER


@pytest.fixture
def trial(server):
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P9"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    return client, tid, trial_files(settings.data_dir, tid).root / TRIAL_FOLDER


def test_validation_is_served_once_written_and_a_404_says_why_before(trial):
    client, tid, folder = trial
    r = client.get(f"/trials/{tid}/validation")
    assert r.status_code == 404 and "gaitcap validate" in r.json()["detail"]
    assert client.get("/trials/nosuchtrial/validation").status_code == 404
    folder.mkdir(parents=True)
    result = {"reference": "walk.c3d", "alignment": {"lag_s": 0.25}, "events": [], "parameters": {}}
    (folder / FILES["json"]).write_text(json.dumps(result))
    (folder / FILES["csv"]).write_text("section,name\n")
    got = client.get(f"/trials/{tid}/validation").json()
    assert {k: v for k, v in got.items() if k != "shown"} == result
    assert got["shown"] == {"alignment": "Against reference walk.c3d: lag +0.250 s.", "rows": [],
                            "not_compared": []}
    r = client.get(f"/trials/{tid}/validation/csv")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv") and r.text == "section,name\n"
    r = client.get(f"/trials/{tid}/validation/pdf")
    assert r.status_code == 404 and "no validation pdf" in r.json()["detail"]
    assert client.get(f"/trials/{tid}/validation/xls").status_code == 422
