import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.drivers.base import CaptureSettings
from gaitcap.acquisition.drivers.flir import FlirSystem, GigESettings, PySpinMissing, import_pyspin, to_bgr


def _load_fake():
    spec = importlib.util.spec_from_file_location("fake_pyspin", Path(__file__).parent / "fake_pyspin.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["fake_pyspin"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


fake = _load_fake()
GIGE = GigESettings(packet_size=9000, packet_delay=4500, frame_timeout_ms=5, stall_timeouts=3)


def _rig(behaviours, names=None):
    fake.reset(behaviours)
    system = FlirSystem(pyspin=fake)
    cams = system.cameras(list(behaviours), names=names, gige=GIGE)
    settings = CaptureSettings(fps=30, exposure_us=15000, pixel_format="BayerRG8")
    for c in cams:
        c.open()
        c.configure(settings)
    return system, cams


def _set(serial, node):
    return [v for owner, name, v in fake.calls if owner == f"cam:{serial}" and name == node]


def test_missing_pyspin_has_a_clear_message(monkeypatch):
    monkeypatch.setitem(sys.modules, "PySpin", None)
    with pytest.raises(PySpinMissing, match="Spinnaker SDK"):
        import_pyspin()


def test_lazy_import_uses_the_installed_module(monkeypatch):
    monkeypatch.setitem(sys.modules, "PySpin", fake)
    fake.reset({"1": fake.Behaviour()})
    assert FlirSystem().serials() == ["1"]


def test_configure_sets_the_labs_settings_in_order():
    _rig({"1001": fake.Behaviour(), "1002": fake.Behaviour()})
    assert _set("1001", "ExposureAuto") == ["ExposureAuto_Off"]
    assert _set("1001", "ExposureTime") == [15000.0]
    assert _set("1001", "AcquisitionFrameRate") == [30.0]
    assert _set("1001", "GevSCPSPacketSize") == [9000] and _set("1002", "GevSCPD") == [4500]
    assert _set("1002", "PixelFormat") == ["PixelFormat_BayerRG8"]
    assert _set("1002", "GevIEEE1588") == [True]
    assert _set("1001", "TriggerSource") == ["TriggerSource_Action0"]
    assert _set("1001", "TriggerMode") == ["TriggerMode_Off", "TriggerMode_On"]  # trigger set while off
    seq = [n for o, n, _ in fake.calls if o == "cam:1001"]
    assert seq.index("ExposureAuto") < seq.index("ExposureTime")
    assert seq.index("AcquisitionFrameRateEnable") < seq.index("AcquisitionFrameRate")
    assert seq.index("Init") == 0
    assert _set("1001:TLStream", "StreamBufferHandlingMode") == ["StreamBufferHandlingMode_OldestFirst"]


def test_unknown_serial_and_pixel_format_are_named():
    fake.reset({"1001": fake.Behaviour()})
    system = FlirSystem(pyspin=fake)
    with pytest.raises(ValueError, match=r"\['999'\].*found \['1001'\]"):
        system.cameras(["999"])
    cam = system.cameras(["1001"])[0]
    cam.open()
    with pytest.raises(ValueError, match="BayerXY8"):
        cam.configure(CaptureSettings(pixel_format="BayerXY8"))


def test_waits_for_ptp_lock_and_times_out_naming_states():
    system, cams = _rig({"1001": fake.Behaviour(ptp_polls_until_lock=3), "1002": fake.Behaviour()})
    sleeps = []
    states = system.wait_ptp_locked(cams, sleep=sleeps.append, poll_s=0.1)
    assert states == {"1001": "Master", "1002": "Slave"} and len(sleeps) == 3
    system, cams = _rig({"1001": fake.Behaviour(ptp_polls_until_lock=10**6)})
    t = iter(range(100))
    with pytest.raises(ValueError, match="PTP not locked.*Listening"):
        system.wait_ptp_locked(cams, timeout_s=3, clock=lambda: next(t), sleep=lambda s: None)


def test_synchronised_start_by_one_scheduled_action_command():
    system, cams = _rig({"1001": fake.Behaviour(frames=3), "1002": fake.Behaviour(frames=3)}, names=["a", "b"])
    before = fake.ptp_now_ns()
    cams[0].start()
    assert not [c for c in fake.calls if c[1] == "ActionCommand"]  # waits until every camera is armed
    cams[1].start()
    actions = [c for c in fake.calls if c[1] == "ActionCommand"]
    assert len(actions) == 1
    at = system.action_time_ns
    assert before + 0.2e9 < at < fake.ptp_now_ns() + 0.3e9  # ~250 ms ahead on the cameras' PTP clock
    begin = [i for i, c in enumerate(fake.calls) if c[1] == "BeginAcquisition"]
    assert max(begin) < fake.calls.index(actions[0])
    frames = {c.name: list(c.frames()) for c in cams}
    assert [f.timestamp_ns for f in frames["a"]] == [at + i * 33_333_333 for i in range(3)]
    assert [f.frame_id for f in frames["b"]] == [0, 1, 2]
    np.testing.assert_array_equal(frames["a"][0].image[2, 2], [0, 0, 255])  # Bayer RGGB -> BGR red
    assert _set("1001", "EndAcquisition") == [None]


def test_gaps_incomplete_jumps_and_a_stalled_camera():
    b = fake.Behaviour(frames=8, drop_ids={2, 3}, incomplete_ids={5}, jump_at=7)
    system, cams = _rig({"1001": b})
    cam = cams[0]
    cam.start()
    frames = list(cam.frames())
    assert [f.frame_id for f in frames] == [0, 1, 4, 6, 7]
    assert [f.ptp_jump for f in frames] == [False, False, False, False, True]
    st = cam.status()
    assert st.drops == 3 and st.extra["incomplete"] == 1 and st.ptp_jumps == 1
    assert st.state == "error" and "no frame" in st.error  # ran dry: 3 timeouts in a row
    released = [v for o, n, v in fake.calls if n == "Image.Release"]
    assert len(released) == 6  # every image handed out is released, incomplete included
    system.release()
    assert ("system", "ReleaseInstance", None) in fake.calls


@pytest.mark.parametrize("fmt,raw_shape", [("Mono8", (4, 6)), ("RGB8", (4, 6, 3)), ("BGR8", (4, 6, 3))])
def test_to_bgr_formats(fmt, raw_shape):
    raw = np.full(raw_shape, 7, np.uint8)
    assert to_bgr(raw, fmt).shape == (4, 6, 3)


def test_hardware_trigger_sends_no_action_command():
    fake.reset({"1001": fake.Behaviour(frames=2)})
    system = FlirSystem(pyspin=fake)
    cam = system.cameras(["1001"], gige=GigESettings(trigger_source="Line0", frame_timeout_ms=5, stall_timeouts=2))[0]
    cam.open()
    cam.configure(CaptureSettings())
    cam.start()
    assert _set("1001", "TriggerSource") == ["TriggerSource_Line0"]
    assert not [c for c in fake.calls if c[1] == "ActionCommand"] and system.action_time_ns is None
    with pytest.raises(ValueError, match="Line9"):
        bad = system.cameras(["1001"], gige=GigESettings(trigger_source="Line9"))[0]
        bad.configure(CaptureSettings())
