"""An instrumented walkway's export (GAITRite / Zeno / ProtoKinetics style, one row per footfall) as a
reference: the CSV format of :mod:`gaitcap.reconstruction.gait.walkway` (foot, first and last contact s,
heel and toe positions mm); a missing column is named. One trial per file (the first when several)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gaitcap.acquisition.readers import read_walkway_csv
from gaitcap.reconstruction.validation.reference import Reference


def read_walkway(path: Path) -> Reference:
    trials = read_walkway_csv(path)
    if len(trials) > 1:
        raise ValueError(f"{path}: {len(trials)} trials in one walkway file; validate one trial at a time")
    w = trials[0]
    feet = np.array(w.feet)
    hs = {s: w.first_contact_s[feet == s] for s in ("left", "right")}
    to = {s: w.last_contact_s[feet == s] for s in ("left", "right")}
    return Reference(str(path), "walkway CSV", np.zeros(0), {}, {}, hs, to, {}, w,
                     ("joint angles (a walkway measures footfalls only)",))
