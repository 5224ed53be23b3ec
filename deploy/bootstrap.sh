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
HASH="$(cat "$ROOT/pyproject.toml" "$ROOT/setup.py" | sha256sum | cut -c1-16)"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$HASH" ]; then
  echo "[bootstrap] installing gaitcap and its dependencies into $VENV" >&2
  "$VENV/bin/python" -m pip install -q --upgrade pip >/dev/null
  "$VENV/bin/python" -m pip install -q -e "$ROOT[${GAITCAP_EXTRAS:-dev}]"
  echo "$HASH" > "$STAMP"
fi

# Detector model files and a real test video (no downloads at run time): MediaPipe Pose's TFLite models
# from the npm package @mediapipe/pose (Apache-2.0), and the walking demo video of the sports2d wheel
# (BSD-3-Clause) for the detector tests. Both go to $VENV/share/gaitcap/ (see acquisition/detectors/).
# Without them everything else works (the MediaPipe tests skip), so a failure here only warns.
SHARE="$VENV/share/gaitcap"
MP_POSE_VERSION="0.5.1675469404"
SPORTS2D_VERSION="0.8.34"
install_mediapipe_models() {
  local dest="$SHARE/mediapipe-pose" tmp
  [ -f "$dest/.version-$MP_POSE_VERSION" ] && return 0
  command -v npm >/dev/null 2>&1 || apt_install npm || return 1
  echo "[bootstrap] installing MediaPipe Pose models (npm @mediapipe/pose@$MP_POSE_VERSION)" >&2
  tmp="$(mktemp -d)" || return 1
  (cd "$tmp" && npm pack -q "@mediapipe/pose@$MP_POSE_VERSION" >/dev/null && tar xzf mediapipe-pose-*.tgz) \
    && mkdir -p "$dest" \
    && install -m 644 "$tmp"/package/pose_landmark_{lite,full,heavy}.tflite "$tmp/package/package.json" "$dest/" \
    && install -m 644 "$tmp/package/pose_solution_packed_assets.data" "$dest/pose_detection.tflite" \
    && touch "$dest/.version-$MP_POSE_VERSION"
  # (the packed assets file is the person detector's tflite: the package's loader maps it whole to
  # pose_detection.tflite)
  local rc=$?
  rm -rf "$tmp"
  return $rc
}
install_test_video() {
  local dest="$SHARE/testdata/sports2d-demo.mp4" tmp
  [ -f "$dest" ] && return 0
  echo "[bootstrap] fetching the sports2d demo video (wheel sports2d==$SPORTS2D_VERSION, not installed)" >&2
  tmp="$(mktemp -d)" || return 1
  "$VENV/bin/python" -m pip download -q --no-deps -d "$tmp" "sports2d==$SPORTS2D_VERSION" \
    && mkdir -p "$SHARE/testdata" \
    && "$VENV/bin/python" - "$tmp" "$dest" <<'PYEOF'
import glob, os, sys, zipfile
wheel = glob.glob(os.path.join(sys.argv[1], "sports2d-*.whl"))[0]
with zipfile.ZipFile(wheel) as z:
    data = z.read("Sports2D/Demo/demo.mp4")
with open(sys.argv[2] + ".tmp", "wb") as f:
    f.write(data)
os.replace(sys.argv[2] + ".tmp", sys.argv[2])
PYEOF
  local rc=$?
  rm -rf "$tmp"
  return $rc
}
install_mediapipe_models || echo "[bootstrap] WARNING: MediaPipe Pose models not installed (needs npm)" >&2
install_test_video || echo "[bootstrap] WARNING: detector test video not installed" >&2
