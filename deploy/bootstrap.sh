#!/usr/bin/env bash
# Set up everything gaitcap needs on a fresh Debian/Ubuntu machine: apt packages, a venv, the package.
# Idempotent and quick when nothing changed. Used by deploy/main.sh and deploy/test.sh.
#   GAITCAP_VENV   venv folder (default: .venv in the checkout)
#   GAITCAP_APT=0  skip apt (e.g. when packages are pre-installed or without root)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${GAITCAP_VENV:-$ROOT/.venv}"
PY="${PYTHON:-python3}"

apt_install() {
  [ "${GAITCAP_APT:-1}" = "0" ] && return 0
  local missing=()
  for pkg in "$@"; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""; [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "[bootstrap] apt-get install ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get install -y -q "${missing[@]}" >/dev/null 2>&1 || {
    $sudo apt-get update -q >/dev/null && $sudo apt-get install -y -q "${missing[@]}" >/dev/null; }
}

# Chromium drives the browser test of the web page; iproute2 makes the two-host namespace test.
apt_install ${GAITCAP_APT_PACKAGES:-chromium iproute2}

if [ ! -x "$VENV/bin/python" ]; then
  echo "[bootstrap] creating venv $VENV" >&2
  "$PY" -m venv "$VENV"
fi
STAMP="$VENV/.gaitcap-installed"
HASH="$(cat "$ROOT/pyproject.toml" | sha256sum | cut -c1-16)"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$HASH" ]; then
  echo "[bootstrap] installing gaitcap and its dependencies into $VENV" >&2
  "$VENV/bin/python" -m pip install -q --upgrade pip >/dev/null
  "$VENV/bin/python" -m pip install -q -e "$ROOT[${GAITCAP_EXTRAS:-dev}]"
  echo "$HASH" > "$STAMP"
fi
