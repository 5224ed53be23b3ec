import json
import math

import numpy as np
from gaitcap.reconstruction.jsonable import finite_or_none, json_ready


def test_json_ready_makes_strict_json():
    value = {1: (np.float32(1.5), np.nan), "a": np.array([[1.0, np.inf], [2.0, -np.inf]]), "b": [True, None, "x"],
             "n": np.int64(3)}
    out = json_ready(value)
    assert out == {"1": [1.5, None], "a": [[1.0, None], [2.0, None]], "b": [True, None, "x"], "n": 3}
    json.dumps(out, allow_nan=False)


def test_finite_or_none():
    assert finite_or_none("2.5") == 2.5 and finite_or_none(np.float64(3)) == 3.0
    assert [finite_or_none(v) for v in (None, math.nan, math.inf, "x", [1])] == [None] * 5
