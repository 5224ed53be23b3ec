"""Model coordinates resting on the bounds of their range: a fit that wanted to go further and could not.

A coordinate held at its bound is not measured there (the markers asked for more than the model allows: a
model whose shape is not the patient's, a wrong keypoint, or a joint beyond the model's range), so every
such coordinate is named with how often it rests there, never passed over in silence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TOLERANCE_DEG = 0.5  # a rotational coordinate this close to a bound (degrees) rests on it
TOLERANCE_M = 0.001  # a translational one (m)
MIN_FRAMES = 3  # fewer frames at a bound are not reported (a swing passing through it)


@dataclass(frozen=True)
class BoundHit:
    """``coordinate`` rested on its ``bound`` (``"lower"`` or ``"upper"``, value ``limit`` in degrees, or m
    when not ``rotational``) in ``frames`` of the ``fitted`` frames."""

    coordinate: str
    bound: str
    limit: float
    frames: int
    fitted: int
    rotational: bool = True

    @property
    def fraction(self) -> float:
        return self.frames / self.fitted if self.fitted else 0.0

    def message(self) -> str:
        unit = "deg" if self.rotational else "m"
        return (f"{self.coordinate} rests on its {self.bound} bound ({self.limit:g} {unit}) in {self.frames} of "
                f"{self.fitted} frames ({100 * self.fraction:.0f} %): the fit could not follow the keypoints there")

    def to_dict(self) -> dict:
        return {"coordinate": self.coordinate, "bound": self.bound, "limit": round(self.limit, 4),
                "unit": "deg" if self.rotational else "m",
                "frames": self.frames, "fitted": self.fitted, "fraction": round(self.fraction, 3)}


def bound_hits(values: dict[str, np.ndarray], ranges: dict[str, tuple[float, float, bool]]) -> list[BoundHit]:
    """The coordinates of ``values`` (name -> (T,) degrees for rotations, m for translations; NaN = not
    fitted) resting on a bound of ``ranges`` (name -> (lower, upper, rotational)) in at least
    :data:`MIN_FRAMES` frames, most frames first."""
    out = []
    for name, (lo, hi, rotational) in ranges.items():
        v = np.asarray(values.get(name, []), dtype=np.float64)
        v = v[np.isfinite(v)]
        if not v.size:
            continue
        tol = TOLERANCE_DEG if rotational else TOLERANCE_M
        for bound, limit, at in (("lower", lo, v <= lo + tol), ("upper", hi, v >= hi - tol)):
            if int(at.sum()) >= MIN_FRAMES:
                out.append(BoundHit(name, bound, float(limit), int(at.sum()), int(v.size), bool(rotational)))
    return sorted(out, key=lambda h: -h.frames)
