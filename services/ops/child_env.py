"""The environment of each child process of the stack: only what that process needs.

The shell that starts the stack may hold secrets: the API's tokens (``GAITCAP_TOKENS``), cloud or
registry credentials, an agent's socket. A child inherits none of them by default. It gets:

- the system variables any Python process needs (:data:`SYSTEM_NAMES`, :data:`SYSTEM_PREFIXES`: the
  path, home, locale, temporary folder, the venv, Python's own and the numeric libraries' settings), never
  one whose name says it holds a secret (:data:`SECRET_WORDS`);
- the gaitcap settings of its role only (:data:`ROLE_SETTINGS`: ``GAITCAP_TOKENS`` to the API, which checks
  them, and to no other process);
- what the stack sets for it (bus file, catalog, data folder), given by the caller.

:func:`child_environment` builds it; :func:`held_secrets` names the parent's variables a role does not get
(for the start-up log: names only, never values).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

#: Variables passed as they are (when not secret-looking).
SYSTEM_NAMES = frozenset({
    "PATH", "HOME", "USER", "LOGNAME", "SHELL", "LANG", "LANGUAGE", "TZ", "TMPDIR", "TEMP", "TMP", "VIRTUAL_ENV",
    "LD_LIBRARY_PATH", "SSL_CERT_FILE", "SSL_CERT_DIR", "XDG_CACHE_HOME", "XDG_CONFIG_HOME", "XDG_DATA_HOME",
    "MPLBACKEND", "MPLCONFIGDIR", "SOURCE_DATE_EPOCH",
})
#: Prefixes of variables passed as they are: locale, Python, JAX/XLA and the BLAS/OpenMP thread settings,
#: GPU selection, coverage of child processes (CI).
SYSTEM_PREFIXES = ("LC_", "PYTHON", "JAX_", "XLA_", "TF_", "OMP_", "OPENBLAS_", "MKL_", "NUMBA_", "CUDA_", "NVIDIA_",
                   "COV_CORE_", "COVERAGE_")
#: A variable whose name holds one of these words is never passed as a system variable.
SECRET_WORDS = ("TOKEN", "PASSWORD", "PASSWD", "SECRET", "KEY", "CREDENTIAL", "AUTH", "COOKIE", "PRIVATE", "SESSION",
                "SOCK")
_SECRET = re.compile("|".join(SECRET_WORDS))

#: role -> the gaitcap settings from the parent's environment that its process reads.
ROLE_SETTINGS: dict[str, frozenset[str]] = {
    "api": frozenset({"GAITCAP_TOKENS", "GAITCAP_TLS_CERT", "GAITCAP_TLS_KEY", "GAITCAP_AUDIT_SYSLOG",
                      "GAITCAP_SUBJECT_ID_PATTERN", "GAITCAP_CLINIC_NAME", "GAITCAP_BOARD_FILE",
                      "GAITCAP_NORMS_CSV", "GAITCAP_NORMS_FILE", "GAITCAP_ADULT_NORMS_FILE", "GAITCAP_OPENSIM_DIR"}),
    "worker": frozenset({"GAITCAP_NORMS_CSV", "GAITCAP_NORMS_FILE", "GAITCAP_ADULT_NORMS_FILE", "GAITCAP_OPENSIM_DIR",
                         "GAITCAP_CLINIC_NAME"}),
    "detector": frozenset({"GAITCAP_MEDIAPIPE_DIR"}),
    "camera": frozenset(),
    "recorder": frozenset(),
}


def is_secret_name(name: str) -> bool:
    """True when the variable's name says it holds a secret (token, password, key, credentials, ...)."""
    return bool(_SECRET.search(name.upper()))


def system_environment(parent: Mapping[str, str]) -> dict[str, str]:
    """The parent's system variables a child may have (see the module docstring)."""
    return {k: v for k, v in parent.items()
            if (k in SYSTEM_NAMES or k.startswith(SYSTEM_PREFIXES)) and not is_secret_name(k)}


def child_environment(role: str, parent: Mapping[str, str], stack_set: Mapping[str, str]) -> dict[str, str]:
    """The whole environment of a child of ``role`` (a key of :data:`ROLE_SETTINGS`): the parent's system
    variables, the parent's gaitcap settings of that role, then ``stack_set`` (what the stack sets for it)."""
    if role not in ROLE_SETTINGS:
        raise ValueError(f"role: {role!r} is not one of {sorted(ROLE_SETTINGS)}")
    own = {k: v for k, v in parent.items() if k in ROLE_SETTINGS[role]}
    return {**system_environment(parent), **own, **stack_set}


def held_secrets(role: str, parent: Mapping[str, str]) -> list[str]:
    """Names of the parent's secret-looking or gaitcap variables that a ``role`` child does not get."""
    given = set(child_environment(role, parent, {}))
    return sorted(k for k in parent if k not in given and (is_secret_name(k) or k.startswith("GAITCAP_")))
