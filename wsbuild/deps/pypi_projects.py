"""ROS packages that PyPI carries under their own project (no `ros-<distro>-*` wheel): a
curated table, each entry checked by hand against the project's upstream (same repository,
same Python modules). A key is never turned into a PyPI name by guessing: PyPI has look-alikes
(`launch` 0.1.3 is ROS 2's launch of 2017, long incompatible; `rpyutils` is an unrelated
project; `python-qt-binding` 0.3.4 is ROS 1's), and those must not get installed."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

#: ROS package key -> its PyPI project, for every distro wsbuild knows (the projects are
#: released from the same repositories as the distro's packages)
ROS_PACKAGES_ON_PYPI: Mapping[str, str] = MappingProxyType({
    # osrf_pycommon (William Woodall, OSRF; module osrf_pycommon): launch, launch_testing and
    # ros2cli import osrf_pycommon.process_utils
    "osrf_pycommon": "osrf-pycommon",
    # urdfdom_py (Chris Lalancette, Open Robotics; module urdf_parser_py): Jazzy's 1.2.1
    "urdfdom_py": "urdfdom-py",
    # xacro (ros/xacro; module xacro): the `ros` extra installs it already
    "xacro": "xacro",
})


def pypi_project(key: str) -> str | None:
    """The PyPI project of a ROS package key from the table, or None (no guessing)."""
    return ROS_PACKAGES_ON_PYPI.get(key)
