"""testing.py: pytest and CTest per package against the built workspace, results and summary."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from conftest import run_wsbuild, write_package
from wsbuild.errors import WorkspaceError
from wsbuild.events import Event, JobFinished, Notice
from wsbuild.workspace.graph import build_graph
from wsbuild.build_types.junit import Case, CaseOutcome, Counts, read_junit
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.workspace.model import Dependency, DepKind, Package
from wsbuild.workspace.selection import Selection
from wsbuild.prefix.layout import resolve_layout
from wsbuild.testing.results import (
    PackageStatus, PackageTests, TestRun, results_dir, summary_lines,
)
from wsbuild.testing.closure import check_built, closure_under_test
from wsbuild.testing.request import TestRequest
from wsbuild.testing.test_run import run_tests
from wsbuild.verbs.load import LoadRequest, load
from wsbuild.workspace.selection import SelectionOptions
from wsbuild.workspace.root import Workspace

FLAKY_TEST = '''from pathlib import Path

HERE = Path(__file__).parent


def test_follows_the_plan():
    runs = HERE / "runs.txt"
    count = int(runs.read_text()) if runs.exists() else 0
    runs.write_text(str(count + 1))
    plan = (HERE / "plan.txt").read_text().split()
    assert plan[min(count, len(plan) - 1)] == "pass"
'''

CM_CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(cm NONE)
enable_testing()
add_test(NAME ok COMMAND true)
# colcon puts the package's own install on the test environment
add_test(NAME sees_own_install COMMAND sh -c "echo $CMAKE_PREFIX_PATH | grep -q install/cm")
install(FILES package.xml DESTINATION share/cm)
"""

CM_BAD_CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(cm_bad NONE)
enable_testing()
add_test(NAME fine COMMAND true)
add_test(NAME broke COMMAND sh -c "echo the widget broke; exit 2")
add_test(NAME absent COMMAND /nonexistent/test_program)
add_test(NAME not_here COMMAND sh -c "exit 77")
set_tests_properties(not_here PROPERTIES SKIP_RETURN_CODE 77)
install(FILES package.xml DESTINATION share/cm_bad)
"""


def _write_tests(package: Path, files: Mapping[str, str]) -> None:
    (package / "test").mkdir(exist_ok=True)
    for name, text in files.items():
        (package / "test" / name).write_text(text)


@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A workspace of every kind of package, built once with the real command line."""
    root = tmp_path_factory.mktemp("testing_ws")
    src = root / "src"
    _write_tests(write_package(src, "good"), {"test_good.py": (
        "import importlib.metadata\n\n"
        "def test_installed_metadata_is_visible():\n"
        "    assert importlib.metadata.version('good') == '0.1.0'\n")})
    _write_tests(write_package(src, "bad", deps=["good"]), {"test_bad.py": (
        "from good.main import main\n\n"
        "def test_uses_its_dependency():\n    main()\n\n"
        "def test_math():\n    assert 1 + 1 == 3, 'arithmetic is broken'\n")})
    _write_tests(write_package(src, "broken"), {"test_broken.py": (
        "import not_a_module\n\ndef test_never():\n    pass\n")})
    write_package(src, "empty")
    flaky = write_package(src, "flaky")
    _write_tests(flaky, {"test_flaky.py": FLAKY_TEST, "plan.txt": "pass"})
    (write_package(src, "cm", "cmake") / "CMakeLists.txt").write_text(CM_CMAKELISTS)
    (write_package(src, "cm_bad", "cmake") / "CMakeLists.txt").write_text(CM_BAD_CMAKELISTS)
    write_package(src, "cm_none", "cmake")  # no enable_testing()
    plain = src / "plainpy"
    (plain / "plainpy").mkdir(parents=True)
    (plain / "plainpy" / "__init__.py").write_text("ANSWER = 42\n")
    (plain / "setup.cfg").write_text("[metadata]\nname = plainpy\nversion = 1.0\n\n"
                                     "[options]\npackages = plainpy\n")
    (plain / "setup.py").write_text("from setuptools import setup\nsetup()\n")
    _write_tests(plain, {"test_plain.py": "from plainpy import ANSWER\n\n"
                                          "def test_answer():\n    assert ANSWER == 42\n"})
    built = run_wsbuild("build", cwd=root)
    assert built.returncode == 0, built.stdout + built.stderr
    return root


def plan_for(root: Path, *names: str) -> Selection:
    loaded = load(LoadRequest(workspace_dir=str(root),
                              selection=SelectionOptions(packages_select=names or None)))
    return Selection(loaded.workspace, loaded.packages, loaded.graph, loaded.selected)


def run(root: Path, *names: str, **options: object) -> tuple[dict[str, PackageTests], TestRun,
                                                            list[Event]]:
    events: list[Event] = []
    request = TestRequest(workers=2, **options)  # type: ignore[arg-type]
    result = run_tests(plan_for(root, *names), request, events.append)
    return {r.package: r for r in result.results}, result, events


def test_every_package_is_tested_by_its_build_type(ws: Path) -> None:
    names = ("good", "bad", "broken", "empty", "cm", "cm_bad", "cm_none", "plainpy")
    results, test_run, events = run(ws, *names)
    status = {name: r.status for name, r in results.items()}
    assert status == {
        "good": PackageStatus.PASSED, "bad": PackageStatus.FAILED,
        "broken": PackageStatus.FAILED, "empty": PackageStatus.NO_TESTS,
        "cm": PackageStatus.PASSED, "cm_bad": PackageStatus.FAILED,
        "cm_none": PackageStatus.NO_TESTS, "plainpy": PackageStatus.PASSED,
    }
    assert results["bad"].counts == Counts(tests=2, failures=1)
    assert [c.full_name for c in results["bad"].problems] == ["bad.test.test_bad.test_math"]
    assert results["broken"].counts == Counts(tests=1, errors=1)
    assert results["cm"].counts == Counts(tests=2)
    assert results["cm_bad"].counts == Counts(tests=4, errors=1, failures=1, skipped=1)
    problems = {c.name: (c.outcome, c.headline) for c in results["cm_bad"].problems}
    assert problems == {"broke": (CaseOutcome.FAILURE, "Failed: the widget broke"),
                        "absent": (CaseOutcome.ERROR, "Unable to find executable")}
    assert test_run.failed and not test_run.interrupted
    assert test_run.counts == Counts(tests=11, errors=2, failures=2, skipped=1)
    # the reporter sees failing tests as a failed package with its log, and "no tests" said
    shown = {e.result.package: e.result for e in events if isinstance(e, JobFinished)}
    assert shown["bad"].outcome is Outcome.FAILED and shown["bad"].message == "1 failure"
    assert shown["bad"].log_dir == results["bad"].log_dir
    assert shown["empty"].outcome is Outcome.FINISHED
    assert Notice("no tests found by pytest", package="empty") in events
    log = results["bad"].log_dir / "stdout_stderr.log"
    assert "arithmetic is broken" in log.read_text()


def test_results_are_junit_files_in_the_build_directory(ws: Path) -> None:
    results, _, _ = run(ws, "bad", "cm_bad", "empty")
    workspace = Workspace.at(ws)
    for name, files in (("bad", ["pytest.xml"]), ("cm_bad", ["ctest.xml"]),
                        ("empty", ["pytest.xml"])):
        folder = ws / "build" / name / "test_results" / name
        assert results_dir(workspace, name, None) == folder
        assert sorted(p.name for p in folder.iterdir()) == files
        assert results[name].result_files == tuple(folder / f for f in files)
    assert read_junit(ws / "build/bad/test_results/bad/pytest.xml").counts == \
        Counts(tests=2, failures=1)
    assert read_junit(ws / "build/cm_bad/test_results/cm_bad/ctest.xml").counts == \
        Counts(tests=4, errors=1, failures=1, skipped=1)


def test_test_result_base_takes_colcons_layout(ws: Path, tmp_path: Path) -> None:
    results, _, _ = run(ws, "good", "cm", test_result_base=tmp_path / "results")
    assert results["good"].result_files == (tmp_path / "results" / "good" / "pytest.xml",)
    assert results["cm"].result_files == (tmp_path / "results" / "cm" / "ctest.xml",)


def test_a_pytest_that_cannot_start_is_an_error_not_a_pass(ws: Path, tmp_path: Path) -> None:
    results, _, _ = run(ws, "good", tool_arguments={"pytest": ("--no-such-option",)},
                        test_result_base=tmp_path)
    good = results["good"]
    assert good.status is PackageStatus.FAILED
    (problem,) = good.problems
    assert problem.message == "pytest exited with code 4 without writing results"
    assert "--no-such-option" in problem.details
    # the file says so too, for `wsbuild test-result` and CI
    assert read_junit(tmp_path / "good" / "pytest.xml").counts == Counts(tests=1, errors=1)


def test_pytest_args_reach_pytest(ws: Path, tmp_path: Path) -> None:
    results, _, _ = run(ws, "bad", tool_arguments={"pytest": ("-k", "not test_math")},
                        test_result_base=tmp_path)
    assert results["bad"].status is PackageStatus.PASSED
    assert results["bad"].counts == Counts(tests=1)


def test_ctest_args_reach_ctest(ws: Path, tmp_path: Path) -> None:
    results, _, _ = run(ws, "cm_bad", tool_arguments={"ctest": ("-R", "^fine$")},
                        test_result_base=tmp_path)
    assert results["cm_bad"].status is PackageStatus.PASSED
    assert results["cm_bad"].counts == Counts(tests=1)
    results, _, _ = run(ws, "cm_bad", tool_arguments={"ctest": ("-R", "^nothing_matches$")},
                        test_result_base=tmp_path)
    assert results["cm_bad"].status is PackageStatus.NO_TESTS


def test_a_packages_own_arguments_come_after_the_command_lines(ws: Path, tmp_path: Path) -> None:
    """colcon.meta's arguments of a package extend the command line's: pytest's later `-k`
    wins; another package's, or another tool's, reach nothing."""
    results, _, _ = run(ws, "bad", tool_arguments={"pytest": ("-k", "nothing_matches")},
                        package_arguments={"bad": {"pytest": ("-k", "not test_math")}},
                        test_result_base=tmp_path)
    assert (results["bad"].status, results["bad"].counts) == (PackageStatus.PASSED, Counts(tests=1))
    results, _, _ = run(ws, "bad", package_arguments={"good": {"pytest": ("-k", "not test_math")},
                                                      "bad": {"ctest": ("-R", "^fine$")}},
                        test_result_base=tmp_path)
    assert (results["bad"].status, results["bad"].counts) == \
        (PackageStatus.FAILED, Counts(tests=2, failures=1))


def test_only_a_packages_own_tools_arguments_enter_its_test_key(ws: Path, tmp_path: Path) -> None:
    options: dict[str, object] = {"test_result_base": tmp_path}
    first, _, _ = run(ws, "good", "cm", **options)
    assert not first["good"].cached and not first["cm"].cached
    others = {"good": {"ctest": ("-V",)}, "cm": {"pytest": ("-v",)}}
    again, _, _ = run(ws, "good", "cm", package_arguments=others, **options)
    assert again["good"].cached and again["cm"].cached
    own, _, _ = run(ws, "good", "cm", package_arguments={"good": {"pytest": ("-v",)}}, **options)
    assert not own["good"].cached and own["good"].status is PackageStatus.PASSED
    assert own["cm"].cached


def _plan(ws: Path, outcomes: str) -> None:
    test_dir = ws / "src" / "flaky" / "test"
    (test_dir / "runs.txt").unlink(missing_ok=True)
    (test_dir / "plan.txt").write_text(outcomes)


def test_retest_until_pass_reruns_a_failing_package_and_calls_it_flaky(ws: Path) -> None:
    _plan(ws, "fail pass")
    results, test_run, _ = run(ws, "flaky", retest_until_pass=3)
    flaky = results["flaky"]
    assert (flaky.status, flaky.attempts, flaky.max_attempts, flaky.flaky) == \
        (PackageStatus.PASSED, 2, 4, True)
    assert not test_run.failed
    assert "  flaky: flaky passed on attempt 2 of 4" in summary_lines(test_run, shown=ws)
    _plan(ws, "fail")
    results, test_run, _ = run(ws, "flaky", retest_until_pass=1)
    assert (results["flaky"].status, results["flaky"].attempts) == (PackageStatus.FAILED, 2)
    assert test_run.failed


def test_retest_until_fail_reruns_a_passing_package_until_it_fails(ws: Path) -> None:
    _plan(ws, "pass fail")
    results, _, _ = run(ws, "flaky", retest_until_fail=3)
    flaky = results["flaky"]
    assert (flaky.status, flaky.attempts, flaky.flaky) == (PackageStatus.FAILED, 2, True)
    _plan(ws, "pass")
    results, _, _ = run(ws, "flaky", retest_until_fail=1)
    flaky = results["flaky"]
    assert (flaky.status, flaky.attempts, flaky.flaky) == (PackageStatus.PASSED, 2, False)


def test_abort_on_error_starts_nothing_after_a_failure(ws: Path) -> None:
    events: list[Event] = []
    test_run = run_tests(plan_for(ws, "broken", "empty", "good"),
                         TestRequest(workers=1, abort_on_error=True), events.append)
    status = {r.package: r.status for r in test_run.results}
    assert status == {"broken": PackageStatus.FAILED, "empty": PackageStatus.NOT_RUN,
                      "good": PackageStatus.NOT_RUN}
    assert test_run.failed


def test_packages_that_are_not_built_are_refused_all_at_once(
        make_workspace: Callable[..., Path]) -> None:
    root = make_workspace({"app": ("ament_python", [], {"test_depend": ["helper"]}),
                           "helper": ("ament_python", []), "lib": ("cmake", [])})
    plan = plan_for(root, "app", "lib")
    with pytest.raises(WorkspaceError) as raised:
        check_built(plan, merged=False)
    assert raised.value.message == "not built: app; helper (needed to test app); lib"
    assert raised.value.hint == "build first: wsbuild build --packages-up-to app helper lib"
    assert raised.value.exit_code == 2


def test_the_install_layout_comes_from_install_unless_given(tmp_path: Path) -> None:
    install = Workspace.at(tmp_path).install_base
    assert resolve_layout(install, None, verb="test") is False
    install.mkdir()
    (install / ".colcon_install_layout").write_text("merged\n")
    assert resolve_layout(install, None, verb="test") is True
    assert resolve_layout(install, True, verb="test") is True
    (install / ".colcon_install_layout").write_text("isolated\n")
    with pytest.raises(WorkspaceError, match="isolated install") as raised:
        resolve_layout(install, True, verb="test")
    assert raised.value.hint == "test without --merge-install, as the workspace was built"


def _package(name: str, **deps: list[str]) -> Package:
    kinds = {"build": DepKind.BUILD, "run": DepKind.EXEC, "test": DepKind.TEST}
    return Package(name=name, path=Path(name), build_type="ament_python", dependencies=tuple(
        Dependency(dep, kinds[kind]) for kind, names in deps.items() for dep in names))


def test_the_test_environment_holds_direct_dependencies_and_their_run_dependencies() -> None:
    graph = build_graph({p.name: p for p in (
        _package("app", build=["lib"], test=["fixture"]),
        _package("lib", run=["runtime"], build=["codegen"]),
        _package("fixture", run=["helper"]),
        _package("runtime"), _package("codegen"), _package("helper"), _package("unrelated"),
    )})
    assert closure_under_test(graph, "app") == {"lib", "runtime", "fixture", "helper"}
    assert closure_under_test(graph, "lib") == {"runtime", "codegen"}


def test_summary_names_every_failing_test_with_its_log(tmp_path: Path) -> None:
    failure = Case(name="test_math", classname="bad.test.test_bad", outcome=CaseOutcome.FAILURE,
                   message="AssertionError: arithmetic is broken\nassert 2 == 3")
    error = Case(name="test.test_broken", classname="broken", outcome=CaseOutcome.ERROR,
                 message="collection failure",
                 details="E   ModuleNotFoundError: No module named 'x'")
    test_run = TestRun((
        PackageTests("bad", PackageStatus.FAILED, Counts(tests=2, failures=1), (failure,),
                     log_dir=tmp_path / "log" / "test_1" / "bad"),
        PackageTests("broken", PackageStatus.FAILED, Counts(tests=1, errors=1), (error,),
                     log_dir=tmp_path / "log" / "test_1" / "broken"),
        PackageTests("empty", PackageStatus.NO_TESTS),
        PackageTests("good", PackageStatus.PASSED, Counts(tests=3, skipped=1)),
        PackageTests("later", PackageStatus.NOT_RUN),
    ), seconds=1.5)
    assert summary_lines(test_run, shown=tmp_path) == [
        "Summary: 4 packages tested, 6 tests, 1 error, 1 failure, 1 skipped [1.50s]",
        "  1 package passed: good",
        "  1 package without tests: empty",
        "  2 packages failed: bad broken",
        "  1 package not tested: later",
        "Failed tests:",
        "  bad: 2 tests, 0 errors, 1 failure, 0 skipped (log: log/test_1/bad/stdout_stderr.log)",
        "    FAILED bad.test.test_bad.test_math - AssertionError: arithmetic is broken",
        "  broken: 1 test, 1 error, 0 failures, 0 skipped "
        "(log: log/test_1/broken/stdout_stderr.log)",
        "    ERROR broken.test.test_broken - collection failure: ModuleNotFoundError: "
        "No module named 'x'",
    ]


def test_an_internal_error_in_a_job_is_a_failed_package() -> None:
    from wsbuild.testing.test_run import _final

    result = _final(JobResult("pkg", Outcome.FAILED, message="internal error (a bug)"), None)
    assert (result.status, result.message) == (PackageStatus.FAILED, "internal error (a bug)")
