import numpy as np
from gaitcap.reconstruction.calibration.report import coverage, error_stats, triangulate_normalized


def test_triangulation_is_exact_and_needs_two_views():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-500, 500, (10, 3)) + [0, 0, 3000]
    extr = np.array([np.hstack([np.eye(3), np.zeros((3, 1))]),
                     np.hstack([np.eye(3), [[-800.0], [0], [0]]]),
                     np.hstack([np.eye(3), [[0.0], [600], [0]]])])
    xy = np.stack([(pts + e[:, 3])[:, :2] / (pts + e[:, 3])[:, 2:] for e in extr])
    xy[1:, 0] = np.nan  # point 0 seen by one camera only
    xy[2, 1] = np.nan
    out = triangulate_normalized(xy, extr)
    assert np.isnan(out[0]).all()
    assert np.allclose(out[1:], pts[1:], atol=1e-6)


def test_coverage_and_stats():
    uv = np.array([[10.0, 10.0], [630.0, 470.0], [12.0, 15.0]])
    assert coverage(uv, (640, 480), (4, 2)) == 2 / 8
    mean, p95, rms = error_stats(np.array([3.0, 4.0]))
    assert mean == 3.5 and rms == np.sqrt(12.5) and 3.9 < p95 <= 4.0
