"""Helpers shared by the node tests (real Zenoh sessions on loopback): waiting for a condition with a
timeout that names what did not happen, and a noise renderer for simulated cameras."""

import time

import numpy as np


def wait_for(cond, timeout_s=20.0, what="condition", *, poll_s=0.05):
    """Return once ``cond()`` is true; AssertionError naming ``what`` after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(poll_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def noise_render(trial, camera_index, frame_index, size_px):
    """A simulated camera's image: reproducible noise (different for every camera and frame)."""
    rng = np.random.default_rng(camera_index * 10_000 + frame_index)
    return rng.integers(0, 255, (size_px[1], size_px[0], 3), dtype=np.uint8)
