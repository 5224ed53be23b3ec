"""How much memory a reconstruction needs, and refusing one the machine cannot hold (before it starts).

A reconstruction's peak memory (a whole ``gaitcap reconstruct`` process: Python, NumPy, JAX with its
compiled code, the detections, the triangulation, the fit) is close to linear in the number of 2D
observations C x T x J: a fixed part plus bytes per observation measured with ``bench/scaling.py``
(10 cameras, 26 joints, 30 fps, 30 to 600 s). The Fourier time model adds a frames x features matrix and
its Gram matrix (quadratic in the trial), the paper's MLP its activations. Estimates are rounded up.

The memory the machine has is the smallest of MemAvailable (/proc/meminfo) and the control group's
limit minus its use (cgroup v2 or v1); unknown (None) on systems without either, where nothing is refused.
"""

from __future__ import annotations

from pathlib import Path

# Fitted to bench/scaling.py (2026-11-24: 30/120/360/600 s, peaks 0.45-0.98 GB triangulating, 0.69-1.56 GB
# fitting); each estimate is within 5 % of those peaks or above them.
TRIANGULATION_BASE_BYTES = 480_000_000  # Python, NumPy, JAX and the compiled triangulation
TRIANGULATION_BYTES_PER_OBS = 110
FIT_BASE_BYTES = 680_000_000  # the same and the compiled fit
FIT_BYTES_PER_OBS = 200
_CGROUP_V2 = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current")
_CGROUP_V1 = ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes")
NO_LIMIT = 1 << 60


class TrialTooLarge(ValueError):
    """A reconstruction refused because its estimated peak memory exceeds what the machine has."""


def observations(cameras: int, frames: int, joints: int) -> int:
    return int(cameras) * int(frames) * int(joints)


def triangulation_bytes(cameras: int, frames: int, joints: int) -> int:
    """Estimated peak bytes of a triangulation-only reconstruction (DLT, robust)."""
    return TRIANGULATION_BASE_BYTES + TRIANGULATION_BYTES_PER_OBS * observations(cameras, frames, joints)


def fit_bytes(cameras: int, frames: int, joints: int, model_bytes: int = 0) -> int:
    """Estimated peak bytes of a trajectory fit, plus ``model_bytes`` for the time model's own arrays."""
    return FIT_BASE_BYTES + FIT_BYTES_PER_OBS * observations(cameras, frames, joints) + int(model_bytes)


def _read_int(path: str) -> int | None:
    try:
        text = Path(path).read_text().strip()
    except OSError:
        return None
    if text == "max":
        return NO_LIMIT
    try:
        return int(text)
    except ValueError:
        return None


def _mem_available() -> int | None:
    try:
        lines = Path("/proc/meminfo").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        if line.startswith("MemAvailable:"):
            return int(line.split()[1]) * 1024
    return None


def available_bytes() -> int | None:
    """Bytes this process can still use (see the module docstring), or None if unknown."""
    candidates = [_mem_available()]
    for limit_path, usage_path in (_CGROUP_V2, _CGROUP_V1):
        limit, usage = _read_int(limit_path), _read_int(usage_path)
        if limit is not None and usage is not None and limit < NO_LIMIT:
            candidates.append(max(limit - usage, 0))
    known = [c for c in candidates if c is not None]
    return min(known) if known else None


def check_memory(needed_bytes: int, *, what: str, available: int | None = None) -> None:
    """Raise :class:`TrialTooLarge` naming ``what``, the estimate and the memory available, if the
    estimate exceeds it. ``available``: bytes (default: :func:`available_bytes`)."""
    available = available_bytes() if available is None else available
    if available is None or needed_bytes <= available:
        return
    raise TrialTooLarge(
        f"{what} needs about {needed_bytes / 1e9:.1f} GB of memory, but this machine has "
        f"{available / 1e9:.1f} GB available; reconstruct the trial in shorter sections or on a machine "
        "with more memory"
    )
