"""One camera count on the clinic page (real uvicorn, headless Chromium; the cameras are the in-test
link's, the hardware edge): with a camera down the Cameras heading and the system banner say the same
words ("9 of 10 cameras working; not working: cam03 (no frames)"), never "10 cameras, all working" beside
"9 of 10 working"; with it back both say so, at 1280, 768 and 390 px."""

from gaitcap.services.live.protocols import CameraHealth

from .conftest import signed_in_page

WIDTHS = ((1280, 900), (768, 1024), (390, 844))
DOWN = "9 of 10 cameras working; not working: cam03 (no frames)"


def _rig(down: str | None) -> list[CameraHealth]:
    return [CameraHealth(f"cam{i:02d}", 0.0 if f"cam{i:02d}" == down else 30.0, f"cam{i:02d}" != down,
                         "no frames" if f"cam{i:02d}" == down else "ok", 0.01) for i in range(1, 11)]


def _banner_cameras(page) -> str:
    line = page.locator('#system-list li[data-component="cameras"]')
    return line.inner_text() if line.count() else ""


def test_the_heading_and_the_banner_count_the_cameras_alike(server):
    srv, _, link, _ = server
    link.camera_list = _rig("cam03")
    with signed_in_page(srv.url, timeout_ms=15_000) as page:
        page.wait_for_selector('#system-list li[data-component="cameras"]')  # after the 3 s grace
        for width, height in WIDTHS:
            page.set_viewport_size({"width": width, "height": height})
            assert page.inner_text("#camera-summary") == DOWN
            assert _banner_cameras(page) == f"Cameras: {DOWN}"
            assert page.locator("#system").is_visible() and page.locator("#camera-summary").is_visible()
            assert "all working" not in page.inner_text("body")
        link.camera_list = _rig(None)
        page.wait_for_function("() => !document.querySelector('#system-list li[data-component=\"cameras\"]')")
        for width, height in WIDTHS:
            page.set_viewport_size({"width": width, "height": height})
            assert page.inner_text("#camera-summary") == "10 cameras, all working"
            assert "of 10" not in page.inner_text("body")
