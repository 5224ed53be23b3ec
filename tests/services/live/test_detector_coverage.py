"""Live detection coverage as the API sees it: the detector nodes' status messages over a real bus."""

import time

import pytest
from gaitcap.services.bus.messages import DetectorStatus
from gaitcap.services.bus.session import BusConfig, open_session
from gaitcap.services.live.bus_link import BusLink
from gaitcap.services.live.detector_coverage import STALE_S, detection_summary

ROW = {"received": 90, "detected": 60, "skipped": 30, "lost": 0, "failed": 0, "lag_s": 0.4}


def _status(node, cameras, workers=2):
    return DetectorStatus(node=node, time_ns=time.time_ns(), workers=workers, pool=2, cameras=cameras)


def test_summary_per_camera_and_node():
    now = time.time()
    latest = {"detector-0": (now - 1, _status("detector-0", {"cam01": ROW, "cam02": {**ROW, "received": 10}})),
              "detector-1": (now - STALE_S - 1, _status("detector-1", {"cam02": ROW}, workers=1))}
    got = detection_summary(latest, now)
    assert got["nodes"]["detector-0"]["stale"] is False and got["nodes"]["detector-1"]["stale"] is True
    assert got["cameras"]["cam01"] == {"node": "detector-0", **ROW, "coverage": pytest.approx(2 / 3, abs=1e-4)}
    assert got["cameras"]["cam02"]["node"] == "detector-1"  # moved: the node that saw more of it


def test_bad_status_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"detector status.cameras.cam01.detected"):
        _status("detector-0", {"cam01": {**ROW, "detected": -1}})
    with pytest.raises(ValueError, match=r"unknown fields \['secret'\]"):
        _status("detector-0", {"cam01": {**ROW, "secret": 1}})


def test_the_link_reports_what_the_detector_nodes_publish_and_drops_a_status_on_another_nodes_key(caplog):
    bus = BusConfig.free_local(["api", "detector-0"], prefix="gaitcap/cov")
    sd = open_session(bus, "detector-0")
    link = BusLink(bus, node="api")
    key = bus.keys.detector_status("detector-0")
    try:
        end = time.monotonic() + 10
        while time.monotonic() < end and "cam01" not in link.detection()["cameras"]:
            sd.put(key, _status("detector-1", {"cam02": ROW}).to_bytes())  # on detector-0's key
            sd.put(key, b"{not json")
            sd.put(key, _status("detector-0", {"cam01": ROW}).to_bytes())
            time.sleep(0.1)
        got = link.detection()
        assert got["cameras"]["cam01"]["detected"] == 60 and got["nodes"]["detector-0"]["workers"] == 2
        assert list(got["nodes"]) == ["detector-0"] and list(got["cameras"]) == ["cam01"]
        dropped = {r.getMessage() for r in caplog.records if r.getMessage().startswith("dropping a detector status")}
        assert {m.split(" (Expecting")[0] for m in dropped} == {
            f"dropping a detector status: detector status of node detector-1 on {key} (the key of node detector-0)",
            "dropping a detector status: detector status: payload is not JSON"}, dropped
    finally:
        link.close()
        sd.close()
