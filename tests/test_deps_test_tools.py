"""wsbuild/deps/test_tools.py and the shipped requirement files it and `deps install` use
(wsbuild/underlay/constraints.py): when the ROS tests' pytest is wanted, where it goes, and
which constraints file a distro gets."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import REPO
from wsbuild.deps.plan import Source
from wsbuild.deps.test_tools import has_tests, linter_program_steps, ros_pytest_command
from wsbuild.deps.test_tools import ros_pytest_step
from wsbuild.build_types.ros_pytest import ROS_PYTEST_VAR, ros_pytest_installed
from wsbuild.underlay.constraints import distro_constraints, ros_pytest_requirements
from wsbuild.workspace.model import DepKind, Dependency, Package

ALL = frozenset(DepKind)
PYTHON = Path("/venv/bin/python3")


def package(tmp_path: Path, name: str, *, test_depend: bool = False,
            folder: str = "") -> Package:
    path = tmp_path / name
    (path / folder if folder else path).mkdir(parents=True)
    dependencies = (Dependency("python3-pytest", DepKind.TEST),) if test_depend else ()
    return Package(name, path, "ament_python", dependencies=dependencies)


def test_a_package_has_tests_by_a_test_depend_or_a_test_folder(tmp_path: Path) -> None:
    assert has_tests(package(tmp_path, "a", test_depend=True))
    assert has_tests(package(tmp_path, "b", folder="test"))
    assert has_tests(package(tmp_path, "c", folder="tests"))
    assert not has_tests(package(tmp_path, "d", folder="src"))


def test_the_ros_pytest_is_wanted_only_for_tests_and_only_when_missing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "ros-pytest"
    monkeypatch.setenv(ROS_PYTEST_VAR, str(target))
    tested = [package(tmp_path, "b_pkg", folder="test"), package(tmp_path, "a_pkg",
                                                                 test_depend=True)]
    step = ros_pytest_step(tested, PYTHON, ALL)
    assert step is not None and step.source is Source.ROS_PYTEST
    assert step.need.key == "pytest==7.4.4" and step.need.needed_by == ("a_pkg", "b_pkg")
    assert ros_pytest_step(tested, PYTHON, ALL - {DepKind.TEST}) is None  # --types build,run
    assert ros_pytest_step([package(tmp_path, "plain")], PYTHON, ALL) is None
    (target / "pytest-7.4.4.dist-info").mkdir(parents=True)
    assert ros_pytest_installed(str(PYTHON)) and ros_pytest_step(tested, PYTHON, ALL) is None


def test_the_ros_pytest_goes_into_its_own_folder_without_the_venvs_packages(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ROS_PYTEST_VAR, str(tmp_path / "ros-pytest"))
    assert ros_pytest_command(PYTHON) == [
        str(PYTHON), "-m", "pip", "install", "--no-deps", "--upgrade", "--target",
        str(tmp_path / "ros-pytest"), "-r", str(REPO / "requirements" / "ros-pytest.txt")]
    assert "pytest==7.4.4" in (ros_pytest_requirements() or Path("/")).read_text()


def test_each_distro_gets_its_shipped_constraints_and_only_by_a_plain_name() -> None:
    assert distro_constraints("jazzy") == REPO / "requirements" / "ros-jazzy.lock.txt"
    assert distro_constraints("kilted") is None  # none shipped: pip runs unconstrained
    for odd in ("../jazzy", "jazzy/../x", "", "Jazzy"):
        assert distro_constraints(odd) is None


def _linted(tmp_path: Path, name: str, *test_depends: str) -> Package:
    (tmp_path / name).mkdir(parents=True)
    return Package(name, tmp_path / name, "ament_cmake",
                   dependencies=tuple(Dependency(d, DepKind.TEST) for d in test_depends))


def test_the_programs_the_linters_run_are_installed_when_missing(tmp_path: Path) -> None:
    """ament_lint_common brings cppcheck's linter, which runs the cppcheck program: missing
    on PATH, it is an apt-get step; a linter wsbuild stands in for needs no program."""
    common = _linted(tmp_path, "cpp_common", "ament_lint_auto", "ament_lint_common")
    direct = _linted(tmp_path, "cpp_direct", "ament_cmake_cppcheck", "ament_mypy")
    empty = tmp_path / "empty-path"
    empty.mkdir()
    steps = linter_program_steps([common, direct], ALL, path=str(empty), installed=(),
                                 stood_in={"ament_cmake_xmllint", "ament_uncrustify"})
    found = {(s.need.key, s.installer.value, s.packages, s.need.needed_by) for s in steps}
    assert found == {("cppcheck", "apt", ("cppcheck",), ("cpp_common", "cpp_direct")),
                     ("flake8", "pip", ("flake8",), ("cpp_common",)),
                     ("pydocstyle", "pip", ("pydocstyle",), ("cpp_common",)),
                     ("mypy", "pip", ("mypy",), ("cpp_direct",))}
    assert all(s.source is Source.LINT_PROGRAM for s in steps)
    # there already: nothing to do; and nothing at all without test dependencies
    for program in ("cppcheck", "uncrustify"):
        (empty / program).symlink_to("/bin/true")
    again = linter_program_steps([common], ALL, path=str(empty), stood_in=(),
                                 installed={"flake8", "pydocstyle"})
    assert [s.need.key for s in again] == ["xmllint"]  # not stood in here: its program counts
    assert again[0].packages == ("libxml2-utils",)
    assert linter_program_steps([common, direct], ALL - {DepKind.TEST}, path=str(empty),
                                installed=(), stood_in=()) == []
