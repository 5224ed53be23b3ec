"""Detectors for the detector pool tests, importable by name in the pool's spawned worker processes
(the test puts this folder on ``sys.path``, which spawned processes inherit)."""

import time

import numpy as np
from gaitcap.reconstruction.skeletons import get_skeleton


class SlowDetector:
    """One person at (frame id px, 20 px); takes ``delay_s`` per frame; fails to build when ``fail``."""

    skeleton = get_skeleton("coco17")

    def __init__(self, delay_s: float = 0.01, fail: bool = False):
        if fail:
            raise FileNotFoundError("model file missing: /nowhere/model.onnx")
        self.delay_s = delay_s

    def detect(self, image_bgr, *, camera, frame_id, timestamp_ns):
        time.sleep(self.delay_s)
        return np.tile([[float(frame_id), 20.0, 0.9]], (1, 17, 1))


class BatchDetector(SlowDetector):
    """Detects a batch at once; the person's y is the batch's size."""

    def detect_batch(self, images, *, cameras, frame_ids, timestamps_ns):
        time.sleep(self.delay_s)
        return [np.tile([[float(f), float(len(images)), 0.9]], (1, 17, 1)) for f in frame_ids]
