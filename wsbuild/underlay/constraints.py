"""The pip requirement files wsbuild ships (package data `wsbuild/requirements`, the
repository's top-level `requirements/` in a checkout): each ROS distro's constraints (every
wheel of the underlay pinned) and the pytest that distro's test plugins need."""

from __future__ import annotations

from pathlib import Path

from wsbuild.patterns import lazy

#: a ROS distro's name (`jazzy`): the only text that goes into a file name here
_DISTRO = lazy(r"^[a-z]+$")
#: the pytest for ROS packages' tests (testing/pytest_env.py)
ROS_PYTEST_FILE = "ros-pytest.txt"
def requirements_dir() -> Path | None:
    """Where the shipped requirement files are: beside the package in a wheel, the top-level
    `requirements/` of a source checkout or editable install; None when neither is there."""
    here = Path(__file__).resolve().parent.parent
    for candidate in (here / "requirements", here.parent / "requirements"):
        if (candidate / ROS_PYTEST_FILE).is_file():
            return candidate
    return None


def distro_constraints(distro: str) -> Path | None:
    """`ros-<distro>.lock.txt` shipped with wsbuild, or None for a distro it has none for."""
    folder = requirements_dir()
    if folder is None or not _DISTRO.match(distro):
        return None
    path = folder / f"ros-{distro}.lock.txt"
    return path if path.is_file() else None


def ros_pytest_requirements() -> Path | None:
    """The requirements of the ROS tests' pytest (pinned, with its own dependencies)."""
    folder = requirements_dir()
    return folder / ROS_PYTEST_FILE if folder is not None else None
