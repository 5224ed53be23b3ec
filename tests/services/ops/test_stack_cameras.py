"""The demo stack's simulated cameras shared among camera processes on one synchronised frame count."""

import pytest
from gaitcap.services.ops.stack import StackConfig, bus_config, process_specs

TOKEN = "stack-config-test-token"


def _arg(argv: tuple[str, ...], flag: str) -> str | None:
    return argv[argv.index(flag) + 1] if flag in argv else None


def test_cameras_are_dealt_to_the_camera_processes_which_share_one_start():
    cfg = StackConfig(token=TOKEN, cameras=10, camera_nodes=3)
    specs = {s.name: s for s in process_specs(cfg, epoch_ns=123_000)}
    cams = {n: _arg(specs[n].argv, "--cameras").split(",") for n in ("camera-0", "camera-1", "camera-2")}
    assert cams["camera-0"] == ["cam01", "cam04", "cam07", "cam10"] and cams["camera-2"] == ["cam03", "cam06", "cam09"]
    assert sorted(c for share in cams.values() for c in share) == [f"cam{i:02d}" for i in range(1, 11)]
    assert {_arg(specs[n].argv, "--cycle-epoch-ns") for n in cams} == {"123000"}
    assert all(specs[n].nice == cfg.camera_nice for n in cams) and "camera-3" not in specs
    assert {"camera-0", "camera-1", "camera-2"} <= set(bus_config(cfg).nodes)


def test_one_camera_process_keeps_its_own_start():
    specs = {s.name: s for s in process_specs(StackConfig(token=TOKEN, cameras=4, camera_nodes=1), epoch_ns=5)}
    assert _arg(specs["camera-0"].argv, "--cameras") == "cam01,cam02,cam03,cam04"
    assert "--cycle-epoch-ns" not in specs["camera-0"].argv


@pytest.mark.parametrize("nodes", [0, 5])
def test_camera_processes_out_of_range_are_refused(nodes):
    with pytest.raises(ValueError, match="camera_nodes: need 1..4"):
        StackConfig(token=TOKEN, cameras=4, camera_nodes=nodes)
