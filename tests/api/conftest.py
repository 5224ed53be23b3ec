"""A real uvicorn on 127.0.0.1 with a real SQLite catalog; the live system behind it is a small
in-test link that records the recorder calls (the full stack runs in the browser and fault tests)."""

import contextlib
import time

import httpx
import pytest
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.live.nodes import NodeState
from gaitcap.services.live.protocols import CameraHealth, RecorderUnavailable

TOKEN = "test-api-token-123456"  # an API token of alice (scripts)


class RecordingLink:
    """Stands in for the recorder and cameras: remembers calls, serves two preview frames."""

    connected = True

    def __init__(self):
        self.calls, self.fail, self.recording, self.calibration_toml = [], False, None, None
        self.board_calls = []  # the board watch's (watch_board, unwatch_board)
        self.camera_list = [CameraHealth("cam0", 30.0, True, "ok", 0.01),
                            CameraHealth("cam1", 12.0, False, "low frame rate", 0.5)]
        self.up = {n: NodeState(n, True, time.time(), False) for n in ("recorder", "detector", "worker-0")}
        self.jpeg = bytes.fromhex("ffd8ffe000104a464946") + b"\x00" * 20 + bytes.fromhex("ffd9")

    def start(self, *, trial_id, path, metadata, calibration_toml=None):
        if self.fail:
            raise RecorderUnavailable("recorder did not answer within 2 s")
        self.calls.append(("start", trial_id, path, metadata))
        self.calibration_toml = calibration_toml
        self.recording = trial_id

    def stop(self, trial_id):
        self.calls.append(("stop", trial_id))
        self.recording = None
        return {"frames": 10}

    def cameras(self):
        return list(self.camera_list)

    def nodes(self):
        return dict(self.up)

    def recorder_status(self):
        return {"trial_id": self.recording, "queued": 0} if self.up["recorder"].alive else None

    def detection(self):
        return {"nodes": {}, "cameras": {}}

    def watch_board(self, calibration_id, board):
        self.board_calls.append(("watch board", calibration_id, board))
        self.board_watched, self.board_sightings, self.board_looked = calibration_id, [], {}

    def unwatch_board(self, calibration_id):
        self.board_calls.append(("unwatch board", calibration_id))

    def board_coverage(self, calibration_id, cameras):
        from gaitcap.services.live.board_coverage import coverage_summary

        if getattr(self, "board_watched", None) != calibration_id:
            return None
        return coverage_summary(self.board_sightings, self.board_looked, cameras=cameras)

    def preview(self, camera):
        return (time.time(), self.jpeg) if camera in ("cam0", "cam1") else None

    def close(self):
        pass


ALL_ROLES = ("admin", "clinician", "engineer", "researcher")
PASSWORD = "a-long-test-password"


def make_accounts(data_dir, **users) -> None:
    """Accounts ``name=(role, ...)``, all with :data:`PASSWORD`."""
    from gaitcap.services.access.accounts import AccountStore

    store = AccountStore(data_dir / "accounts.json")
    for name, roles in users.items():
        store.set(name, password=PASSWORD, roles=roles)


@contextlib.contextmanager
def signed_in(url: str, user: str = "alice", **kwargs):
    """A client with the session cookie of ``user`` (closed on exit)."""
    from gaitcap.services.access.client import sign_in

    with httpx.Client(base_url=url, timeout=10, **kwargs) as client:
        yield sign_in(client, user, PASSWORD)


def sign_in_page(page, url: str, user: str = "alice", password: str = PASSWORD) -> None:
    """Open the page and sign in through its form (the session cookie is HttpOnly: the page never sees it)."""
    page.goto(url.rstrip("/") + "/")
    page.wait_for_selector("#login:not([hidden])")
    page.fill("#user-input", user)
    page.fill("#password-input", password)
    page.click("#login-form button")
    page.wait_for_selector("#app:not([hidden])")


BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]


@contextlib.contextmanager
def signed_in_page(url: str, *, width: int = 1280, height: int = 900, timeout_ms: int = 30_000):
    """A headless Chromium page of ``width`` x ``height`` px, signed in to the page at ``url``; the
    browser is closed afterwards, whatever happens."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=BROWSER_ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.set_default_timeout(timeout_ms)
            sign_in_page(page, url)
            yield page
        finally:
            browser.close()


@pytest.fixture
def server(tmp_path):
    make_accounts(tmp_path / "data", alice=ALL_ROLES)
    settings = Settings(tokens={TOKEN: "alice"}, catalog_url=str(tmp_path / "catalog.sqlite"),
                        data_dir=tmp_path / "data", port=free_loopback_ports(1)[0], status_period_s=0.1)
    link = RecordingLink()
    srv = serve_in_thread(settings, link)
    client = httpx.Client(base_url=srv.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=10)
    yield srv, client, link, settings
    client.close()
    srv.stop()
