"""Joint kinematics of a trial: an OpenSim model scaled to the patient and inverse kinematics over the
trial, behind a small engine interface (``engine.get_engine``); when the engine or its setup files are
missing, :class:`KinematicsUnavailable` says why and the rest of gaitcap works without kinematics.

Modules: ``files`` (where the model, setups and norms are installed), ``base`` (the interface),
``engine`` (the registry), ``opensim_engine`` (scaling and IK with the ``opensim`` package), ``c3d_file`` (C3D writer),
``trial`` (one trial's kinematics files). The maths (cycles, clinical values, norms, file contents) is in
``gaitcap.reconstruction.kinematics``.
"""

from gaitcap.services.kinematics.base import KinematicsUnavailable, ModelFit
from gaitcap.services.kinematics.engine import availability, get_engine

__all__ = ["KinematicsUnavailable", "ModelFit", "availability", "get_engine"]
