"""The test tools the selected packages' tests need that no package.xml names: the pytest that
the distro's pytest plugins need (launch_testing's hooks want pytest 7), installed where
`wsbuild test` looks for it (underlay/constraints.py: `<venv>/ros-pytest`); and the programs
their linters run (cppcheck, xmllint, ...: underlay/lint_programs.py), by apt-get or pip."""

from __future__ import annotations

from collections.abc import Collection, Iterable
from pathlib import Path

from wsbuild import inputs

from wsbuild.deps.needs import Need
from wsbuild.deps.plan import Installer, Source, Step
from wsbuild.build_types.ros_pytest import (
    ROS_PYTEST_VERSION,
    ros_pytest_dir,
    ros_pytest_installed,
)
from wsbuild.underlay.constraints import ros_pytest_requirements
from wsbuild.underlay.lint import COMMON_LINTERS, LINTERS
from wsbuild.underlay.lint_programs import LINT_PROGRAMS, LintProgram
from wsbuild.workspace.model import DepKind, Package, Resolution
from wsbuild.workspace.resolve import normalize_distribution

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


def linters_of(package: Package) -> set[str]:
    """The CMake packages of the ament linters `package`'s tests run: those it names as test
    dependencies (`ament_cmake_cppcheck`, or the Python module `ament_cppcheck`), and every
    common one when it names ament_lint_common."""
    modules = {module: cmake for cmake, module in LINTERS.items()}
    found: set[str] = set()
    for dep in package.dependencies:
        if dep.kind is not DepKind.TEST:
            continue
        if dep.name == "ament_lint_common":
            found.update(COMMON_LINTERS)
        elif dep.name in LINTERS:
            found.add(dep.name)
        elif dep.name in modules:
            found.add(modules[dep.name])
    return found


def linter_program_steps(packages: Iterable[Package], kinds: frozenset[DepKind], *, path: str,
                         installed: Collection[str], stood_in: Collection[str]) -> list[Step]:
    """A step for each program the selected packages' linters run that is not there (not on
    `path`; a Python one not among the `installed` distributions): apt-get for a program
    Debian packages, pip for the others. A linter wsbuild stands in for (`stood_in`: its
    CMake package or Python module has no wheel) registers no test and needs no program."""
    if DepKind.TEST not in kinds:
        return []
    users: dict[str, list[str]] = {}
    for package in packages:
        for linter in sorted(linters_of(package)):
            program = LINT_PROGRAMS.get(linter)
            if program is None or linter in stood_in or LINTERS[linter] in stood_in:
                continue
            if not _present(program, path, installed):
                users.setdefault(linter, []).append(package.name)
    steps = []
    for linter, names in sorted(users.items()):
        program = LINT_PROGRAMS[linter]
        installer = Installer.APT if program.apt else Installer.PIP
        need = Need(program.name, tuple(names), (DepKind.TEST,), Resolution.UNRESOLVED,
                    location=linter)
        steps.append(Step(need, Source.LINT_PROGRAM, installer,
                          (program.apt if program.apt else program.pip,)))
    return steps


def _present(program: LintProgram, path: str, installed: Collection[str]) -> bool:
    if program.python:
        return normalize_distribution(program.name) in installed
    return inputs.which(program.name, path) is not None
