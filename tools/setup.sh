#!/usr/bin/env bash
# Sets up a Debian 12 machine for building and testing mound-survey. Idempotent: installs
# only the Debian packages that are missing, creates the project venv (.venv) once and
# re-installs Python packages only when python/requirements.txt changes.
#
#   bash tools/setup.sh          (root, or a user with sudo)
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"

APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  nlohmann-json3-dev libgtest-dev libeigen3-dev libopencv-dev libceres-dev
  libpcl-dev libopenmpi-dev
  chromium firefox-esr
  clang libclang-rt-14-dev
  python3 python3-venv python3-dev
  proj-data  # PROJ's EGM96 geoid grid (egm96_15.gtx): ellipsoidal DEM heights to AMSL
)

missing=()
for pkg in "${APT_PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: Debian packages present"
fi

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $($PYTHON --version)"
  "$PYTHON" -m venv .venv
fi
want=$(cat python/requirements.txt pyproject.toml | sha256sum | cut -d' ' -f1)
have=$(cat .venv/.requirements.sha256 2>/dev/null || true)
if [ "$want" != "$have" ]; then
  echo "setup: installing Python packages into .venv"
  # No pip cache: the wheels (open3d, pycolmap, scipy, ...) would be kept a second time in
  # ~/.cache/pip, about 0.7 GB that a CI machine short of disk cannot spare.
  export PIP_NO_CACHE_DIR=1
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -r python/requirements.txt
  .venv/bin/python -m pip install -q --no-deps -e .
  echo "$want" > .venv/.requirements.sha256
else
  echo "setup: Python packages present"
fi

# The report's JavaScript (Leaflet for the map page, three.js for the 3-D viewer), pinned
# by tools/web/package-lock.json, installed into tools/web/node_modules and copied into
# each report (it works offline).
# Debian's nodejs and npm where no npm is on the PATH (a NodeSource nodejs brings its own
# npm and conflicts with Debian's).
if ! command -v npm >/dev/null; then
  echo "setup: installing Debian packages: nodejs npm"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends nodejs npm
fi
want=$(sha256sum tools/web/package-lock.json | cut -d' ' -f1)
have=$(cat tools/web/node_modules/.lock.sha256 2>/dev/null || true)
if [ "$want" != "$have" ]; then
  echo "setup: installing the report's JavaScript (npm ci in tools/web)"
  (cd tools/web && npm ci --no-audit --no-fund --loglevel=error)
  echo "$want" > tools/web/node_modules/.lock.sha256
else
  echo "setup: the report's JavaScript present"
fi
