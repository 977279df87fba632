"""Which pytest runs a ROS package's tests: Jazzy's platform pytest (7.x), whose hooks Jazzy's
pytest plugins were written for, when it is installed beside the interpreter's own.

ROS 2 Jazzy's pytest plugins (launch_testing's `pytest_pycollect_makemodule(path, parent)`,
`Module.from_parent(parent, fspath=...)`) use the py.path arguments that pytest 9 removed; the
interpreter that runs wsbuild (and wsbuild's own test suite) may well hold pytest 9. So a
package's tests, and the pytest tests CTest runs, get `<prefix>/ros-pytest` (a `pip install
--target` of `requirements/ros-pytest.txt`, made by `wsbuild deps install` or scripts/setup.sh;
where it lives: underlay/constraints.py) first on PYTHONPATH: the
ROS packages stay the interpreter's, only pytest and its own dependencies are Jazzy's. Without
that directory the interpreter's own pytest runs, and a plugin it refuses is reported as the
test tooling failing to start, with this fix (tooling.py). The runners that run pytest put
it on PYTHONPATH themselves (`TestRunner.environment`, build_types/ros_pytest.py). `$WSBUILD_ROS_PYTEST` names another
directory (one shared by several virtualenvs, say).
"""

from __future__ import annotations

from wsbuild.build_types.ros_pytest import (
    ROS_PYTEST_DIR,
    ROS_PYTEST_VAR,
    ROS_PYTEST_VERSION,
    ros_pytest_dir,
)

__all__ = ["ROS_PYTEST_DIR", "ROS_PYTEST_VAR", "ROS_PYTEST_VERSION", "install_hint",
           "ros_pytest_dir"]


def install_hint(python_executable: str) -> str:
    """How to install the ROS tests' pytest for this interpreter."""
    return (f"wsbuild deps install (or: {python_executable} -m pip install --target "
            f"{ros_pytest_dir(python_executable)} pytest=={ROS_PYTEST_VERSION})")
