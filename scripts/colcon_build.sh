#!/usr/bin/env bash
# Build ros_ws with colcon against the ROS 2 Jazzy wheels in .venv (the venv is the ROS prefix).
# --symlink-install: Python sources are used in place, so editing them needs no rebuild.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="$root/.venv"
export PATH="$venv/bin:$PATH"
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
cd "$root/ros_ws"
colcon --log-base log build --symlink-install --event-handlers console_cohesion+ summary+ \
  --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$venv/bin/python" 2>&1 \
  | grep -v "doesn't contain any 'local_setup" || exit "${PIPESTATUS[0]}"
