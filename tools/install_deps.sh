#!/usr/bin/env bash
# Installs every Debian 12 package the project needs to build, test and render.
# Run as root (or with sudo). Safe to run again: apt-get skips what is present.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
PKGS=(
  build-essential cmake pkg-config git
  libmujoco-dev libqhull-dev
  libopencv-dev libopencv-contrib-dev
  libeigen3-dev libceres-dev libyaml-cpp-dev
  libosmesa6-dev libegl-dev libegl-mesa0 libgl-dev libgles-dev libgl1-mesa-dri
  libgtest-dev libgmock-dev libbenchmark-dev
  libapriltag-dev
  nlohmann-json3-dev libfmt-dev
  # sha256 of flight plugins (summary.json, run.json, campaign.csv)
  libssl-dev
  ffmpeg
  # campaign report (plots) and its headless-browser check
  python3 python3-matplotlib chromium
  # the detector probe with independently rendered frames (tools/probe/)
  python3-numpy python3-pil python3-scipy
  # the documentation site (mkdocs build --strict) and its reference generator (tests/docs/)
  mkdocs python3-yaml
  # the Python package and its tests (python/)
  pybind11-dev python3-pytest python3-pandas python3-dev
  # sanitizer and fuzzing builds
  clang libclang-rt-14-dev
  # the one-node Slurm cluster of the campaign's cluster test
  slurmctld slurmd slurm-client munge
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -eq 0 ]; then
  echo "install_deps: all packages present"
  exit 0
fi
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
