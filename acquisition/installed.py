"""Where ``deploy/bootstrap.sh`` installs the files the code reads: ``<venv>/share/gaitcap/``.

Model files (``mediapipe-pose/``, ``opensim/``), normative data (``normative/``) and the real test data
(``testdata/``) all live there; :func:`share_path` is the one way to name one of them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path


def share_path(*parts: str, env: str | None = None) -> Path:
    """``$env`` when that environment variable is set (and not empty), else ``<venv>/share/gaitcap/<parts>``
    (``<venv>`` is ``sys.prefix``).

    ``share_path("testdata", "sports2d-demo.mp4")``; ``share_path("opensim", env="GAITCAP_OPENSIM_DIR")``.
    """
    override = os.environ.get(env) if env else None
    return Path(override) if override else Path(sys.prefix, "share", "gaitcap", *parts)
