"""A calibration that fails because the board was not seen enough (real uvicorn, SQLite catalog, the
worker's calibrate job on a real board MCAP, headless Chromium): the failure is stored with what each
camera saw, and the page says plainly what failed, a line per failing camera, and per camera what was found
("not seen" for a camera that never saw the board; for a board held still, "too few positions" with
the advice to move it), with no "nan", at 1280, 768 and 390 px."""

import numpy as np
from gaitcap.acquisition.drivers.simulated import SimTrialSpec
from gaitcap.simulator.board import write_board_mcap
from gaitcap.simulator.board_scene import BoardScene, board_scene_config

from .conftest import signed_in_page

SIZE = (576, 360)
WIDTHS = ((1280, 900), (768, 1024), (390, 844))


def _board_recording(path, *, still: bool = False) -> None:
    """cam01 films the short board clip's first frames (enough views); cam02 sees an empty room. ``still``:
    both cameras film the board held still in one place for 6 frames (the views a camera needs: enough
    views, one position each)."""
    rig = SimTrialSpec(cameras=2, fps=10.0, seconds=5.0).make().rig
    scene = BoardScene(rig, board_scene_config("short"))
    seen = np.stack([scene.render_gray("cam01", 0, SIZE)] * 6 if still
                    else [scene.render_gray("cam01", i, SIZE) for i in range(8)])
    write_board_mcap(path, {"cam01": seen, "cam02": seen if still else np.full_like(seen, 110)}, fps=10.0)


def _recording_path(link) -> str:
    """Where the recorder was told to write the board recording (the last start)."""
    return next(call for call in reversed(link.calls) if call[0] == "start")[2]


def test_a_board_not_seen_enough_is_shown_per_camera_without_nan(server):
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.worker import Worker, WorkerConfig
    srv, c, link, settings = server
    run = c.post("/calibrations/record/start").json()
    _board_recording(_recording_path(link))
    assert c.post("/calibrations/record/stop").json()["state"] == "calibrating"
    db = cat.open_catalog(settings.catalog_url)
    worker = Worker(WorkerConfig(catalog_url=settings.catalog_url, data_dir=settings.data_dir, refine=False), db=db)
    assert worker.run_once()
    got = c.get(f"/calibrations/{run['id']}").json()
    assert got["state"] == "failed" and not got["active"], got
    assert "too few board views" in got["error"] and "nan" not in got["error"].lower(), got["error"]
    assert "camera      frames" not in got["error"]  # the detection table is in the report, per camera
    found = {d["name"]: d for d in got["report"]["detections"]}
    assert sorted(found) == ["cam01", "cam02"]
    assert not found["cam02"]["seen"] and found["cam02"]["with_board"] == 0 and found["cam02"]["frames"] == 8
    assert found["cam01"]["usable"] >= found["cam01"]["needed"] and not found["cam01"]["advice"]
    assert found["cam02"]["usable"] == 0 and found["cam02"]["advice"]
    assert found["cam01"]["positions"] >= found["cam01"]["needed"] and found["cam02"]["positions"] == 0
    with signed_in_page(srv.url) as page:
        page.evaluate("id => { cal.id = id; followCalibration(); }", run["id"])
        page.wait_for_function("() => document.querySelector('#calibration-status').textContent"
                               ".startsWith('Calibration failed')")
        for width, height in WIDTHS:
            page.set_viewport_size({"width": width, "height": height})
            card = page.inner_text("#calibrate-card")
            assert "nan" not in card.lower(), (width, card)
            error = page.locator("#calibration-error")
            assert error.is_visible() and "too few board views" in error.inner_text()
            lines = error.inner_text().splitlines()
            assert len(lines) >= 2 and lines[1].startswith("camera 'cam02'"), lines  # a line per camera
            assert page.locator("#calibration-found").is_visible(), width
            rows = {r.locator("td").first.inner_text(): r.locator("td").all_inner_texts()
                    for r in page.locator("#calibration-found tbody tr").all()}
            assert sorted(rows) == ["cam01", "cam02"]
            assert rows["cam02"][1].startswith("not seen") and rows["cam02"][3] == "not seen", rows
            assert rows["cam01"][1] == "8 of 8 frames" and rows["cam01"][3] == "enough views", rows
            assert page.evaluate("document.documentElement.scrollWidth") <= width
        # the board held still: enough views, too few positions, and the advice column says what to change
        still = c.post("/calibrations/record/start").json()
        _board_recording(_recording_path(link), still=True)
        assert c.post("/calibrations/record/stop").json()["state"] == "calibrating"
        assert worker.run_once()
        got = c.get(f"/calibrations/{still['id']}").json()
        assert got["state"] == "failed", got
        found = {d["name"]: d for d in got["report"]["detections"]}
        assert all(d["usable"] >= d["needed"] > d["positions"] == 1 and d["advice"] for d in found.values()), found
        page.evaluate("id => { cal.id = id; followCalibration(); }", still["id"])
        page.wait_for_function("() => document.querySelector('#calibration-found tbody td:nth-child(4)')"
                               "?.textContent.startsWith('too few positions')")
        for width, height in WIDTHS:
            page.set_viewport_size({"width": width, "height": height})
            rows = {r.locator("td").first.inner_text(): r.locator("td").all_inner_texts()
                    for r in page.locator("#calibration-found tbody tr").all()}
            assert sorted(rows) == ["cam01", "cam02"], rows
            for name, cells in rows.items():
                assert cells[3] == "too few positions (1)" and cells[4] == "; ".join(found[name]["advice"]), cells
                assert "only 1 distinct positions remain" in cells[4] and "move the board to more places" in cells[4]
            assert page.locator("#calibration-found tbody tr td:nth-child(5)").first.is_visible(), width
            assert page.evaluate("document.documentElement.scrollWidth") <= width
