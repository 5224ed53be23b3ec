"""The web service's security, against a real uvicorn (HTTP and HTTPS) and a real catalog: every route
of the OpenAPI schema refused without sign-in and to the wrong roles, body limits before parsing, no
echo, NaN refused, headers, cookies, throttled sign-in, the hash-chained audit trail, TLS and modes."""

import contextlib
import json
import re
import ssl
import stat
import time

import httpx
import pytest
from gaitcap.api.audit_chain import verify
from gaitcap.api.auth import PUBLIC_PATHS, ROUTE_PERMISSIONS
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services.access.accounts import ROLES
from gaitcap.services.bus.session import free_loopback_ports

from .conftest import PASSWORD, RecordingLink, make_accounts, signed_in

ROLE_USERS = {f"{r}1": (r,) for r in ROLES}
SAMPLE = {"trial_id": "T1", "cal_id": "C1", "name": "cam0", "camera": "cam0", "subject_id": "P1"}


@pytest.fixture(scope="module")
def srv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sec")
    make_accounts(tmp / "data", **ROLE_USERS)
    settings = Settings(catalog_url=str(tmp / "data" / "catalog.sqlite"), data_dir=tmp / "data",
                        port=free_loopback_ports(1)[0], max_body_bytes=100_000, login_failures=3,
                        login_window_s=60)
    server = serve_in_thread(settings, RecordingLink())
    yield server, settings
    server.stop()


def _routes(url):
    schema = httpx.get(f"{url}/openapi.json").json()
    for path, methods in schema["paths"].items():
        for method in methods:
            yield method.upper(), path


def _fill(path):
    return re.sub(r"\{(\w+)\}", lambda m: SAMPLE[m.group(1)], path)


def test_every_route_needs_sign_in_and_the_right_role(srv):
    server, _ = srv
    routes = [r for r in _routes(server.url) if r[1] not in PUBLIC_PATHS]
    assert len(routes) >= 25
    missing = [r for r in routes if r not in ROUTE_PERMISSIONS]
    assert not missing, f"routes without a permission (refused to everyone): {missing}"
    with contextlib.ExitStack() as stack:
        clients = {u: stack.enter_context(signed_in(server.url, u)) for u in ROLE_USERS}
        for method, path in routes:
            url = f"{server.url}{_fill(path)}"
            assert httpx.request(method, url, json={}, timeout=30).status_code == 401, (method, path)
            for user, (role,) in ROLE_USERS.items():
                code = clients[user].request(method, _fill(path), json={} if method == "POST" else None,
                                             timeout=30).status_code if "mjpg" not in path else None
                if code is None:
                    continue
                allowed = bool(ROUTE_PERMISSIONS[(method, path)] & ROLES[role])
                assert (code == 403) != allowed, (method, path, role, code)


def test_bodies_are_limited_before_parsing_and_never_echoed(srv):
    server, _ = srv
    big = b"{" + b"x" * 200_000
    r = httpx.post(f"{server.url}/trials", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413 and len(r.content) < 200  # refused from its size: not parsed, not echoed
    r = httpx.post(f"{server.url}/trials", content=b'{"subject_id": ', headers={"content-type": "application/json"})
    assert r.status_code == 401  # unauthenticated first, even when malformed

    def chunks():  # no Content-Length: counted while streaming
        for _ in range(30):
            yield b" " * 10_000

    with signed_in(server.url, "clinician1") as c:
        assert c.post("/trials", content=chunks(), headers={"content-type": "application/json"}).status_code == 413
        for bad in (b'{"subject_id": "P1", "x": NaN}', b'{"subject_id": "P1", "x": Infinity}'):
            r = c.post("/trials", content=bad, headers={"content-type": "application/json"})
            assert r.status_code == 422 and "JSON allows" in r.json()["detail"], bad
        secret = "SECRET-INPUT-" + "y" * 500
        r = c.post("/trials", json={"subject_id": secret})
        assert r.status_code == 422 and "SECRET-INPUT" not in r.text and "subject_id" in r.json()["detail"]
        r = c.post("/trials", json={"subject_id": "P1", "session": "x..y"})
        assert r.status_code == 422 and "session" in r.text


def test_security_headers_and_the_session_cookie(srv):
    server, settings = srv
    for path in ("/", "/health", "/docs", "/static/app.js"):
        h = httpx.get(f"{server.url}{path}").headers
        assert "script-src 'self'" in h["content-security-policy"] and "unsafe-inline" not in \
            h["content-security-policy"].split("script-src")[1].split(";")[0], path
        assert "frame-ancestors 'none'" in h["content-security-policy"]
        assert (h["x-frame-options"], h["referrer-policy"], h["x-content-type-options"]) == \
            ("DENY", "no-referrer", "nosniff")
        assert "strict-transport-security" not in h  # plain HTTP on loopback
    docs = httpx.get(f"{server.url}/docs").text
    assert "cdn" not in docs.lower() and "<script>" not in docs
    assert httpx.get(f"{server.url}/static-docs/swagger-ui-bundle.js").status_code == 200
    r = httpx.post(f"{server.url}/login", json={"user": "clinician1", "password": PASSWORD})
    cookie = r.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=strict" in cookie and "secure" not in cookie
    assert PASSWORD not in (settings.audit_path.read_text() + (settings.data_dir / "accounts.json").read_text())


def test_sign_in_is_throttled_and_every_access_audited_as_the_signed_in_user(srv):
    server, settings = srv
    url = server.url
    for _ in range(3):
        assert httpx.post(f"{url}/login", json={"user": "researcher1", "password": "wrong"}).status_code == 401
    r = httpx.post(f"{url}/login", json={"user": "researcher1", "password": PASSWORD})
    assert r.status_code == 429  # even the right password, until the window has passed
    with signed_in(url, "clinician1", headers={"X-Gaitcap-User": "mallory"}) as c:
        c.get("/trials", params={"limit": 3})

    codes = [httpx.get(f"{url}/trials", headers={"Authorization": f"Bearer guess-{i:04d}-xxxxxxxxxx"}).status_code
             for i in range(12)]  # the address has 3 failures already; its limit is 4 x 3
    assert codes == [401] * 9 + [429] * 3
    lines = [json.loads(x) for x in settings.audit_path.read_text().splitlines()]
    assert [x["action"] for x in lines if "researcher1" in x["detail"]][:4] == ["login failed"] * 3 + ["login throttled"]
    assert sum(x["action"] == "token failed" for x in lines) == 9
    mine = [x for x in lines if x["target"] == "/trials" and x["detail"] == "limit=3"]
    assert mine and mine[-1]["actor"] == "clinician1" and "mallory" not in settings.audit_path.read_text()
    assert verify(settings.audit_path) == (len(lines), None)
    tampered = settings.audit_path.with_name("tampered.log")
    tampered.write_text(settings.audit_path.read_text().replace('"actor":"clinician1"', '"actor":"someone"', 1))
    n, problem = verify(tampered)
    assert problem and "edited" in problem
    for f in (settings.audit_path, settings.data_dir / "accounts.json", settings.data_dir / "catalog.sqlite"):
        assert stat.S_IMODE(f.stat().st_mode) == 0o600, f


def test_sessions_end_when_idle_and_on_sign_out(tmp_path):
    make_accounts(tmp_path, ann=("clinician",))
    settings = Settings(catalog_url=str(tmp_path / "c.sqlite"), data_dir=tmp_path,
                        port=free_loopback_ports(1)[0], session_idle_s=1.0)
    server = serve_in_thread(settings)
    try:
        with signed_in(server.url, "ann") as c:
            assert c.get("/trials").status_code == 200
            time.sleep(1.3)
            assert c.get("/trials").status_code == 401  # automatic log-off
        with signed_in(server.url, "ann") as c:
            assert c.post("/logout").status_code == 200 and c.get("/trials").status_code == 401
    finally:
        server.stop()


def test_https_with_the_lab_certificate_and_no_plain_http_beyond_loopback(tmp_path):
    from gaitcap.services.bus.certs import web_certificate

    with pytest.raises(ValueError, match="beyond loopback without TLS"):
        Settings(catalog_url="x", data_dir=tmp_path, host="0.0.0.0")
    cert, key = web_certificate("127.0.0.1", tmp_path / "tls")
    make_accounts(tmp_path, ann=("clinician",))
    settings = Settings(catalog_url=str(tmp_path / "c.sqlite"), data_dir=tmp_path,
                        port=free_loopback_ports(1)[0], tls_cert=cert, tls_key=key)
    server = serve_in_thread(settings)
    try:
        assert server.url.startswith("https://")
        verify_ca = ssl.create_default_context(cafile=str(tmp_path / "tls" / "ca.pem"))
        with httpx.Client(base_url=server.url, verify=verify_ca) as c:
            r = c.post("/login", json={"user": "ann", "password": PASSWORD})
            assert r.status_code == 200 and "secure" in r.headers["set-cookie"].lower()
            assert "max-age=31536000" in c.get("/trials").headers["strict-transport-security"]
        with pytest.raises(httpx.ConnectError):  # an unknown certificate is not trusted
            httpx.get(f"{server.url}/health")
    finally:
        server.stop()


@pytest.mark.parametrize("subject,refused", [
    ("P0042", None), ("p0042", None), ("DEMO001", None), ("P-netns", None),
    ("Smith_John", "looks like a name"), ("P19840217", "date"), ("anna.berg-2", "looks like a name"),
    ("P-17.02.1984", "date"), ("x" * 40, "must match"),
])
def test_subject_ids_are_pseudonyms_matched_case_insensitively(subject, refused):
    from gaitcap.api.subject_ids import check_subject_id

    if refused is None:
        assert check_subject_id(subject) == subject.upper()
    else:
        with pytest.raises(ValueError, match=refused):
            check_subject_id(subject)


def test_the_api_refuses_name_like_ids_and_finds_patients_in_any_case(server):
    srv, client, _, _ = server
    r = client.post("/trials", json={"subject_id": "Maria_Lopez"})
    assert r.status_code == 422 and "looks like a name" in r.json()["detail"]
    tid = client.post("/trials", json={"subject_id": "p0042"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    assert [t["id"] for t in client.get("/trials", params={"subject_id": "P0042"}).json()] == [tid]
    assert [t["id"] for t in client.get("/trials", params={"subject_id": "p0042"}).json()] == [tid]


def test_the_catalog_is_backed_up_online_on_a_schedule(tmp_path):
    import sqlite3

    make_accounts(tmp_path, ann=("clinician",))
    settings = Settings(catalog_url=str(tmp_path / "c.sqlite"), data_dir=tmp_path,
                        port=free_loopback_ports(1)[0], backup_interval_s=0.4, backup_keep=2)
    server = serve_in_thread(settings, RecordingLink())
    try:
        with signed_in(server.url, "ann") as c:
            tid = c.post("/trials", json={"subject_id": "P7"}).json()["id"]
        deadline = time.monotonic() + 10
        while len(list((tmp_path / "backups").glob("*.sqlite"))) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.5)
        copies = sorted((tmp_path / "backups").glob("catalog-*.sqlite"))
        assert len(copies) == 2  # the newest two kept
        assert stat.S_IMODE(copies[-1].stat().st_mode) == 0o600
        with sqlite3.connect(copies[-1]) as db:
            assert [tid] in [list(r) for r in db.execute("SELECT id FROM trials")]
    finally:
        server.stop()


def test_an_admin_voids_a_trial_with_a_reason_files_and_rows_go_the_audit_stays(server):
    srv, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P8"}).json()["id"]
    folder = settings.data_dir / "trials" / tid
    assert client.post(f"/trials/{tid}/void", json={"reason": "wrong patient"}).status_code == 409  # recording
    client.post(f"/trials/{tid}/stop")
    assert client.post(f"/trials/{tid}/void", json={"reason": "x"}).status_code == 422  # a reason is required
    r = client.post(f"/trials/{tid}/void", json={"reason": "consent withdrawn"})
    assert r.status_code == 200 and r.json()["catalog_rows"] == 1 and r.json()["files_removed"]
    assert not folder.exists() and client.get(f"/trials/{tid}").status_code == 404
    audit = client.get("/audit", params={"trial_id": tid}).json()
    assert audit[0]["action"] == "void" and audit[0]["detail"] == "consent withdrawn" and audit[0]["actor"] == "alice"
    assert "consent withdrawn" in settings.audit_path.read_text()


def test_the_audit_trail_is_copied_to_syslog(tmp_path):
    import socket

    from gaitcap.api.audit_chain import AuditChain

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver:
        receiver.bind(("127.0.0.1", 0))
        receiver.settimeout(5)
        chain = AuditChain(tmp_path / "audit.log", syslog_address=f"127.0.0.1:{receiver.getsockname()[1]}")
        chain.record(actor="ann", action="get", target="/trials/T1/gait", ip="10.0.0.7")
        datagram = receiver.recv(65536).decode()
    assert "gaitcap-audit" in datagram and '"actor":"ann"' in datagram and '"target":"/trials/T1/gait"' in datagram
    assert verify(tmp_path / "audit.log") == (1, None)


def test_the_page_shows_each_role_only_what_it_may_do(server):
    from gaitcap.services.access.accounts import AccountStore
    from playwright.sync_api import sync_playwright

    from .conftest import sign_in_page

    srv, _, _, settings = server
    store = AccountStore(settings.accounts_path)
    for name, role in (("rita", "researcher"), ("carl", "clinician"), ("eve", "engineer")):
        store.set(name, password=PASSWORD, roles=[role])
    shown = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=["--headless", "--no-sandbox",
                                                                                "--disable-gpu"])
        try:
            for name in ("rita", "carl", "eve"):
                page = browser.new_page()
                page.set_default_timeout(20_000)
                sign_in_page(page, srv.url, name)
                shown[name] = [c for c in ("#record", "#calibrate-card", "#cameras-card") if page.is_visible(c)]
                assert name in page.inner_text("#account-name")
                page.click("#logout")
                page.wait_for_selector("#login:not([hidden])")
                page.close()
        finally:
            browser.close()
    assert shown == {"rita": [], "carl": ["#record", "#cameras-card"], "eve": ["#calibrate-card", "#cameras-card"]}
