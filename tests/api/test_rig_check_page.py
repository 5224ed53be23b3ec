"""The rig check on the clinic page (real uvicorn, real catalog, headless Chromium): the latest processed
trial's rig check, computed by the worker's own check on a synthetic walk whose calibration is 2 deg off
for one camera, is shown in the calibration card before the next patient: the camera named as moved with
its rotation (deg) and shift (mm); the others in place."""

from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.services import catalog as cat
from gaitcap.services.processing.checks import rig_check
from gaitcap.simulator.rig_faults import with_camera_moved

from .conftest import ALL_ROLES, make_accounts, sign_in_page, signed_in_page
from .test_clinic_page import _fits

MOVED = "cam02"


def _stale(rig: Rig) -> Rig:
    return with_camera_moved(rig, MOVED, rotation_deg=2.0)


def _processed_trial(db) -> str:
    """A trial processed under a stale calibration, its quality record holding the worker's rig check."""
    from gaitcap.simulator import make_trial

    walk = make_trial("clean", seconds=8, cameras=5, people=1, seed=4, fps=30)
    stale = _stale(walk.rig)
    check = rig_check(walk.detections, stale, robust_triangulate(walk.detections, stale).points_mm)
    t = cat.start_trial(db, subject_id="P7", session="s1", recording_path_for=lambda tid: f"/nowhere/{tid}.mcap")
    for state in ("recorded", "processing", "done_with_warnings"):
        cat.set_state(db, t.id, state)
    cat.set_quality(db, t.id, "processing", {"warnings": check["warnings"], "checks": {"rig": check}})
    return t.id


def test_the_latest_trials_rig_check_names_the_moved_camera_on_the_page(server):
    srv, client, _, settings = server
    assert client.get("/rig-check/latest").status_code == 404  # nothing processed yet
    db = cat.open_catalog(settings.catalog_url)
    tid = _processed_trial(db)
    got = client.get("/rig-check/latest").json()
    assert got["trial_id"] == tid and got["moved"] == [MOVED] and got["flagged"]
    with signed_in_page(srv.url) as page:
        page.wait_for_selector("#rig-check:not([hidden])")
        summary = page.locator("#rig-check-summary").inner_text()
        header = page.locator("#rig-check-table thead th").all_inner_texts()
        rows = {r.locator("td").first.inner_text(): r.locator("td").all_inner_texts()
                for r in page.locator("#rig-check-table tbody tr").all()}
    assert summary.startswith(f"Camera {MOVED} (about ") and f"seen in trial {tid} (patient P7" in summary, summary
    assert "before the next patient" in summary
    result, rotation = header.index("Since calibration"), header.index("Rotation (deg)")
    estimate, bound = (float(x) for x in rows[MOVED][rotation].split(" ± "))  # the page says how far it may be off
    assert rows[MOVED][result] == "MOVED" and abs(estimate - 2.0) < 0.3, rows[MOVED]
    stored = next(c for c in got["cameras"] if c["name"] == MOVED)
    assert abs(bound - max(stored["rotation_bound_deg"])) < 0.006 and f"± {bound:.1f} deg" in summary, (bound, summary)
    assert [r[result] for n, r in rows.items() if n != MOVED] == ["in place"] * 4, rows
    assert all(float(r[rotation].split(" ± ")[0]) < 0.3 for n, r in rows.items() if n != MOVED), rows

    # a clinician records but does not calibrate: the rig check is in the record card, beside Start
    make_accounts(settings.data_dir, alice=ALL_ROLES, carol=("clinician",))
    with signed_in_page(srv.url) as page:
        page.click("#logout")
        sign_in_page(page, srv.url, "carol")
        assert page.is_hidden("#calibrate-card") and page.is_visible("#record")
        page.wait_for_selector("#record #rig-check:not([hidden])")
        for width, height in ((1280, 900), (768, 1024), (390, 844)):
            page.set_viewport_size({"width": width, "height": height})
            assert page.locator("#rig-check-summary").inner_text() == summary, width
            assert page.locator("#rig-check-summary").is_visible(), width
            _fits(page, width, ("rig check", width))
