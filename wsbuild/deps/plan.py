"""The install plan: for every key nothing provides, the first source that can install it.

Sources, in this order (issue 21):

1. a `ros-<distro>-<name>` wheel on the package index pip uses, for ROS package names;
1b. the PyPI project of a ROS package that PyPI carries under its own name (`osrf_pycommon` →
   `osrf-pycommon`), from a curated table (pypi_projects.py), never guessed;
2. rosdep's rule for this OS, when rosdep and its rules cache are there: `pip` entries go to
   the venv's pip, `apt` entries to apt-get (an `apt` rule for a `python3-*` key is passed over
   when the venv does not see the system's site-packages: it would install where the underlay
   cannot import it; so is one naming `ros-<distro>-*` Debian packages, which install into
   /opt/ros, an underlay the venv does not use);
3. a `python3-*` key by convention: its PyPI distribution (`python3-psutil` → `psutil`).

Every name a step hands to pip or apt-get is checked (names.py): a key whose name would not be
one (`python3--h` → `-h`) is unresolved, never a command-line option.

Keys the build finds are satisfied; ament linters wsbuild stands in for count as found; system
keys (`libfoo-dev`) are checked through rosdep's installer when rosdep knows them, and otherwise
reported as not checked.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum

from wsbuild.deps.from_source import FromSource
from wsbuild.deps.index import IndexAnswer
from wsbuild.deps.names import invalid_name, valid_debian_package, valid_pip_requirement
from wsbuild.deps.needs import Need
from wsbuild.deps.pypi_projects import pypi_project
from wsbuild.deps.rosdep import RosdepRules, Rule
from wsbuild.workspace.model import Resolution
from wsbuild.workspace.resolve import normalize_distribution, python_distribution
from wsbuild.patterns import lazy

#: a ROS package name (REP 144): only such keys can be `ros-<distro>-*` wheels
_ROS_NAME = lazy(r"^[a-z][a-z0-9_]*$")


class Source(Enum):
    """Where the plan found a way to install a key."""

    ROS_WHEEL = "ROS wheel"
    PYPI_PROJECT = "ROS package on PyPI"
    ROSDEP = "rosdep"
    PYTHON = "Python key by convention"
    ROS_PYTEST = "the ROS tests' pytest"
    LINT_PROGRAM = "a program a linter runs"
    SYSTEM_LIBRARY = "a system library a wheel links"


class Installer(Enum):
    """The program that installs a step's packages."""

    PIP = "pip"
    APT = "apt"


@dataclass(frozen=True, slots=True)
class Step:
    """Install `packages` with `installer` to provide `need`."""

    need: Need
    source: Source
    installer: Installer
    packages: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Unresolved:
    """A key no source can install, and what each source said."""

    need: Need
    why: str


@dataclass(frozen=True, slots=True)
class DepsPlan:
    """Every key of the selection, sorted into what is there and what to do."""

    needs: tuple[Need, ...]
    steps: tuple[Step, ...]
    unresolved: tuple[Unresolved, ...]
    #: system keys nothing could check (no rosdep)
    unchecked: tuple[Need, ...]
    #: keys satisfied by a linter stand-in of wsbuild's
    stood_in: tuple[Need, ...] = ()
    #: keys the build's lookup does not find but whose rosdep rule is installed
    by_rosdep: tuple[Need, ...] = ()
    #: the pytest the packages' tests need, when it is not installed (test_tools.py)
    test_tools: tuple[Step, ...] = ()
    #: keys no installer provides that the distro's index releases from source
    from_source: tuple[FromSource, ...] = ()

    @property
    def missing(self) -> int:
        return (len(self.steps) + len(self.unresolved) + len(self.test_tools)
                + len(self.from_source))

    def by_installer(self) -> dict[Installer, list[Step]]:
        """The steps grouped by installer, pip first."""
        groups: dict[Installer, list[Step]] = {}
        for installer in Installer:
            steps = [s for s in self.steps if s.installer is installer]
            if steps:
                groups[installer] = steps
        return groups


@dataclass(slots=True)
class Planner:
    """Decides a source per missing key. `wheels`/`pythons` are the index's answers for the
    candidate distributions (see `wheel_candidates`, `python_candidates`)."""

    distro: str
    wheels: Mapping[str, IndexAnswer]
    pythons: Mapping[str, IndexAnswer]
    rosdep: RosdepRules | None
    rosdep_status: str
    #: whether the venv sees the system's site-packages (then apt's python3-* packages count)
    system_site_packages: bool = False
    stand_ins: frozenset[str] = frozenset()
    #: normalised names of the distributions installed in the venv (for rosdep's pip entries)
    installed: frozenset[str] = frozenset()
    _rules: dict[str, Rule | None] = field(default_factory=dict)

    def plan(self, needs: Sequence[Need]) -> DepsPlan:
        steps: list[Step] = []
        unresolved: list[Unresolved] = []
        unchecked: list[Need] = []
        stood_in: list[Need] = []
        by_rosdep: list[Need] = []
        for need in needs:
            if need.found:
                continue
            if need.key in self.stand_ins:
                stood_in.append(need)
                continue
            if need.resolution is Resolution.SYSTEM and self.rosdep is None:
                unchecked.append(need)
                continue
            step, why = self._source(need)
            if step is not None:
                step, why = _checked_names(step)
            if step is None and not why:
                by_rosdep.append(need)  # rosdep's rule is installed already
            elif step is not None:
                steps.append(step)
            else:
                unresolved.append(Unresolved(need, why))
        return DepsPlan(tuple(needs), tuple(steps), tuple(unresolved), tuple(unchecked),
                        tuple(stood_in), tuple(by_rosdep))

    def _source(self, need: Need) -> tuple[Step | None, str]:
        """The first source's step; (None, "") when rosdep's rule is installed already;
        (None, why) when no source can install the key."""
        tried: list[str] = []
        wheel = wheel_name(self.distro, need.key)
        if wheel is not None and need.resolution is Resolution.UNRESOLVED:
            answer = self.wheels.get(wheel)
            if answer is not None and answer.exists:
                return Step(need, Source.ROS_WHEEL, Installer.PIP, (wheel,)), ""
            tried.append(f"no {wheel} wheel ({answer.detail if answer else 'not asked'})")
        project = pypi_project(need.key)
        if project is not None and need.resolution is Resolution.UNRESOLVED:
            answer = self.pythons.get(project)
            if answer is not None and answer.exists:
                return Step(need, Source.PYPI_PROJECT, Installer.PIP, (project,)), ""
            tried.append(f"no PyPI project {project} "
                         f"({answer.detail if answer else 'not asked'})")
        step, why = self._rosdep(need)
        if step is not None or not why:
            return step, ""
        tried.append(why)
        distribution = python_distribution(need.key)
        if distribution is not None and not valid_pip_requirement(distribution):
            tried.append(invalid_name("pip", distribution))
        elif distribution is not None and need.resolution is Resolution.UNRESOLVED:
            answer = self.pythons.get(distribution)
            if answer is not None and answer.exists:
                return Step(need, Source.PYTHON, Installer.PIP, (distribution,)), ""
            tried.append(f"no Python distribution {distribution} "
                         f"({answer.detail if answer else 'not asked'})")
        elif distribution is None:
            tried.append("not a python3-* key")
        return None, "; ".join(tried)

    def _rule(self, key: str) -> Rule | None:
        if key not in self._rules:
            self._rules[key] = self.rosdep.rule(key) if self.rosdep is not None else None
        return self._rules[key]

    def _rosdep(self, need: Need) -> tuple[Step | None, str]:
        """rosdep's step for `need`; (None, "") when its packages are installed already."""
        if self.rosdep is None:
            return None, f"rosdep: {self.rosdep_status}"
        rule = self._rule(need.key)
        if rule is None:
            return None, f"rosdep has no rule for {need.key}"
        if rule.problem:
            return None, rule.problem
        if rule.installer == "pip":
            missing = [p for p in rule.packages
                       if normalize_distribution(_requirement_name(p)) not in self.installed]
            return (Step(need, Source.ROSDEP, Installer.PIP, tuple(missing)) if missing
                    else None), ""
        if rule.installer == "apt":
            if need.key.startswith("python3-") and not self.system_site_packages:
                return None, (f"rosdep's apt rule ({' '.join(rule.packages)}) installs into the "
                              "system Python, which the virtualenv does not see")
            ros_debs = [p for p in rule.packages if p.startswith(f"ros-{self.distro}-")]
            if ros_debs:
                return None, (f"rosdep's apt rule ({' '.join(ros_debs)}) installs into "
                              f"/opt/ros/{self.distro}, which the virtualenv underlay does not "
                              "use")
            missing = self.rosdep.missing_system_packages("apt", rule.packages)
            return (Step(need, Source.ROSDEP, Installer.APT, tuple(missing)) if missing
                    else None), ""
        return None, (f"rosdep's rule uses the '{rule.installer}' installer, which wsbuild does "
                      f"not run (rosdep install can)")


def _checked_names(step: Step) -> tuple[Step | None, str]:
    """`step` when every package is a name its installer takes; else (None, why)."""
    valid = valid_pip_requirement if step.installer is Installer.PIP else valid_debian_package
    bad = [p for p in step.packages if not valid(p)]
    if bad:
        return None, invalid_name(step.installer.value, bad[0])
    return step, ""


def _requirement_name(requirement: str) -> str:
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0]


def wheel_name(distro: str, key: str) -> str | None:
    """`sensor_msgs` -> `ros-jazzy-sensor-msgs`; None for keys that are no ROS package name."""
    if not _ROS_NAME.match(key):
        return None
    return f"ros-{distro}-{key.replace('_', '-')}"


def wheel_candidates(distro: str, needs: Iterable[Need]) -> list[str]:
    """The wheels to ask the index about: one per unresolved ROS package name."""
    names = (wheel_name(distro, n.key) for n in needs if n.resolution is Resolution.UNRESOLVED)
    return sorted({n for n in names if n is not None})


def python_candidates(needs: Iterable[Need]) -> list[str]:
    """The distributions to ask the index about: one per unresolved `python3-*` key or ROS
    package of the PyPI table (names pip would not take as a requirement are never asked)."""
    unresolved = [n.key for n in needs if n.resolution is Resolution.UNRESOLVED]
    names = [*(python_distribution(k) for k in unresolved), *(pypi_project(k) for k in unresolved)]
    return sorted({n for n in names if n is not None and valid_pip_requirement(n)})
