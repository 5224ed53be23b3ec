"""The clinic's board reaches the calibration: ``gaitcap serve --board-file`` (here its settings) gives the
board recorded on every board recording, the Start body may override it, the worker searches for that
board and the report names it. A non-default board (8 x 6 checkerboard of 100 mm) rendered in the
synthetic room calibrates; the same recording searched for the wrong board fails naming the board used.
Real uvicorn, SQLite and worker; the recorder is played by the test (it writes the MCAP at the path the
API gave the recorder)."""

import httpx
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services import catalog as cat
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.processing.worker import Worker, WorkerConfig
from gaitcap.simulator.board import (
    BoardMotion,
    board_trajectory,
    render_board_images,
    write_board_mcap,
)
from gaitcap.simulator.room import build_rig

from .conftest import ALL_ROLES, TOKEN, RecordingLink, make_accounts

CLINIC_BOARD = {"kind": "checkerboard", "squares": [8, 6], "square_mm": 100.0}
WRONG_BOARD = {"kind": "charuco", "squares": [4, 5], "square_mm": 54.0, "dictionary": "DICT_4X4_50"}


@pytest.fixture(scope="module")
def frames():
    """The clinic's board waved in front of cam01 and cam02 of the synthetic room (32 frames at 0.3 x size)."""
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard(8, 6, 100.0))
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=32, floor_frames=3, seed=3), rig)
    return render_board_images(rig, board, rot, tvec, scale=0.3)


@pytest.fixture
def clinic(tmp_path):
    make_accounts(tmp_path / "data", alice=ALL_ROLES)
    settings = Settings(tokens={TOKEN: "alice"}, catalog_url=str(tmp_path / "catalog.sqlite"),
                        data_dir=tmp_path / "data", port=free_loopback_ports(1)[0], board=CLINIC_BOARD)
    link = RecordingLink()
    srv = serve_in_thread(settings, link)
    client = httpx.Client(base_url=srv.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=10)
    db = cat.open_catalog(settings.catalog_url)
    yield client, link, Worker(WorkerConfig(catalog_url=settings.catalog_url, data_dir=settings.data_dir,
                                            refine=False), db=db)
    client.close()
    srv.stop()
    db.close()


def _record(client, link, worker, frames, body=None) -> dict:
    """Start (with ``body``), the recorder writes the board clip, Stop, the worker calibrates: the result."""
    started = client.post("/calibrations/record/start", json=body)
    assert started.status_code == 201, started.text
    write_board_mcap(link.calls[-1][2], frames)
    assert client.post("/calibrations/record/stop").json()["state"] == "calibrating"
    assert worker.run_once()
    return client.get(f"/calibrations/{started.json()['id']}").json()


def test_the_clinic_board_is_recorded_searched_for_and_named_in_the_report(clinic, frames):
    client, link, worker = clinic
    got = _record(client, link, worker, frames)
    assert got["state"] == "done", got["error"]
    assert got["board"] == CLINIC_BOARD and got["active"]
    assert got["report"]["board_used"] == "checkerboard 8 x 6 squares of 100 mm"
    assert [c["name"] for c in got["report"]["cameras"]] == ["cam01", "cam02"]


def test_a_board_given_to_start_overrides_and_a_wrong_one_fails_naming_it(clinic, frames):
    client, link, worker = clinic
    got = _record(client, link, worker, frames, body={"board": WRONG_BOARD})
    assert got["state"] == "failed" and got["board"] == WRONG_BOARD and not got["active"]
    assert "too few board views of charuco 4 x 5 squares of 54 mm" in got["error"], got["error"]
    assert "camera 'cam01':" in got["error"] and "camera 'cam02':" in got["error"]
    assert got["error"].endswith("(board used: charuco 4 x 5 squares of 54 mm, markers 40.5 mm DICT_4X4_50)")


def test_a_board_that_is_no_board_is_refused_naming_the_field(clinic):
    client, link, _ = clinic
    for bad, field in (({"kind": "circles", "squares": [4, 5], "square_mm": 54}, "kind"),
                       ({"kind": "checkerboard", "squares": [1, 5], "square_mm": 54}, "squares"),
                       ({"kind": "checkerboard", "squares": [4, 5], "square_mm": -3}, "square_mm"),
                       ({"kind": "checkerboard", "squares": [4, 5], "square_mm": 54, "colour": "red"}, "colour"),
                       # well formed but no board the worker could search for: refused before filming it
                       ({**WRONG_BOARD, "dictionary": "DICT_FOO"}, "DICT_FOO"),
                       ({**WRONG_BOARD, "marker_mm": 60.0}, "marker")):
        r = client.post("/calibrations/record/start", json={"board": bad})
        assert r.status_code == 422 and field in r.text, (bad, r.text)
    assert link.calls == []  # nothing recorded
