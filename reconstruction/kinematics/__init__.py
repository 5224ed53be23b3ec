"""Joint kinematics as data and maths: the OpenSim frame, marker layouts per keypoint skeleton, joint-angle
conventions, gait-cycle curves, key clinical values, normative bands, MOT/C3D contents.

The model fit itself (OpenSim scaling and inverse kinematics) lives in ``gaitcap.services.kinematics``.
"""
