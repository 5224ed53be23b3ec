import numpy as np
import pytest
from gaitcap.reconstruction.fits import memory
from gaitcap.reconstruction.fits.bspline import BSplineBasis
from gaitcap.reconstruction.fits.implicit import FourierBasis
from gaitcap.reconstruction.fits.memory import TrialTooLarge, available_bytes, check_memory, fit_bytes
from gaitcap.reconstruction.methods import DLT, Explicit, Implicit, reconstruct


def test_check_memory_refuses_with_the_estimate_in_the_message():
    check_memory(1_000_000_000, what="x", available=2_000_000_000)
    with pytest.raises(TrialTooLarge, match=r"a 600 s trial needs about 3\.0 GB .* 2\.0 GB available"):
        check_memory(3_000_000_000, what="a 600 s trial", available=2_000_000_000)
    assert issubclass(TrialTooLarge, ValueError)  # the CLI and the worker report it as a user error


def test_this_machine_reports_its_available_memory():
    free = available_bytes()
    assert free is not None and 0 < free < 1 << 50


def test_estimates_grow_linearly_for_the_spline_and_quadratically_for_fourier():
    spline = [BSplineBasis().model_bytes(30 * s, s, 26) for s in (60.0, 600.0)]
    fourier = [FourierBasis().model_bytes(30 * s, s, 26) for s in (60.0, 600.0)]
    assert spline[1] / spline[0] == pytest.approx(10, rel=0.05)
    assert fourier[1] / fourier[0] > 50 and fourier[1] > 5e9  # what made 10-minute trials fail
    # the default fit of a 10-minute, 10-camera Halpe-26 trial is expected to fit in 2 GB
    assert fit_bytes(10, 18_000, 26, spline[1]) < 2e9


def test_reconstruct_refuses_up_front(scene, monkeypatch):
    rig, det, _ = scene(cameras=4, frames=30, noise_px=1.0)
    for method in (DLT(), Explicit(), Implicit()):
        assert method.memory_bytes(det) > memory.TRIANGULATION_BASE_BYTES
    monkeypatch.setattr(memory, "available_bytes", lambda: 100_000_000)
    with pytest.raises(TrialTooLarge, match=r"reconstructing 1 s \(30 frames x 4 cameras x 26 joints\) with the "
                                            r"implicit method needs about 0\.\d GB .* 0\.1 GB available"):
        reconstruct(det, rig)
    monkeypatch.setattr(memory, "available_bytes", lambda: 10_000_000_000)
    assert np.isfinite(reconstruct(det, rig, method=DLT()).points_mm).all()
