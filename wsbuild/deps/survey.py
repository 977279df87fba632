"""One look at the selection and the underlay: the keys, where each comes from, the plan."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from wsbuild.deps import index
from wsbuild.deps.index import IndexAnswer
from wsbuild.deps.needs import collect_needs
from wsbuild.deps.from_source import FromSource, load_distro_sources
from wsbuild.deps.plan import (
    DepsPlan,
    Planner,
    Unresolved,
    python_candidates,
    wheel_candidates,
    wheel_name,
)
from wsbuild.deps.rosdep import load_rosdep
from wsbuild.deps.test_tools import linter_program_steps, ros_pytest_step
from wsbuild.underlay.environment import PreparedUnderlay
from wsbuild.errors import UnderlayError
from wsbuild.underlay.detect import ros_distro, venv_python
from wsbuild.underlay.environment import prepare_underlay
from wsbuild.underlay.wheels import JAZZY_WHEELS, wheel_name as jazzy_wheel_name
from wsbuild.underlay.lint import LINTERS
from wsbuild.workspace.model import DepKind, Package
from wsbuild.workspace.resolve import Resolver, ament_index, normalize_distribution
from wsbuild.workspace.resolve import python_distributions
from wsbuild.deps.system_libraries import system_library_steps
from wsbuild.words import did_you_mean


@dataclass(frozen=True, slots=True)
class Survey:
    """The plan and the facts it was made with."""

    plan: DepsPlan
    venv: Path
    python: Path
    distro: str
    rosdep_status: str
    #: where the keys available from source were looked up ("" when no key needed it)
    sources_status: str = ""


def survey(packages: Sequence[Package], workspace: Mapping[str, Package],
           kinds: frozenset[DepKind], *, environ: Mapping[str, str], shim_dir: Path,
           skip: frozenset[str] = frozenset(), refresh: bool = False) -> Survey:
    """Resolve the keys of `packages` as the build would and plan a source for each missing one."""
    importlib.invalidate_caches()  # distributions installed since the last look
    underlay = prepare_underlay(environ, executable=sys.executable, repair=False,
                                shim_dir=shim_dir, notice=lambda _text: None, dry_run=True)
    if underlay.venv is None:
        raise UnderlayError(
            "wsbuild deps installs into a virtualenv ROS underlay, and none is active",
            hint="install wsbuild with its ros extra into a virtualenv (README: Installing) "
                 "and run that virtualenv's wsbuild, or activate it")
    venv = underlay.venv
    distro = ros_distro(venv) or environ.get("ROS_DISTRO", "")
    if not distro:
        raise UnderlayError("cannot tell the ROS distribution: no ros-<distro>-* wheel in the "
                            "virtualenv and ROS_DISTRO is not set", path=venv,
                            hint="install wsbuild with its ros extra into this virtualenv, "
                                 "or set ROS_DISTRO=jazzy")
    resolver = Resolver.from_environment(underlay.environ, [venv])
    needs = collect_needs(packages, workspace, resolver, kinds, skip)
    python = venv_python(venv).executable
    rosdep, rosdep_status = load_rosdep()
    wheels = wheel_candidates(distro, needs)
    known = {name: IndexAnswer(name, True) for name in wheels if _known_wheel(distro, name)}
    answers = index.query(python, [n for n in wheels if n not in known]
                          + python_candidates(needs), environ,
                          memory=index.AnswerMemory.for_index(python, environ), refresh=refresh)
    installed = frozenset(python_distributions(resolver.python_paths))
    planner = Planner(distro=distro, wheels={**answers, **known}, pythons=answers,
                      rosdep=rosdep, rosdep_status=rosdep_status,
                      system_site_packages=_system_site_packages(venv),
                      stand_ins=_provided_by_wsbuild(underlay),
                      installed=frozenset(normalize_distribution(n) for n in installed))
    plan = planner.plan(needs)
    programs = linter_program_steps(packages, kinds, path=underlay.environ.get("PATH", ""),
                                    installed=planner.installed,
                                    stood_in=_provided_by_wsbuild(underlay))
    libraries = system_library_steps(packages, kinds)
    plan = replace(plan, steps=(*plan.steps, *programs, *libraries))
    pytest_step = ros_pytest_step(packages, python, kinds)
    if pytest_step is not None:
        plan = replace(plan, test_tools=(pytest_step,))
    memory = index.AnswerMemory.for_index(python, environ)
    plan, sources_status = _from_source(plan, distro, memory.path.parent, memory.now, refresh)
    plan = _with_close_names(plan, {*workspace, *ament_index(resolver.ament_prefixes),
                                    *(JAZZY_WHEELS if distro == "jazzy" else ())})
    return Survey(plan, venv, python, distro, rosdep_status, sources_status)


def _with_close_names(plan: DepsPlan, known: set[str]) -> DepsPlan:
    """An unresolved key close to a package name that exists (`std_msg`) says which one it
    may have meant (`std_msgs`): a misspelling, not a missing package."""
    unresolved = []
    for item in plan.unresolved:
        hint = did_you_mean(item.need.key, known - {item.need.key})
        unresolved.append(replace(item, why=f"{hint} {item.why}") if hint else item)
    return replace(plan, unresolved=tuple(unresolved))


def _from_source(plan: DepsPlan, distro: str, cache_dir: Path, now: float,
                 refresh: bool) -> tuple[DepsPlan, str]:
    """The unresolved ROS package keys the distro's index releases from a source repository
    move to `from_source`; the others say what the index answered."""
    ros_keys = [u for u in plan.unresolved if wheel_name(distro, u.need.key) is not None]
    if not ros_keys:
        return plan, ""
    sources, status = load_distro_sources(distro, cache_dir=cache_dir, now=now,
                                          refresh=refresh)
    unresolved: list[Unresolved] = []
    from_source: list[FromSource] = []
    for item in plan.unresolved:
        if item not in ros_keys:
            unresolved.append(item)
            continue
        repository = sources.repository_of(item.need.key) if sources is not None else None
        problem = repository.problem() if repository is not None else ""
        if repository is not None and not problem:
            from_source.append(FromSource(item.need.key, item.need.needed_by, repository))
            continue
        why = (problem if repository is not None
               else f"not released in the {distro} index" if sources is not None
               else "the index could not be read (see the first line)")
        unresolved.append(replace(item, why=f"{item.why}; from source: {why}"))
    return replace(plan, unresolved=tuple(unresolved), from_source=tuple(from_source)), status


def _provided_by_wsbuild(underlay: PreparedUnderlay) -> frozenset[str]:
    """Keys wsbuild answers itself: the linter CMake packages it stands in for or writes for
    an installed program, and the ament linters' Python modules that have no wheel
    (`wsbuild test` reports their tests as not installed, not run)."""
    no_wheel = [module for module in LINTERS.values() if module not in JAZZY_WHEELS]
    return frozenset((*underlay.lint_stand_ins, *underlay.lint_driven, *no_wheel))


def _known_wheel(distro: str, wheel: str) -> bool:
    """The Jazzy wheels wsbuild already knows exist on PyPI need no question to the index."""
    return distro == "jazzy" and any(jazzy_wheel_name(p) == wheel for p in JAZZY_WHEELS)


def _system_site_packages(venv: Path) -> bool:
    try:
        text = (venv / "pyvenv.cfg").read_text(encoding="utf-8")
    except OSError:
        return False
    for line in text.splitlines():
        key, _, value = line.partition("=")
        if key.strip() == "include-system-site-packages":
            return value.strip().lower() == "true"
    return False
