"""The test tool the selected packages' tests need that no package.xml names: the pytest that
the distro's pytest plugins need (launch_testing's hooks want pytest 7), installed where
`wsbuild test` looks for it (underlay/constraints.py: `<venv>/ros-pytest`)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from wsbuild.deps.needs import Need
from wsbuild.deps.plan import Installer, Source, Step
from wsbuild.underlay.constraints import (
    ROS_PYTEST_VERSION,
    ros_pytest_dir,
    ros_pytest_installed,
    ros_pytest_requirements,
)
from wsbuild.workspace.model import DepKind, Package, Resolution

#: what the plan calls the ROS tests' pytest
ROS_PYTEST = f"pytest=={ROS_PYTEST_VERSION}"


def has_tests(package: Package) -> bool:
    """A package declares test dependencies or has a test folder."""
    return (any(d.kind is DepKind.TEST for d in package.dependencies)
            or (package.path / "test").is_dir() or (package.path / "tests").is_dir())


def ros_pytest_step(packages: Iterable[Package], python: Path,
                    kinds: frozenset[DepKind]) -> Step | None:
    """The step installing the ROS tests' pytest, when test dependencies are wanted, some
    selected package has tests, and it is not installed for `python`."""
    if DepKind.TEST not in kinds:
        return None
    testers = sorted(p.name for p in packages if has_tests(p))
    if not testers or ros_pytest_installed(str(python)):
        return None
    need = Need(ROS_PYTEST, tuple(testers), (DepKind.TEST,), Resolution.UNRESOLVED)
    return Step(need, Source.ROS_PYTEST, Installer.PIP, (ROS_PYTEST,))


def ros_pytest_command(python: Path) -> list[str]:
    """`pip install --no-deps --target <venv>/ros-pytest -r ros-pytest.txt` (its requirements
    pin pytest's own dependencies, so they never mix with the venv's)."""
    target = ros_pytest_dir(str(python))
    requirements = ros_pytest_requirements()
    what = ["-r", str(requirements)] if requirements is not None else ["--", ROS_PYTEST]
    return [str(python), "-m", "pip", "install", "--no-deps", "--upgrade", "--target",
            str(target), *what]
