"""Trajectory fits: explicit (T x J x 3 points) and implicit (a function of time), optimised with Optax.

- :mod:`.common`: the fit problem (observations, weights, initial trajectory, gap filling).
- :mod:`.optim`: Adam (with the paper's schedule) and L-BFGS, run in jitted chunks.
- :mod:`.explicit`: points as free parameters.
- :mod:`.implicit`: a function of time: cubic B-splines (default, :mod:`.bspline`), Fourier features or
  the paper's MLP.
"""
