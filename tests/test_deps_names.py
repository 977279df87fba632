"""The names `wsbuild deps` hands to installers (wsbuild/deps/names.py) and the curated table of
ROS packages PyPI carries under their own project (wsbuild/deps/pypi_projects.py): a key that
looks like an option never reaches pip or apt-get as one, and no PyPI name is guessed."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.deps.index import IndexAnswer, query_one
from wsbuild.deps.install import apt_install_command, pip_install_command
from wsbuild.deps.needs import Need
from wsbuild.deps.names import valid_debian_package, valid_pip_requirement
from wsbuild.deps.plan import Installer, Planner, Source, python_candidates
from wsbuild.deps.pypi_projects import ROS_PACKAGES_ON_PYPI
from wsbuild.deps.rosdep import Rule
from wsbuild.workspace.model import DepKind, Resolution
from test_deps_plan import FakeRosdep, planner


def need(key: str) -> Need:
    return Need(key, ("pkg",), (DepKind.EXEC,), Resolution.UNRESOLVED)


@pytest.mark.parametrize("name", ["psutil", "osrf-pycommon", "ros-jazzy-std-msgs", "PyYAML",
                                  "foo>=1.2", "zope.interface", "a"])
def test_pip_takes_requirement_names(name: str) -> None:
    assert valid_pip_requirement(name)


@pytest.mark.parametrize("name", ["-h", "--index-url=http://x", "-r/etc/passwd", "", " ",
                                  "./local", "/abs/path", "foo @ https://x/foo.whl", "a b",
                                  "foo;", "-"])
def test_pip_refuses_options_paths_and_urls(name: str) -> None:
    assert not valid_pip_requirement(name)


@pytest.mark.parametrize("name", ["hello", "libfoo-dev", "g++", "libc6:amd64", "python3.11"])
def test_apt_takes_debian_names(name: str) -> None:
    assert valid_debian_package(name)


@pytest.mark.parametrize("name", ["-h", "--allow-unauthenticated", "Foo", "a", "lib foo",
                                  "/tmp/x.deb", "foo=1.0", ""])
def test_apt_refuses_what_debian_policy_does_not_allow(name: str) -> None:
    assert not valid_debian_package(name)


def test_an_option_like_python_key_is_unresolved_and_never_asked_about() -> None:
    # `python3--h` would be the distribution `-h` by convention
    assert python_candidates([need("python3--h"), need("python3-psutil")]) == ["psutil"]
    plan = planner(pythons=["-h", "psutil"]).plan([need("python3--h"), need("python3-psutil")])
    assert [s.need.key for s in plan.steps] == ["python3-psutil"]
    (item,) = plan.unresolved
    assert item.need.key == "python3--h"
    assert "'-h' is not a PEP 508 requirement, so wsbuild does not hand it to pip" in item.why


def test_option_like_names_in_rosdep_rules_are_refused_for_pip_and_apt() -> None:
    rosdep = FakeRosdep({"bad-pip": Rule("bad-pip", "pip", ("--index-url=http://evil",)),
                         "bad-apt": Rule("bad-apt", "apt", ("-o=APT::Get::x",))})
    plan = planner(rosdep).plan([need("bad-pip"), need("bad-apt")])
    assert plan.steps == ()
    whys = {u.need.key: u.why for u in plan.unresolved}
    assert "does not hand it to pip" in whys["bad-pip"]
    assert "'-o=APT::Get::x' is not a Debian package name" in whys["bad-apt"]


def test_the_index_is_never_asked_with_an_option() -> None:
    # no pip runs at all: the python given does not exist
    answer = query_one(Path("/nonexistent/python"), "-h", {})
    assert answer == IndexAnswer("-h", False, "'-h' is not a PEP 508 requirement, so wsbuild "
                                              "does not hand it to pip")


def test_installer_commands_put_names_after_a_double_dash() -> None:
    pip = pip_install_command(Path("/v/bin/python"), ["psutil"], Path("/c.txt"))
    assert pip[-2:] == ["--", "psutil"] and pip.index("-c") < pip.index("--")
    assert apt_install_command(["hello"], [])[-2:] == ["--", "hello"]


# ------------------------------------------------------------------- the PyPI table


def test_osrf_pycommon_comes_from_its_own_pypi_project() -> None:
    answers = {"ros-jazzy-osrf-pycommon": IndexAnswer("ros-jazzy-osrf-pycommon", False, "none")}
    keys = [need("osrf_pycommon")]
    assert python_candidates(keys) == ["osrf-pycommon"]
    plan = Planner("jazzy", answers, {"osrf-pycommon": IndexAnswer("osrf-pycommon", True)},
                   None, "not installed").plan(keys)
    (step,) = plan.steps
    assert (step.source, step.installer, step.packages) == (
        Source.PYPI_PROJECT, Installer.PIP, ("osrf-pycommon",))


def test_a_wheel_of_the_distro_comes_before_the_table() -> None:
    plan = planner(wheels=["ros-jazzy-xacro"], pythons=["xacro"]).plan([need("xacro")])
    assert plan.steps[0].source is Source.ROS_WHEEL


@pytest.mark.parametrize("key", ["launch", "rpyutils", "python_qt_binding", "cv_bridge"])
def test_look_alikes_on_pypi_are_never_installed(key: str) -> None:
    # PyPI has projects of these names (an old launch, an unrelated rpyutils, ROS 1's
    # python-qt-binding and cv-bridge): even when the index says they exist, no step uses them
    pypi_name = key.replace("_", "-")
    assert python_candidates([need(key)]) == []
    plan = planner(pythons=[pypi_name, key]).plan([need(key)])
    assert plan.steps == ()
    assert "no ros-jazzy-" in plan.unresolved[0].why


def test_the_table_maps_ros_names_to_valid_pypi_names() -> None:
    for key, project in ROS_PACKAGES_ON_PYPI.items():
        assert key.replace("_", "").isalnum() and key.islower(), key
        assert valid_pip_requirement(project) and not any(c in project for c in "<>=@ ;"), project

