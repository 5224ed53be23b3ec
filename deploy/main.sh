#!/usr/bin/env bash
# The README's main command: set up (apt, venv, package) and run gaitcap on embedded defaults.
# Extra arguments are passed to `gaitcap demo`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/deploy/bootstrap.sh"
cd "$ROOT"
exec "${GAITCAP_VENV:-$ROOT/.venv}/bin/gaitcap" demo "$@"
