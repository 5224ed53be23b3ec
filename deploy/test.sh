#!/usr/bin/env bash
# The README's test command: set up (apt, venv, package) and run the whole test suite.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/deploy/bootstrap.sh"
cd "$ROOT"
exec "${GAITCAP_VENV:-$ROOT/.venv}/bin/python" -m pytest "$@"
