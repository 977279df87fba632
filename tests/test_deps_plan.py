"""wsbuild/deps/plan.py and needs.py: which source each missing key gets, in the issue's order
(ROS wheel, rosdep's rule, python3-* by convention), and what is said when none can."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pytest

from wsbuild.deps.index import IndexAnswer
from wsbuild.deps.needs import Need, parse_types
from wsbuild.deps.plan import Installer, Planner, Source, python_candidates, wheel_candidates
from wsbuild.deps.rosdep import Rule
from wsbuild.errors import WsbuildError
from wsbuild.workspace.model import DepKind, Resolution


def need(key: str, resolution: Resolution = Resolution.UNRESOLVED) -> Need:
    return Need(key, ("pkg",), (DepKind.EXEC,), resolution)


class FakeRosdep:
    """rosdep's rules as a dict; `installed` are the apt packages dpkg would report."""

    platform = "debian:bookworm"

    def __init__(self, rules: dict[str, Rule], installed: Sequence[str] = ()) -> None:
        self.rules = rules
        self.installed = set(installed)

    def rule(self, key: str) -> Rule | None:
        return self.rules.get(key)

    def missing_system_packages(self, installer_key: str, packages: Sequence[str]) -> list[str]:
        return [p for p in packages if p not in self.installed]


def planner(rosdep: FakeRosdep | None = None, *, wheels: Sequence[str] = (),
            pythons: Sequence[str] = (), **kwargs: object) -> Planner:
    return Planner(
        distro="jazzy",
        wheels={w: IndexAnswer(w, True) for w in wheels},
        pythons={p: IndexAnswer(p, True) for p in pythons},
        rosdep=rosdep,  # type: ignore[arg-type]
        rosdep_status="not installed",
        **kwargs,  # type: ignore[arg-type]
    )


def test_a_ros_name_goes_to_its_wheel_before_rosdep() -> None:
    rosdep = FakeRosdep({"sensor_msgs": Rule("sensor_msgs", "apt", ("ros-jazzy-sensor-msgs",))})
    plan = planner(rosdep, wheels=["ros-jazzy-sensor-msgs"]).plan([need("sensor_msgs")])
    (step,) = plan.steps
    assert (step.source, step.installer, step.packages) == (
        Source.ROS_WHEEL, Installer.PIP, ("ros-jazzy-sensor-msgs",))


def test_rosdep_comes_before_the_python_convention() -> None:
    rosdep = FakeRosdep({"python3-serial": Rule("python3-serial", "pip", ("pyserial",))})
    plan = planner(rosdep, pythons=["pyserial"]).plan([need("python3-serial")])
    assert plan.steps[0].source is Source.ROSDEP and plan.steps[0].packages == ("pyserial",)


def test_python_keys_by_convention_use_the_map_of_names_that_differ() -> None:
    plan = planner(pythons=["psutil", "pyyaml"]).plan([need("python3-psutil"),
                                                       need("python3-yaml")])
    assert [(s.need.key, s.source, s.packages) for s in plan.steps] == [
        ("python3-psutil", Source.PYTHON, ("psutil",)),
        ("python3-yaml", Source.PYTHON, ("pyyaml",)),
    ]


def test_an_apt_rule_for_a_python_key_is_passed_over_in_a_venv_without_system_packages() -> None:
    rosdep = FakeRosdep({"python3-psutil": Rule("python3-psutil", "apt", ("python3-psutil",))})
    plan = planner(rosdep, pythons=["psutil"]).plan([need("python3-psutil")])
    assert plan.steps[0].source is Source.PYTHON
    seen = planner(rosdep, pythons=["psutil"], system_site_packages=True)
    assert seen.plan([need("python3-psutil")]).steps[0].installer is Installer.APT


def test_an_apt_rule_naming_ros_debian_packages_is_passed_over() -> None:
    rosdep = FakeRosdep({"turtlesim": Rule("turtlesim", "apt", ("ros-jazzy-turtlesim",))})
    (item,) = planner(rosdep).plan([need("turtlesim")]).unresolved
    assert "installs into /opt/ros/jazzy, which the virtualenv underlay does not use" in item.why


def test_system_keys_are_checked_through_rosdep_or_reported_as_not_checked() -> None:
    rosdep = FakeRosdep({"libfoo-dev": Rule("libfoo-dev", "apt", ("libfoo-dev", "libbar")),
                         "libok-dev": Rule("libok-dev", "apt", ("libok-dev",))},
                        installed=["libbar", "libok-dev"])
    keys = [need("libfoo-dev", Resolution.SYSTEM), need("libok-dev", Resolution.SYSTEM)]
    plan = planner(rosdep).plan(keys)
    assert [(s.need.key, s.packages) for s in plan.steps] == [("libfoo-dev", ("libfoo-dev",))]
    assert [n.key for n in plan.by_rosdep] == ["libok-dev"]
    assert [n.key for n in planner(None).plan(keys).unchecked] == ["libfoo-dev", "libok-dev"]


def test_unresolved_keys_say_what_each_source_answered() -> None:
    answers = {"ros-jazzy-nowhere": IndexAnswer("ros-jazzy-nowhere", False,
                                                "ERROR: No matching distribution found")}
    plan = Planner("jazzy", answers, {}, None, "not installed (pip install rosdep)").plan(
        [need("nowhere")])
    (item,) = plan.unresolved
    assert item.why == ("no ros-jazzy-nowhere wheel (ERROR: No matching distribution found); "
                        "rosdep: not installed (pip install rosdep); not a python3-* key")


def test_found_keys_and_stand_ins_need_nothing() -> None:
    plan = planner(stand_ins=frozenset({"ament_lint_auto"})).plan(
        [need("rclpy", Resolution.AMENT_INDEX), need("ament_lint_auto")])
    assert plan.steps == () and plan.unresolved == ()
    assert [n.key for n in plan.stood_in] == ["ament_lint_auto"]


def test_candidates_to_ask_the_index_about() -> None:
    keys = [need("sensor_msgs"), need("python3-yaml"), need("libx-dev", Resolution.SYSTEM),
            need("rclpy", Resolution.AMENT_INDEX)]
    assert wheel_candidates("kilted", keys) == ["ros-kilted-sensor-msgs"]
    assert python_candidates(keys) == ["pyyaml"]


def test_types() -> None:
    assert parse_types("build") == {DepKind.BUILD, DepKind.BUILDTOOL}
    assert DepKind.TEST in parse_types(None) and DepKind.DOC not in parse_types(None)
    with pytest.raises(WsbuildError, match="unknown dependency type in --types: exec"):
        parse_types("build,exec")


def test_a_wheel_that_links_a_system_library_asks_for_its_development_package(
        tmp_path: Path) -> None:
    """The tracetools wheel links -llttng-ust, which nothing declares: a package building
    against it (rclcpp from source, or a node of the user's) needs liblttng-ust-dev, unless
    the library is there; a package that only runs with it needs nothing."""
    from wsbuild.deps.plan import Installer, Source
    from wsbuild.deps.system_libraries import system_library_steps
    from wsbuild.workspace.model import Dependency, DepKind, Package

    def package(name: str, kind: DepKind) -> Package:
        return Package(name, tmp_path / name, "ament_cmake",
                       dependencies=(Dependency("tracetools", kind),))

    empty, full = tmp_path / "lib", tmp_path / "lib64"
    empty.mkdir()
    full.mkdir()
    (full / "liblttng-ust.so").write_text("")
    kinds = frozenset(DepKind)
    users = [package("wsb_rclcpp", DepKind.BUILD), package("runs_it", DepKind.EXEC)]
    [step] = system_library_steps(users, kinds, directories=(str(empty),))
    assert (step.need.key, step.need.needed_by, step.source, step.installer, step.packages) == (
        "liblttng-ust-dev", ("wsb_rclcpp",), Source.SYSTEM_LIBRARY, Installer.APT,
        ("liblttng-ust-dev",))
    assert system_library_steps(users, kinds, directories=(str(full),)) == []
    assert system_library_steps(users, frozenset({DepKind.EXEC}),
                                directories=(str(empty),)) == []
