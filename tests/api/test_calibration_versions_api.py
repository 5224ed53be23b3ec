"""Calibration versions over HTTP (real uvicorn, real catalog): a version's record names the calibration it
replaces, its comparison and the trials that used the old one; applying it queues those trials for the
worker under the new version (audited); a calibration that replaces nothing is 404."""

from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_versions as versions


def test_a_version_is_shown_and_applied(server):
    _, client, _, settings = server
    db = cat.open_catalog(settings.catalog_url)
    old = cat.add_calibration(db, toml="[old]")
    trials = []
    for _ in range(2):
        t = cat.start_trial(db, subject_id="P1", session="s1", calibration_id=old,
                            recording_path_for=lambda tid: f"/rec/{tid}.mcap")
        for state in ("recorded", "processing", "done"):
            cat.set_state(db, t.id, state)
        trials.append(t.id)
    comparison = {"cam02": {"centre_mm": 4.0, "rotation_deg": 2.1, "focal_pct": 0.0}}
    new = versions.add_version(db, toml="[new]", replaces_id=old, made_by="refine-rig", trials=[trials[0]],
                               comparison=comparison)
    got = client.get(f"/calibrations/{new}/version").json()
    assert got["replaces"] == old and got["comparison"] == comparison and got["lineage"] == [new, old]
    assert got["trials_using_replaced"] == trials and got["applied_at"] is None
    assert client.get(f"/calibrations/{old}/version").status_code == 404
    r = client.post(f"/calibrations/{new}/apply")
    assert r.status_code == 200 and r.json() == {"id": new, "queued": trials, "skipped": []}
    assert [cat.get_trial(db, t).state for t in trials] == ["recorded", "recorded"]
    assert versions.trials_using(db, new) == trials
    assert any(e.action == "apply calibration" and new in e.detail for e in cat.audit_entries(db))
    assert client.post(f"/calibrations/{old}/apply").status_code == 404


def test_the_page_offers_to_reprocess_the_trials_under_a_new_version(server):
    from playwright.sync_api import sync_playwright

    from .conftest import sign_in_page

    srv, _, _, settings = server
    db = cat.open_catalog(settings.catalog_url)
    old = cat.add_calibration(db, toml="[old]")
    t = cat.start_trial(db, subject_id="P1", session="s1", calibration_id=old,
                        recording_path_for=lambda tid: f"/rec/{tid}.mcap")
    for state in ("recorded", "processing", "done"):
        cat.set_state(db, t.id, state)
    new = versions.add_version(db, toml="[new]", replaces_id=old, made_by="refine-rig", trials=[t.id],
                               comparison={"cam02": {"centre_mm": 4.0, "rotation_deg": 2.1, "focal_pct": 0.0}})
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium",
                                    args=["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"])
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.set_default_timeout(30_000)
        try:
            sign_in_page(page, srv.url)
            page.wait_for_selector("#calibration-version:not([hidden])")
            text = page.inner_text("#calibration-version-text")
            button = page.inner_text("#calibration-version-apply")
            page.click("#calibration-version-apply")
            page.wait_for_function("() => document.querySelector('#calibration-version-status').textContent !== ''")
            status = page.inner_text("#calibration-version-status")
        finally:
            browser.close()
    assert text.startswith(f"Calibration {new} (refined from people, replacing {old}) is in use: cam02 2.10 deg, 4.0 mm")
    assert button == "Reprocess 1 trial(s) with it" and status == "1 trial(s) queued for processing again."
    assert cat.get_trial(db, t.id).state == "recorded" and versions.trials_using(db, new) == [t.id]
