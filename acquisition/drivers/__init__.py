"""Camera drivers behind one small protocol (:mod:`acquisition.drivers.base`).

- :mod:`acquisition.drivers.flir`: FLIR Spinnaker cameras through PySpin (PTP, scheduled action start).
- :mod:`acquisition.drivers.simulated`: the synthetic world rendered from each rig camera.
- :mod:`acquisition.drivers.video`: video files and webcams through OpenCV.
"""
