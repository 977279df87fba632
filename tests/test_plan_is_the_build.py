"""Issue 45: the build runs the plan's steps. A step's in-process work computes what it writes
from the context it runs with, not from values bound when the plan was made; the build takes
the plan's steps when the build type decides every field of every step the same with the
build's context, and says what differs when it does not; the builder's own work (the compiler
cache's server, the times, register, commit) is a planned, labelled step too."""

from __future__ import annotations

import os
import shutil
from dataclasses import replace
from pathlib import Path

from conftest import run_wsbuild, write_package

from wsbuild.build_types import BuildOptions, Command, Step, get_build_type, package_context
from wsbuild.record.configured import read_configured
from wsbuild.builder.package import step_differences
from wsbuild.workspace.manifest import parse_manifest


def _cmake_context(tmp_path: Path, environ: dict[str, str]):  # type: ignore[no-untyped-def]
    path = write_package(tmp_path / "src", "pkg_cmake", "cmake")
    package = parse_manifest(path / "package.xml", environ=os.environ,
                             known_build_types=("cmake",))
    build_type = get_build_type("cmake")
    build = tmp_path / "build" / package.name
    build.mkdir(parents=True, exist_ok=True)
    return build_type, package_context(
        build_type, package=package, build_dir=build,
        install_prefix=tmp_path / "install" / package.name,
        stage_prefix=tmp_path / "stage" / package.name,
        options=BuildOptions(jobs=2, python_executable=shutil.which("python3") or ""),
        environ=environ, run=lambda *a, **k: None, warn=lambda _t: None,
        facts=build_type.run_facts(environ))


def test_the_configure_record_is_what_the_build_s_context_gives_not_the_plan_s(
        tmp_path: Path) -> None:
    """The plan decides the steps with what the environment held before the run; the
    dependencies built in the run (or the run's own resources) change what the build's
    context holds. The configure record step writes what the configure ran with."""
    build_type, planned = _cmake_context(tmp_path, {**os.environ, "CC": "cc"})
    step = next(s for s in build_type.steps(planned) if s.label == "configure record")
    now = replace(planned, environ={**planned.environ, "CC": "gcc"})
    assert step.action is not None
    step.action(now)
    written = read_configured(planned.build_dir)
    assert written == build_type.configured(now)
    assert written != build_type.configured(planned)


def test_the_same_context_gives_equal_steps_every_field_included(tmp_path: Path) -> None:
    """What lets the build compare the plan's steps with the build type's answer field by
    field: in-process actions are functions and methods, equal when they are the same work."""
    build_type, ctx = _cmake_context(tmp_path, dict(os.environ))
    (ctx.build_dir / "CMakeCache.txt").write_text("CMAKE_GENERATOR:INTERNAL=Other\n")
    _, again = _cmake_context(tmp_path, dict(os.environ))
    first, second = build_type.steps(again), build_type.steps(again)
    assert [s.label for s in first][:2] == ["clean cache", "configure"]
    assert first == second
    assert step_differences(first, second) == []


def test_what_differs_between_two_decisions_is_named() -> None:
    cwd = Path("/w/build/p")
    plan = (Step("configure", command=Command(("cmake", "/w/src/p"), cwd, env={"A": "1"})),
            Step("build", command=Command(("cmake", "--build", "."), cwd)))
    other_env = (replace(plan[0], command=replace(plan[0].command, env={"A": "2"})), plan[1])
    assert step_differences(plan, other_env) == ["configure: command's env"]
    other_steps = (plan[1],)
    assert step_differences(plan, other_steps) == ["the plan's steps were configure, build"]


def test_a_build_runs_the_steps_its_plan_decided(built: Path) -> None:
    """A first build and an incremental one, of CMake and Python packages: the build type
    decides with the build's context what the plan decided, field by field."""
    (built / "src" / "pc" / "CMakeLists.txt").open("a").write("# edited\n")
    (built / "src" / "pa" / "pa" / "main.py").write_text("def main():\n    print('again')\n")
    result = run_wsbuild("build", cwd=built)
    assert result.returncode == 0, result.stdout + result.stderr
    logs = sorted((built / "log").glob("build_*/*/command.log"))
    assert {log.parent.name for log in logs} >= {"pa", "pb", "pc"}
    for log in logs:
        assert "The steps differ from the plan's" not in log.read_text(), log
