"""Which pytest runs a ROS package's tests (pytest's and the pytest tests CTest runs): ROS 2
Jazzy's platform pytest, installed beside the interpreter's own (`<prefix>/ros-pytest`, or
`$WSBUILD_ROS_PYTEST`), put first on PYTHONPATH by the test runners that run pytest
(testing/pytest_env.py says why)."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path

#: the directory, under the interpreter's prefix, holding the pytest for ROS packages' tests
ROS_PYTEST_DIR = "ros-pytest"
#: names the directory instead
ROS_PYTEST_VAR = "WSBUILD_ROS_PYTEST"
#: the version Jazzy's platform (Ubuntu 24.04) ships and its plugins are tested with
ROS_PYTEST_VERSION = "7.4.4"



def ros_pytest_dir(python_executable: str) -> Path:
    """Where the ROS tests' pytest lives for this interpreter (it may not exist):
    `$WSBUILD_ROS_PYTEST`, else `<prefix>/ros-pytest`."""
    if os.environ.get(ROS_PYTEST_VAR):
        return Path(os.environ[ROS_PYTEST_VAR])
    if Path(python_executable) == Path(sys.executable):
        prefix = Path(sys.prefix)
    else:  # a virtualenv's bin/python
        prefix = Path(python_executable).absolute().parent.parent
    return prefix / ROS_PYTEST_DIR


def ros_pytest_installed(python_executable: str) -> bool:
    """Whether the ROS tests' pytest, in its version, is installed for this interpreter."""
    folder = ros_pytest_dir(python_executable)
    return (folder / f"pytest-{ROS_PYTEST_VERSION}.dist-info").is_dir()


def with_ros_pytest(env: Mapping[str, str], python_executable: str) -> dict[str, str]:
    """`env` with the ROS tests' pytest first on PYTHONPATH, when it is installed."""
    result = dict(env)
    folder = ros_pytest_dir(python_executable)
    if (folder / "pytest").is_dir():
        rest = result.get("PYTHONPATH", "")
        result["PYTHONPATH"] = str(folder) + (os.pathsep + rest if rest else "")
    return result
