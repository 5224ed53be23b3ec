"""Implicit representation: the trajectory is a function of time, fitted to the detections.

Three models of time -> pose (J x 3 mm):

- :class:`~gaitcap.reconstruction.fits.bspline.BSplineBasis` (default): uniform cubic B-splines with
  knots at the band limit (8 Hz, 62.5 ms apart; the knees on a 12 Hz
  grid of their own by default: ``fast_max_freq_hz``, ``fast_joints``). Local support: each frame depends on 4 control points,
  so cost and memory grow linearly with the trial. The control points start at the banded penalised
  least-squares fit to the robust triangulation, then L-BFGS minimises the paper's loss.
- :class:`FourierBasis`: a linear model on band-limited global time features [1, tau, cos(pi k tau),
  sin(pi k tau)] (tau = time scaled to [0, 1] over the trial, harmonics up to ``max_freq_hz``), started at
  the ridge least-squares fit. As accurate on short trials, but its feature matrix is frames x (4 x
  ``max_freq_hz`` x duration): time and memory grow with the square of the trial.
  Band-limiting plus the skeleton term is what removes detector noise; neither linear model can represent
  faster jitter, so they need no early stopping.
- :class:`PaperMLP`: the paper's network (positional encoding of t in [0, pi] with 6 octaves fed to each
  of the first four layers, Dense-LayerNorm-ReLU layers 128..2048, output x 1000 mm), trained from
  random initialisation with the paper's schedule. Faithful reference; slow on a CPU.

Either way the result is a callable: ``trajectory(times_s) -> (K, J, 3) mm`` at any times in the span.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.fits.bspline import BSplineBasis
from gaitcap.reconstruction.fits.common import FitOutput, check_span, from_fit_layout
from gaitcap.reconstruction.fits.optim import LBFGS, Adam, Progress, Solver, WarmupHoldDecay
from gaitcap.reconstruction.losses import LossConfig, Problem, total_loss

MM_PER_M = 1000.0


# ----------------------------------------------------------------------------- Fourier basis


@dataclass(frozen=True)
class FourierBasis:
    """Band-limited linear time model. ``ridge`` is relative to the mean diagonal of Phi^T Phi."""

    max_freq_hz: float = 6.0
    ridge: float = 1e-3

    def harmonics(self, duration: float) -> int:
        return max(int(math.floor(self.max_freq_hz * 2 * duration)), 0)

    def model_bytes(self, frames: int, duration_s: float, joints: int) -> int:
        """Bytes of the features (frames x F float64, and a temporary) and the Gram matrix (F x F):
        quadratic in the trial, F = 2 + 4 x max_freq_hz x duration. Measured: 1.9 GB beyond the fit's
        linear part at 360 s (3.15 GB peak in all); this gives 2.1 GB."""
        f = 2 + 2 * self.harmonics(duration_s)
        return 8 * (2 * frames * f + f * f)

    def features(self, times_s: np.ndarray, t0: float, duration: float) -> np.ndarray:
        """(K,) s -> (K, F) features."""
        tau = (np.asarray(times_s, dtype=np.float64) - t0) / duration
        k = np.arange(1, self.harmonics(duration) + 1)
        ang = np.pi * tau[:, None] * k[None]
        return np.concatenate([np.ones_like(tau)[:, None], tau[:, None], np.cos(ang), np.sin(ang)], 1)

    def init(self, times_s: np.ndarray, init_mm: np.ndarray, key, *, joint_names=()):
        """Weights, features and span (``joint_names``: unused, every joint has the same basis)."""
        t0, duration = float(times_s[0]), max(float(times_s[-1] - times_s[0]), 1e-3)
        phi = self.features(times_s, t0, duration)
        t, j, _ = init_mm.shape
        target = np.transpose(init_mm, (0, 2, 1)).reshape(t, 3 * j) / MM_PER_M  # (T, 3J), column k*J + j
        gram = phi.T @ phi
        lam = self.ridge * float(np.mean(np.diag(gram)))
        weights = np.linalg.solve(gram + lam * np.eye(len(gram)), phi.T @ target)
        return jnp.asarray(weights, jnp.float32), jnp.asarray(phi, jnp.float32), (t0, duration)

    @staticmethod
    def points(weights, phi):
        """weights (F, 3J) m, phi (T, F) -> points (3, T, J) mm."""
        out = MM_PER_M * (phi @ weights)
        t = phi.shape[0]
        return out.reshape(t, 3, -1).transpose(1, 0, 2)

    def trajectory(self, params, span, num_joints: int):
        return FourierTrajectory(self, span[0], span[1], np.asarray(params, dtype=np.float64), num_joints)


@dataclass(frozen=True, eq=False)
class FourierTrajectory:
    """A fitted Fourier trajectory: call with times (K,) s -> (K, J, 3) mm."""

    basis: FourierBasis
    t0: float
    duration: float
    weights_m: np.ndarray  # (F, 3J)
    num_joints: int

    def __call__(self, times_s) -> np.ndarray:
        t = check_span(times_s, self.t0, self.duration)
        out = MM_PER_M * (self.basis.features(t, self.t0, self.duration) @ self.weights_m)
        return out.reshape(len(t), 3, self.num_joints).transpose(0, 2, 1)


# ----------------------------------------------------------------------------- the paper's MLP


@dataclass(frozen=True)
class PaperMLP:
    """The paper's implicit network (see the module docstring)."""

    widths: tuple[int, ...] = (128, 256, 512, 1024, 2048)
    octaves: int = 6
    skip_layers: int = 4
    output_scale_mm: float = 1000.0
    seed: int = 0

    def model_bytes(self, frames: int, duration_s: float, joints: int) -> int:
        """Bytes of the activations kept for the backward pass (float32, 4 per unit) and the weights."""
        return 4 * 4 * frames * (sum(self.widths) + 3 * joints) + 4 * 4 * (max(self.widths) ** 2) * len(self.widths)

    def encode(self, tin):
        """tin (T, 1) in [0, pi] -> (T, 1 + 2 * octaves)."""
        f = 2.0 ** jnp.arange(self.octaves, dtype=tin.dtype)
        return jnp.concatenate([tin, jnp.sin(tin * f), jnp.cos(tin * f)], -1)

    def init_params(self, num_joints: int):
        key = jax.random.PRNGKey(self.seed)
        pe = 1 + 2 * self.octaves
        layers, width_in = [], pe
        for i, w in enumerate(self.widths):
            key, sub = jax.random.split(key)
            fan_in = width_in + (pe if 0 < i < self.skip_layers else 0)
            kernel = jax.random.normal(sub, (fan_in, w)) / jnp.sqrt(fan_in)  # LeCun normal
            layers.append({"w": kernel, "b": jnp.zeros(w), "scale": jnp.ones(w), "bias": jnp.zeros(w)})
            width_in = w
        key, sub = jax.random.split(key)
        out = {"w": jax.random.normal(sub, (width_in, 3 * num_joints)) / jnp.sqrt(width_in),
               "b": jnp.zeros(3 * num_joints)}
        return {"layers": layers, "out": out}

    def init(self, times_s: np.ndarray, init_mm: np.ndarray, key, *, joint_names=()):
        """Parameters, inputs and span (``joint_names``: unused, one network for every joint)."""
        t0, duration = float(times_s[0]), max(float(times_s[-1] - times_s[0]), 1e-3)
        tin = jnp.asarray(np.pi * (times_s - t0) / duration, jnp.float32)[:, None]
        return self.init_params(init_mm.shape[1]), tin, (t0, duration)

    def points(self, params, tin):
        """tin (T, 1) -> points (3, T, J) mm."""
        pe = self.encode(tin)
        h = pe
        for i, layer in enumerate(params["layers"]):
            if 0 < i < self.skip_layers:
                h = jnp.concatenate([h, pe], -1)
            h = h @ layer["w"] + layer["b"]
            mu = jnp.mean(h, -1, keepdims=True)
            var = jnp.mean((h - mu) ** 2, -1, keepdims=True)
            h = jax.nn.relu((h - mu) * jax.lax.rsqrt(var + 1e-6) * layer["scale"] + layer["bias"])
        out = self.output_scale_mm * (h @ params["out"]["w"] + params["out"]["b"])
        return out.reshape(tin.shape[0], -1, 3).transpose(2, 0, 1)

    def trajectory(self, params, span, num_joints: int):
        return MLPTrajectory(self, span[0], span[1], params)


@dataclass(frozen=True, eq=False)
class MLPTrajectory:
    """A fitted paper-MLP trajectory: call with times (K,) s -> (K, J, 3) mm."""

    model: PaperMLP
    t0: float
    duration: float
    params: dict

    def __call__(self, times_s) -> np.ndarray:
        t = check_span(times_s, self.t0, self.duration)
        tin = jnp.asarray(np.pi * (t - self.t0) / self.duration, jnp.float32)[:, None]
        return from_fit_layout(jax.jit(self.model.points)(self.params, tin))


# ----------------------------------------------------------------------------- the fit

Model = BSplineBasis | FourierBasis | PaperMLP


@dataclass(frozen=True)
class _ModelObjective:
    model: Model
    loss: LossConfig

    def __call__(self, params, data, reg_scale):
        problem, features = data
        return total_loss(self.model.points(params, features), problem, self.loss, reg_scale)


@lru_cache(maxsize=16)
def evaluate(objective: _ModelObjective, model: Model):
    """Jitted (params, data) -> (points (3, T, J), loss terms): one compile instead of eager op-by-op."""

    @jax.jit
    def run(params, data):
        _, parts = objective(params, data, 1.0)
        return model.points(params, data[1]), parts

    return run


def _fast_loss() -> LossConfig:
    return LossConfig(cut_px=10.0, smooth_weight=0.3, skeleton_weight=0.3)


@dataclass(frozen=True)
class ImplicitFit:
    """Fit a time function to the detections.

    Default: cubic B-splines with knots 62.5 ms apart (8 Hz band limit), banded least-squares start,
    150 L-BFGS iterations on the paper's loss terms with the Huber slope cut beyond 10 px and both
    regularisers weighted 0.3 (the paper: 0.1; see docs/methods.md for the measurements behind this). :meth:`paper`: the paper's MLP, schedule, weights and 50k
    Adam steps.
    """

    model: Model = field(default_factory=BSplineBasis)
    solver: Solver = field(default_factory=lambda: LBFGS(iterations=150))
    loss: LossConfig = field(default_factory=_fast_loss)

    @classmethod
    def paper(cls, steps: int = 50_000) -> ImplicitFit:
        """The paper's MLP, schedule and step count. For ``steps`` other than 50k the schedule keeps the
        paper's proportions: warm-up 2 %, regularisers on and decay from 10 %, early stop allowed from 80 %.
        """
        schedule = WarmupHoldDecay(warmup_steps=max(steps // 50, 1), decay_start=max(steps // 10, 1), total_steps=steps)
        solver = Adam(
            learning_rate=schedule, steps=steps, reg_start=steps // 10, clip_norm=1.0,
            early_stop_after=(steps * 4) // 5, chunk=100,
        )
        return cls(model=PaperMLP(), solver=solver, loss=LossConfig())

    def fit(self, problem: Problem, init_mm: np.ndarray, times_s: np.ndarray, progress: Progress | None = None,
            *, joint_names: tuple[str, ...] = ()):
        """init_mm: (T, J, 3) NaN-free (the robust triangulation); ``joint_names`` (J,): the skeleton's
        (a B-spline model with ``fast_max_freq_hz`` gives its ``fast_joints`` their own grid by name). Returns
        :class:`FitOutput`."""
        params, features, span = self.model.init(times_s, init_mm, None, joint_names=joint_names)
        objective = _ModelObjective(self.model, self.loss)
        params, history = self.solver.minimize(objective, params, (problem, features), progress)
        points, parts = evaluate(objective, self.model)(params, (problem, features))
        points = from_fit_layout(points)
        traj = self.model.trajectory(params, span, init_mm.shape[1])
        return FitOutput(points, history, {k: float(v) for k, v in parts.items()}, traj)
