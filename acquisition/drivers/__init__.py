"""Camera drivers behind one small protocol (:mod:`gaitcap.acquisition.drivers.base`).

- :mod:`gaitcap.acquisition.drivers.flir`: FLIR Spinnaker cameras through PySpin (PTP, scheduled action start).
- :mod:`gaitcap.acquisition.drivers.simulated`: the synthetic world rendered from each rig camera.
- :mod:`gaitcap.acquisition.drivers.video`: video files and webcams through OpenCV.
"""
