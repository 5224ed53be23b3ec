"""OpenCV's lens distortion (k1, k2, p1, p2, k3), written once for every backend.

The functions use arithmetic only, so the same code runs on NumPy and JAX arrays (and on Python floats):
:class:`~gaitcap.reconstruction.camera.Camera` (NumPy, one camera), :mod:`~gaitcap.reconstruction.projection`
(JAX, cameras-first), the association's ray casting and the calibration's bundle adjustment all call
them. Coordinates are normalised image coordinates (x/z, y/z; dimensionless); the coefficients broadcast
against them (scalars for one camera, (C, 1) columns for cameras-first arrays).
"""

from __future__ import annotations


def radial_factor(r2, k1, k2, k3):
    """1 + k1 r^2 + k2 r^4 + k3 r^6 for the squared radius ``r2`` (Horner form)."""
    return 1 + r2 * (k1 + r2 * (k2 + r2 * k3))


def tangential(x, y, r2, p1, p2):
    """The tangential shift (dx, dy) of OpenCV's model at (x, y) with r^2 = ``r2``."""
    return 2 * p1 * x * y + p2 * (r2 + 2 * x * x), p1 * (r2 + 2 * y * y) + 2 * p2 * x * y


def distort(x, y, k1, k2, p1, p2, k3):
    """Distorted normalised coordinates (xd, yd) of undistorted (x, y)."""
    r2 = x * x + y * y
    radial = radial_factor(r2, k1, k2, k3)
    dx, dy = tangential(x, y, r2, p1, p2)
    return x * radial + dx, y * radial + dy


def undistort_step(x, y, xd, yd, k1, k2, p1, p2, k3):
    """One step of OpenCV's fixed-point inversion of :func:`distort`: the next estimate of (x, y) whose
    distortion is (xd, yd). Start at (xd, yd); about ten steps converge for lenses of this kind."""
    r2 = x * x + y * y
    inv_radial = 1.0 / radial_factor(r2, k1, k2, k3)
    dx, dy = tangential(x, y, r2, p1, p2)
    return (xd - dx) * inv_radial, (yd - dy) * inv_radial
