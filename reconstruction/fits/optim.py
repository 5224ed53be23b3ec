"""Optimisers shared by the trajectory fits (Optax), run in jitted chunks of steps.

An objective is a hashable callable ``objective(params, data, reg_scale) -> (loss, parts)``; ``data``
is a pytree passed to the jitted step as an argument (never a closure constant, which XLA would fold
at great compile cost). Each solver is a frozen config with ``minimize(objective, params, data,
progress=None) -> (params, history)``; ``history`` has the loss per step (Adam) or per iteration.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np
import optax

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]  # (steps done, steps total)


def _strong(tree):
    """Optimiser state with weak types made strong, so the jitted step's second call does not retrace
    (its outputs are strongly typed) and compile everything a second time."""
    return jax.tree.map(lambda x: jnp.array(x, dtype=x.dtype), tree)


@dataclass(frozen=True)
class WarmupHoldDecay:
    """The paper's implicit schedule: linear warm-up init -> peak, hold, exponential decay to end."""

    init: float = 1e-6
    peak: float = 1e-4
    warmup_steps: int = 1000
    decay_start: int = 5000
    end: float = 1e-6
    total_steps: int = 50_000

    def schedule(self) -> optax.Schedule:
        warm = optax.linear_schedule(self.init, self.peak, self.warmup_steps)
        hold = optax.constant_schedule(self.peak)
        decay_steps = max(self.total_steps - self.decay_start, 1)
        decay = optax.exponential_decay(self.peak, decay_steps, self.end / self.peak, end_value=self.end)
        return optax.join_schedules([warm, hold, decay], [self.warmup_steps, self.decay_start])


@dataclass(frozen=True)
class Adam:
    """Adam (then zero_nans and global-norm clipping, as the authors' code chains them).

    Attributes:
        learning_rate: constant, or a :class:`WarmupHoldDecay` schedule.
        steps: number of steps.
        reg_start: step from which the smoothness and skeleton terms are on (the paper: 5000).
        clip_norm: global-norm clip of the updates (None: no clipping).
        early_stop_after: from this step on, stop once the relative loss change over
            ``early_stop_window`` steps is below ``early_stop_rel`` (None: never).
        chunk: steps per jitted call (progress is reported between chunks).
    """

    learning_rate: float | WarmupHoldDecay = 1e-3
    steps: int = 300
    reg_start: int = 0
    clip_norm: float | None = None
    early_stop_after: int | None = None
    early_stop_window: int = 150
    early_stop_rel: float = 1e-7
    chunk: int = 50

    def transform(self) -> optax.GradientTransformation:
        lr = self.learning_rate
        lr = lr.schedule() if isinstance(lr, WarmupHoldDecay) else lr
        parts = [optax.adam(lr), optax.zero_nans()]
        if self.clip_norm is not None:
            parts.append(optax.clip_by_global_norm(self.clip_norm))
        return optax.chain(*parts)

    def minimize(self, objective, params, data, progress: Progress | None = None):
        opt = self.transform()
        run = _adam_chunk(objective, self, min(self.chunk, self.steps))
        state = _strong(opt.init(params))
        history: list[np.ndarray] = []
        done = 0
        t0 = time.perf_counter()
        while done < self.steps:
            n = min(self.chunk, self.steps - done)
            if n != min(self.chunk, self.steps):
                run = _adam_chunk(objective, self, n)
            params, state, losses = run(params, state, data, jnp.asarray(done))
            history.append(np.asarray(losses))
            done += n
            if progress is not None:
                progress(done, self.steps)
            if self._should_stop(np.concatenate(history), done):
                log.info("early stop at step %d", done)
                break
        log.debug("adam: %d steps in %.2f s", done, time.perf_counter() - t0)
        return params, np.concatenate(history) if history else np.zeros(0)

    def _should_stop(self, losses: np.ndarray, done: int) -> bool:
        if self.early_stop_after is None or done < self.early_stop_after:
            return False
        w = self.early_stop_window
        if len(losses) <= w:
            return False
        old, new = losses[-w - 1], losses[-1]
        return abs(old - new) / max(abs(old), 1e-12) < self.early_stop_rel


@lru_cache(maxsize=32)
def _adam_chunk(objective, solver: Adam, n_steps: int):
    opt = solver.transform()

    def one(carry, step):
        params, state, data = carry
        reg = (step >= solver.reg_start).astype(jnp.float32)
        (loss, _), grad = jax.value_and_grad(objective, has_aux=True)(params, data, reg)
        updates, state = opt.update(grad, state, params)
        return (optax.apply_updates(params, updates), state, data), loss

    @jax.jit
    def run(params, state, data, step0):
        (params, state, _), losses = jax.lax.scan(one, (params, state, data), step0 + jnp.arange(n_steps))
        return params, state, losses

    return run


@dataclass(frozen=True)
class LBFGS:
    """L-BFGS with Optax's zoom line search; stops early when the relative loss change per iteration
    stays below ``rel_tol`` for a whole chunk."""

    iterations: int = 150
    memory: int = 10
    rel_tol: float = 1e-7
    chunk: int = 10

    def minimize(self, objective, params, data, progress: Progress | None = None):
        opt = optax.lbfgs(memory_size=self.memory)
        state = _strong(opt.init(params))
        run = _lbfgs_chunk(objective, self.memory, self.chunk)
        history: list[np.ndarray] = []
        done = 0
        while done < self.iterations:
            params, state, losses = run(params, state, data)
            losses = np.asarray(losses)
            history.append(losses)
            done += self.chunk
            if progress is not None:
                progress(min(done, self.iterations), self.iterations)
            rel = np.abs(np.diff(np.concatenate(history)[-self.chunk - 1 :])) / np.maximum(np.abs(losses[-1]), 1e-12)
            if len(rel) and np.all(rel < self.rel_tol):
                break
        return params, np.concatenate(history)


@lru_cache(maxsize=32)
def _lbfgs_chunk(objective, memory: int, n_steps: int):
    opt = optax.lbfgs(memory_size=memory)

    @jax.jit
    def run(params, state, data):
        def value(p):
            return objective(p, data, 1.0)[0]

        value_and_grad = optax.value_and_grad_from_state(value)

        def one(carry, _):
            params, state = carry
            loss, grad = value_and_grad(params, state=state)
            updates, state = opt.update(grad, state, params, value=loss, grad=grad, value_fn=value)
            return (optax.apply_updates(params, updates), state), loss

        (params, state), losses = jax.lax.scan(one, (params, state), None, length=n_steps)
        return params, state, losses

    return run


Solver = Adam | LBFGS
