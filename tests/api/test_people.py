"""Several people in view over the real API: a patient with a therapist beside, recorded as a real MCAP,
processed by the worker; the clinician switches the patient (by a click on a camera image, then from the
list) and the trial is processed again for the chosen person."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.worker import Worker, WorkerConfig

from .conftest import sign_in_page

_spec = importlib.util.spec_from_file_location("services_test_helpers",
                                               Path(__file__).parents[1] / "services" / "conftest.py")
_helpers = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_helpers)


@pytest.fixture(scope="module")
def pair():
    from gaitcap.simulator import make_trial

    return make_trial(preset="paper", seconds=6.0, cameras=6, people=2, seed=1)


def _mpjpe(points_mm, truth_mm) -> float:
    return float(np.nanmean(np.linalg.norm(np.asarray(points_mm, float) - truth_mm, axis=-1)))


def _process(settings) -> None:
    w = Worker(WorkerConfig(catalog_url=settings.catalog_url, data_dir=settings.data_dir, refine=False, lease_s=5))
    assert w.run_once()


def _closest(client, tid, pair) -> int:
    """Which true person the trial's reconstruction is (0 patient, 1 therapist), checked to be close."""
    points = client.get(f"/trials/{tid}/trajectory").json()["points_mm"]
    errors = [_mpjpe(points, truth) for truth in pair.all_points_mm]
    assert min(errors) < 100.0 and max(errors) > 300.0, errors
    return int(np.argmin(errors))


def _click_on(pair, person: int) -> dict:
    """A click on a confident keypoint of ``person`` in some camera image."""
    ident, kp = pair.multi.identity, pair.multi.observed.keypoints
    c, t, slot = (int(v[0]) for v in np.nonzero(ident[:, 60:] == person))
    t += 60
    j = int(np.argmax(kp[c, t, slot, :, 2]))
    return {"camera": pair.rig.names[c], "frame": t, "x_px": float(kp[c, t, slot, j, 0]),
            "y_px": float(kp[c, t, slot, j, 1])}


@pytest.fixture
def processed(server, pair):
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P9"}).json()["id"]
    assert client.post(f"/trials/{tid}/stop").status_code == 200
    _helpers.write_multi_trial_mcap(pair, trial_files(settings.data_dir, tid).recording, stills=True)
    _process(settings)
    return client, settings, tid


def test_automatic_then_clicked_then_listed_patient(processed, pair):
    client, settings, tid = processed
    people = client.get(f"/trials/{tid}/people").json()
    assert len(people["people"]) == 2 and people["chosen_by"] == "automatic"
    auto = people["patient_track_id"]
    assert [p["is_patient"] for p in people["people"]] == [p["track_id"] == auto for p in people["people"]]
    assert _closest(client, tid, pair) == 0  # the patient, not the therapist

    chosen = client.post(f"/trials/{tid}/patient", json=_click_on(pair, 1))
    assert chosen.status_code == 200, chosen.text
    assert client.get(f"/trials/{tid}").json()["state"] == "recorded"
    assert chosen.json()["pending_choice"] not in (None, auto)
    _process(settings)
    people = client.get(f"/trials/{tid}/people").json()
    assert people["patient_track_id"] != auto and people["chosen_by"] == "clinician"
    assert client.get(f"/trials/{tid}").json()["state"] == "done"
    assert _closest(client, tid, pair) == 1  # now the therapist

    assert client.post(f"/trials/{tid}/patient", json={"track_id": auto}).status_code == 200
    _process(settings)
    assert client.get(f"/trials/{tid}/people").json()["patient_track_id"] == auto
    assert _closest(client, tid, pair) == 0
    audit = [e for e in client.get("/audit", params={"trial_id": tid}).json() if e["action"] == "choose patient"]
    assert len(audit) == 2 and audit[0]["actor"] == "alice" and "list" in audit[0]["detail"]
    assert "click on camera" in audit[1]["detail"]


BAD_CHOICES = [
    ({}, 422, "track_id"),
    ({"track_id": "first"}, 422, "track_id"),
    ({"track_id": -1}, 422, "track_id"),
    ({"track_id": 9}, 404, "track_id"),
    ({"track_id": 0, "camera": "cam01"}, 422, "not both"),
    ({"camera": "cam01", "frame": 3}, 422, "x_px"),
    ({"camera": "nope", "frame": 3, "x_px": 1.0, "y_px": 2.0}, 404, "camera"),
    ({"camera": "cam01", "frame": 100000, "x_px": 1.0, "y_px": 2.0}, 422, "frame"),
    ({"camera": "cam01", "frame": 3, "x_px": -900.0, "y_px": -900.0}, 404, "x_px"),
    ({"track_id": 0, "name": "x"}, 422, "name"),
]


def test_bad_choices_name_the_field(processed):
    client, _, tid = processed
    for body, status, field in BAD_CHOICES:
        r = client.post(f"/trials/{tid}/patient", json=body)
        assert r.status_code == status and field in r.json()["detail"], (body, r.text)
    assert client.get(f"/trials/{tid}").json()["state"] == "done"
    assert not [e for e in client.get("/audit", params={"trial_id": tid}).json() if e["action"] == "choose patient"]


def test_unknown_trial_no_token_and_single_person_trials(server):
    srv, client, _, _ = server
    assert client.get("/trials/T-nope/people").status_code == 404
    assert client.post("/trials/T-nope/patient", json={"track_id": 0}).status_code == 404
    tid = client.post("/trials", json={"subject_id": "P3"}).json()["id"]
    assert client.post(f"/trials/{tid}/patient", json={"track_id": 0}).status_code == 409  # recording
    assert client.get(f"/trials/{tid}/people").json()["people"] == []
    import httpx

    assert httpx.get(f"{srv.url}/trials/{tid}/people").status_code == 401


def _still_click(pair, people: dict, person: int) -> tuple[str, float, float]:
    """A camera that sees ``person`` in the frame the page shows, and where (fractions of the image)."""
    t = people["busiest_frame"]
    for c, cam in enumerate(pair.rig.names):
        slots = np.flatnonzero(pair.multi.identity[c, t] == person)
        if slots.size:
            kp = pair.multi.observed.keypoints[c, t, slots[0]]
            j = int(np.argmax(kp[:, 2]))
            w, h = people["image_sizes_px"][cam]
            return cam, kp[j, 0] / w, kp[j, 1] / h
    raise AssertionError(f"person {person} is not seen in frame {t}")


def test_recorded_stills(processed):
    client, _, tid = processed
    people = client.get(f"/trials/{tid}/people").json()
    frame, cam = people["busiest_frame"], people["cameras"][0]
    r = client.get(f"/trials/{tid}/still/{cam}.jpg", params={"frame": frame})
    assert r.status_code == 200 and r.content.startswith(b"\xff\xd8")
    assert "camera" in client.get(f"/trials/{tid}/still/nope.jpg", params={"frame": 0}).json()["detail"]
    assert client.get(f"/trials/{tid}/still/{cam}.jpg", params={"frame": 10**6}).status_code == 422


def test_the_page_lists_the_people_and_switches_the_patient(server, processed, pair, tmp_path):
    from playwright.sync_api import expect, sync_playwright

    srv, _, _, _ = server
    client, settings, tid = processed
    people = client.get(f"/trials/{tid}/people").json()
    auto = people["patient_track_id"]
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=["--headless", "--no-sandbox",
                                                                                "--disable-gpu"])
        page = browser.new_page(viewport={"width": 1280, "height": 1100})
        page.set_default_timeout(20_000)
        try:
            sign_in_page(page, srv.url)
            page.locator(f'tr[data-trial="{tid}"] .view').click()
            expect(page.locator("#people-table tbody tr")).to_have_count(2)
            expect(page.locator(f'#people tr[data-track="{auto}"]')).to_contain_text("Patient (chosen automatically)")
            # a click on the therapist in a camera image
            cam, fx, fy = _still_click(pair, people, person=1)
            img = page.locator(f'#people-stills [data-camera="{cam}"] img')
            expect(img).to_be_visible()
            expect(page.locator(f'#people-stills .person-mark[data-track="{auto}"]').first).to_contain_text("(patient)")
            box = img.bounding_box()
            img.click(position={"x": fx * box["width"], "y": fy * box["height"]})
            expect(page.locator("#people-status")).to_contain_text("Computing the walk again for person")
            _process(settings)
            expect(page.locator(f'#people tr[data-track="{1 - auto}"]')).to_contain_text("Patient (your choice)")
            # back to the automatic choice from the list
            page.locator(f'#people tr[data-track="{auto}"] .choose').click()
            expect(page.locator("#people-status")).to_contain_text("Computing the walk again")
            _process(settings)
            expect(page.locator(f'#people tr[data-track="{auto}"]')).to_contain_text("Patient (your choice)")
            expect(page.locator("#people-status")).to_contain_text("results below are for the chosen person")
        finally:
            page.screenshot(path=str(tmp_path / "people.png"), full_page=True)
            browser.close()
    assert _closest(client, tid, pair) == 0
