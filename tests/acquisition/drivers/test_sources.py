import importlib.util
import sys
from pathlib import Path

import pytest
from gaitcap.acquisition.drivers.simulated import SimTrialSpec
from gaitcap.acquisition.drivers.sources import FlirSource, SimulatedSource


def _fake_pyspin():
    spec = importlib.util.spec_from_file_location("fake_pyspin_src", Path(__file__).parent / "fake_pyspin.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["fake_pyspin_src"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_flir_source_opens_configures_and_waits_for_ptp(monkeypatch):
    fake = _fake_pyspin()
    fake.reset({"11": fake.Behaviour(ptp_polls_until_lock=0), "12": fake.Behaviour(ptp_polls_until_lock=0)})
    monkeypatch.setitem(sys.modules, "PySpin", fake)
    cams = FlirSource(serials=("11", "12"), names=("left", "right"), fps=25, exposure_us=8000,
                      trigger_source="Line0").build()
    assert [c.name for c in cams] == ["left", "right"] and all(c.status().state == "configured" for c in cams)
    assert ("cam:12", "AcquisitionFrameRate", 25.0) in fake.calls
    assert ("cam:11", "TriggerSource", "TriggerSource_Line0") in fake.calls
    with pytest.raises(ValueError, match="2 names for 1 serials"):
        FlirSource(serials=("11",), names=("a", "b")).build()
    with pytest.raises(ValueError, match="--serials"):
        FlirSource().build()


def test_simulated_source_builds_the_named_cameras():
    src = SimulatedSource(spec=SimTrialSpec(seconds=5.0, cameras=3, seed=5), cameras=["cam02"], size_px=(40, 30),
                          drops=("cam02:1",), max_frames=4, realtime=False)
    (cam,) = src.build()
    cam.start(0)
    frames = list(cam.frames())
    assert cam.name == "cam02" and [f.frame_id for f in frames] == [0, 2, 3]
    assert frames[0].image.shape == (30, 40, 3)  # rendered by the synthetic world
