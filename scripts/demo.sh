#!/usr/bin/env bash
# The sample workspace, end to end, on a fresh Debian/Ubuntu machine: set up .venv (wsbuild with
# ROS 2 Jazzy from PyPI as the underlay), build sample_ws/ in place, and run its nodes, service,
# xacro and C++ app.  Every step prints its command first (docs/guide/sample-workspace.md
# quotes them); background nodes are stopped on exit; the exit status is 0 only if every step
# worked.
set -euo pipefail
cd "$(dirname "$0")/.."

# DDS stays on this machine, in a domain of its own, whatever the caller had set.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=42
# Node logs reach the log files line by line, without colour codes.
export PYTHONUNBUFFERED=1 RCUTILS_LOGGING_BUFFERED_STREAM=0 RCUTILS_COLORIZED_OUTPUT=0

logs="$(mktemp -d "${TMPDIR:-/tmp}/wsbuild-demo.XXXXXX")"
background=()

stop_background() {
  local pid waited
  for pid in "${background[@]}"; do
    kill -INT "$pid" 2>/dev/null || continue
    for waited in 1 2 3 4 5 6 7 8 9 10; do
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.5
    done
    kill -KILL "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  done
  background=()
}

on_exit() {
  local status=$?
  stop_background
  rm -rf "$logs"
  if [ "$status" -eq 0 ]; then
    echo "demo: every step worked"
  else
    echo "demo: FAILED (exit status $status)" >&2
  fi
}
trap on_exit EXIT
trap 'exit 130' INT TERM

step() {
  printf '\n=== %s\n' "$1"
}

show() {
  printf '$ %s\n' "$*"
}

# Runs a command in the background, its output into $logs/<name>.log; prints the command first.
start() {
  local name=$1
  shift
  printf '$ %s > %s.log 2>&1 &\n' "$*" "$name"
  "$@" >"$logs/$name.log" 2>&1 &
  background+=("$!")
}

# Waits until $logs/<name>.log has a line matching the pattern; fails after the timeout.
wait_for() {
  local name=$1 pattern=$2 timeout=${3:-30} waited=0
  until grep -qE "$pattern" "$logs/$name.log"; do
    if [ "$waited" -ge $((timeout * 5)) ]; then
      echo "demo: no '$pattern' from $name within $timeout s; its output:" >&2
      cat "$logs/$name.log" >&2
      return 1
    fi
    sleep 0.2
    waited=$((waited + 1))
  done
}

step "1. set up .venv: wsbuild, its test tools and ROS 2 Jazzy from PyPI (the underlay)"
show bash scripts/setup.sh
bash scripts/setup.sh

step "2. build the sample workspace in place"
show cd sample_ws
cd sample_ws
show ../.venv/bin/wsbuild build
../.venv/bin/wsbuild build
show source install/setup.bash
# shellcheck disable=SC1091
source install/setup.bash
show ../.venv/bin/wsbuild list
../.venv/bin/wsbuild list

step "3. move_joint listens on /joint_setpoint: remap it to /setpoint, name its joint, publish"
start move_joint wsbuild run demo_nodes_py move_joint \
  --ros-args -r /joint_setpoint:=/setpoint -p joint_name:=right_e0
wait_for move_joint 'move_joint ready'
show timeout -s INT 4 wsbuild run demo_nodes_py setpoint_publisher
status=0
timeout -s INT 4 wsbuild run demo_nodes_py setpoint_publisher || status=$?
# 124: stopped by timeout after 4 s, which is the plan
if [ "$status" -ne 0 ] && [ "$status" -ne 124 ]; then
  echo "demo: setpoint_publisher failed with exit status $status" >&2
  exit 1
fi
wait_for move_joint 'right_e0 <- ' 5
received=$(grep -c 'right_e0 <- ' "$logs/move_joint.log")
echo "move_joint received $received setpoints; the last ones:"
grep 'right_e0 <- ' "$logs/move_joint.log" | tail -n 3
stop_background

step "4. without its joint_name parameter, move_joint refuses to start"
show wsbuild run demo_nodes_py move_joint
if wsbuild run demo_nodes_py move_joint; then
  echo "demo: move_joint started without joint_name" >&2
  exit 1
fi

step "5. the parameters file sets joint_name (and more) for every node"
start move_joint_params wsbuild run demo_nodes_py move_joint \
  --ros-args --params-file install/demo_nodes_py/share/demo_nodes_py/config/params.yaml
wait_for move_joint_params 'move_joint ready: joint left_s1'
grep 'move_joint ready' "$logs/move_joint_params.log"
stop_background

step "6. call the ChangeMode service of demo_interfaces"
start mode_server wsbuild run demo_nodes_py mode_server
wait_for mode_server 'serving'
show wsbuild run demo_nodes_py change_mode_client velocity
wsbuild run demo_nodes_py change_mode_client velocity
stop_background

step "7. expand the robot description: demo_description includes an arm from demo_parts"
show "xacro install/demo_description/share/demo_description/urdf/robot.urdf.xacro | grep '<joint name='"
xacro install/demo_description/share/demo_description/urdf/robot.urdf.xacro | grep '<joint name='

step "8. run the C++ app, linked against the library of demo_cpp_lib"
show wsbuild run demo_cpp_app joint_command right_e0 90
wsbuild run demo_cpp_app joint_command right_e0 90
