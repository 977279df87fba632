"""junit.py: pytest/gtest/CTest results read, JUnit written, results crawled and summarised."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from wsbuild.build_types.ctest import ament_result_file, read_ctest_junit, read_ctest_xml
from wsbuild.build_types.junit import (
    BadResultFile, Case, CaseOutcome, Counts, NotJUnit, ResultFile, read_junit, write_junit,
)
from wsbuild.testing.junit import (
    Collected, case_details, collect_results, report_lines,
)

PYTEST_TESTS = '''
import pytest

def test_passes():
    assert True

def test_fails():
    value = 1
    assert value == 2, "value should be two"

@pytest.mark.skip(reason="not today")
def test_skipped():
    pass

@pytest.fixture
def broken():
    raise RuntimeError("fixture exploded")

def test_errors(broken):
    pass
'''

# what gtest writes (run_test.py prefixes the classname with the package name)
GTEST_XML = """<?xml version="1.0" encoding="UTF-8"?>
<testsuites tests="3" failures="1" disabled="1" errors="0" time="0.001" name="AllTests">
  <testsuite name="Limits" tests="3" failures="1" disabled="1" skipped="0" errors="0" time="0.001">
    <testcase name="Clamps" file="/ws/src/lib/test/test_limits.cpp" line="5" status="run" result="completed" time="0." classname="lib.Limits" />
    <testcase name="Rejects" file="/ws/src/lib/test/test_limits.cpp" line="12" status="run" result="completed" time="0." classname="lib.Limits">
      <failure message="/ws/src/lib/test/test_limits.cpp:14&#x0A;Expected equality of these values:&#x0A;  clamp(5)&#x0A;    Which is: 5&#x0A;  3" type=""><![CDATA[/ws/src/lib/test/test_limits.cpp:14
Expected equality of these values:
  clamp(5)
    Which is: 5
  3]]></failure>
    </testcase>
    <testcase name="DISABLED_Later" file="/ws/src/lib/test/test_limits.cpp" line="20" status="notrun" result="suppressed" time="0." classname="lib.Limits" />
  </testsuite>
</testsuites>
"""

CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(probe NONE)
enable_testing()
add_test(NAME ok COMMAND true)
add_test(NAME bad COMMAND sh -c "echo it broke; exit 3")
add_test(NAME missing COMMAND /nonexistent/program)
add_test(NAME skip_me COMMAND sh -c "exit 77")
set_tests_properties(skip_me PROPERTIES SKIP_RETURN_CODE 77)
add_test(NAME switched_off COMMAND true)
set_tests_properties(switched_off PROPERTIES DISABLED TRUE)
"""


def outcomes(result: ResultFile) -> dict[str, CaseOutcome]:
    return {case.name: case.outcome for case in result.cases}


@pytest.fixture(scope="module")
def pytest_xml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A result file written by a real pytest run, as `wsbuild test` runs it."""
    root = tmp_path_factory.mktemp("pytest_run")
    (root / "test_probe.py").write_text(PYTEST_TESTS)
    junit = root / "pytest.xml"
    subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--tb=short",
                    f"--junit-xml={junit}", "--junit-prefix=probe", "test_probe.py"],
                   cwd=root, capture_output=True, check=False)
    return junit


@pytest.fixture(scope="module")
def ctest_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A CMake build directory where CTest ran, writing JUnit (--output-junit) and Test.xml."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed")
    root = tmp_path_factory.mktemp("ctest_run")
    (root / "src").mkdir()
    (root / "src" / "CMakeLists.txt").write_text(CMAKELISTS)
    build = root / "build"
    build.mkdir()
    subprocess.run(["cmake", str(root / "src")], cwd=build, capture_output=True, check=True)
    done = subprocess.run(["ctest", "-T", "Test", "--output-junit", str(root / "junit.xml")],
                          cwd=build, capture_output=True, text=True, check=False)
    assert done.returncode == 8, done.stdout + done.stderr  # CTest: some tests failed
    return root


def test_pytest_results_are_read_case_by_case(pytest_xml: Path) -> None:
    result = read_junit(pytest_xml)
    assert result.counts == Counts(tests=4, errors=1, failures=1, skipped=1)
    assert outcomes(result) == {
        "test_passes": CaseOutcome.PASSED, "test_fails": CaseOutcome.FAILURE,
        "test_skipped": CaseOutcome.SKIPPED, "test_errors": CaseOutcome.ERROR,
    }
    failed = next(c for c in result.cases if c.name == "test_fails")
    assert failed.full_name == "probe.test_probe.test_fails"
    assert failed.headline == "AssertionError: value should be two"
    assert "test_probe.py:9" in failed.details
    errored = next(c for c in result.cases if c.name == "test_errors")
    assert "RuntimeError: fixture exploded" in errored.headline


def test_a_collection_error_names_the_missing_module(tmp_path: Path) -> None:
    (tmp_path / "test_imports.py").write_text(
        "import no_such_module_here\n\ndef test_x():\n    pass\n")
    junit = tmp_path / "pytest.xml"
    subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider",
                    f"--junit-xml={junit}", "--junit-prefix=pkg"],
                   cwd=tmp_path, capture_output=True, check=False)
    result = read_junit(junit)
    assert result.counts == Counts(tests=1, errors=1)
    (case,) = result.problems()
    assert case.full_name == "pkg.test_imports"
    assert case.headline == \
        "collection failure: ModuleNotFoundError: No module named 'no_such_module_here'"


def test_gtest_failures_and_disabled_tests(tmp_path: Path) -> None:
    path = tmp_path / "test_limits.gtest.xml"
    path.write_text(GTEST_XML)
    result = read_junit(path)
    assert result.counts == Counts(tests=3, failures=1, skipped=1)
    (failed,) = result.problems()
    assert failed.full_name == "lib.Limits.Rejects"
    assert failed.label == "lib.Limits Rejects (/ws/src/lib/test/test_limits.cpp:12)"
    assert failed.headline == "/ws/src/lib/test/test_limits.cpp:14"
    assert "Which is: 5" in failed.details


def test_suites_without_cases_are_counted_from_their_attributes(tmp_path: Path) -> None:
    path = tmp_path / "summary.xml"
    path.write_text('<testsuites><testsuite name="a" tests="5" failures="1" errors="2" skip="1"/>'
                    '<testsuite name="b" tests="2" failures="0" disabled="1"/></testsuites>')
    assert read_junit(path).counts == Counts(tests=7, errors=2, failures=1, skipped=2)


def test_other_xml_is_not_junit_and_broken_xml_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "package.xml").write_text("<package><name>x</name></package>")
    with pytest.raises(NotJUnit):
        read_junit(tmp_path / "package.xml")
    (tmp_path / "cut.xml").write_text("<testsuite tests='1'")
    with pytest.raises(BadResultFile, match="malformed"):
        read_junit(tmp_path / "cut.xml")
    (tmp_path / "bad.xml").write_text("<testsuite tests='many' failures='0'/>")
    with pytest.raises(BadResultFile, match="not an integer"):
        read_junit(tmp_path / "bad.xml")


def test_ctest_junit_counts_a_test_that_could_not_run_as_an_error(ctest_run: Path) -> None:
    # CTest's own JUnit files a missing executable under <skipped>, yet CTest fails the run
    raw = read_junit(ctest_run / "junit.xml")
    assert raw.counts.failed and outcomes(raw)["missing"] is CaseOutcome.SKIPPED
    result = read_ctest_junit(ctest_run / "junit.xml")
    assert outcomes(result) == {
        "ok": CaseOutcome.PASSED, "bad": CaseOutcome.FAILURE, "missing": CaseOutcome.ERROR,
        "skip_me": CaseOutcome.SKIPPED, "switched_off": CaseOutcome.SKIPPED,
    }
    assert result.counts == Counts(tests=5, errors=1, failures=1, skipped=2)


def test_ctest_dashboard_xml_reads_the_same_and_keeps_commands(ctest_run: Path) -> None:
    tag = ctest_run / "build" / "Testing" / "TAG"
    test_xml = tag.parent / tag.read_text().splitlines()[0] / "Test.xml"
    result = read_ctest_xml(test_xml)
    assert outcomes(result) == {
        "ok": CaseOutcome.PASSED, "bad": CaseOutcome.FAILURE, "missing": CaseOutcome.ERROR,
        "skip_me": CaseOutcome.SKIPPED, "switched_off": CaseOutcome.SKIPPED,
    }
    bad = next(c for c in result.cases if c.name == "bad")
    assert bad.message == "Failed (exit code 3)"
    assert bad.details == "it broke"
    assert bad.command[-2:] == ("-c", "echo it broke; exit 3")
    with pytest.raises(NotJUnit):
        read_junit(test_xml)


def test_the_result_file_of_an_ament_test_is_found_in_its_command() -> None:
    command = ["/venv/bin/python3", "-u", "/venv/share/ament_cmake_test/cmake/run_test.py",
               "/ws/build/lib/test_results/lib/test_limits.gtest.xml", "--package-name", "lib",
               "--command", "/ws/build/lib/test_limits"]
    assert ament_result_file(command) == \
        Path("/ws/build/lib/test_results/lib/test_limits.gtest.xml")
    assert ament_result_file(["/usr/bin/true"]) is None
    assert ament_result_file(["--package-name", "lib"]) is None


def test_written_results_read_back_the_same(tmp_path: Path) -> None:
    cases = [
        Case(name="ok", classname="pkg", seconds=0.25, stdout="all good\n"),
        Case(name="bad", classname="pkg", outcome=CaseOutcome.FAILURE, message="Timeout",
             details="waited <1 s> & gave up", stderr="oops"),
        Case(name="gone", classname="pkg", outcome=CaseOutcome.ERROR,
             message="Unable to find executable"),
        Case(name="later", classname="pkg", outcome=CaseOutcome.SKIPPED,
             message="SKIP_RETURN_CODE=77"),
    ]
    path = tmp_path / "nested" / "ctest.xml"
    write_junit(path, "pkg", cases)
    result = read_junit(path)
    assert result.counts == Counts(tests=4, errors=1, failures=1, skipped=1)
    def fields(case: Case) -> tuple[object, ...]:
        return (case.name, case.outcome, case.message, case.details, case.stdout, case.stderr)

    assert [fields(c) for c in result.cases] == [fields(c) for c in cases]
    assert path.read_text().startswith('<?xml version="1.0" encoding="UTF-8"?>\n<testsuite ')
    assert [p.name for p in path.parent.iterdir()] == ["ctest.xml"]  # no temporary left behind


def _ctest_tree(base: Path) -> None:
    """A colcon-tested workspace's build/: Test.xml naming an ament result file, and that file."""
    results = base / "lib" / "test_results" / "lib"
    results.mkdir(parents=True)
    gtest = results / "test_limits.gtest.xml"
    gtest.write_text(GTEST_XML)
    tag_dir = base / "lib" / "Testing" / "20250101-0000"
    tag_dir.mkdir(parents=True)
    (base / "lib" / "Testing" / "TAG").write_text("20250101-0000\nExperimental\n")
    (tag_dir / "Test.xml").write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<Site Name="host"><Testing>
  <Test Status="failed"><Name>test_limits</Name>
    <FullCommandLine>/venv/bin/python3 "-u" "/venv/run_test.py" "{gtest}" "--package-name" "lib"
    </FullCommandLine>
    <Results>
      <NamedMeasurement type="text/string" name="Exit Code"><Value>Failed</Value></NamedMeasurement>
    <Measurement><Value>gtest output</Value></Measurement></Results></Test>
  <Test Status="passed"><Name>plain</Name><FullCommandLine>/usr/bin/true</FullCommandLine>
    <Results><Measurement><Value></Value></Measurement></Results></Test>
</Testing></Site>
""")


def test_collect_finds_results_like_colcon_and_counts_ament_tests_once(tmp_path: Path) -> None:
    base = tmp_path / "build"
    _ctest_tree(base)
    (base / "py").mkdir()
    (base / "py" / "pytest.xml").write_text(
        '<testsuites><testsuite name="pytest" tests="2" failures="0" errors="0">'
        '<testcase classname="py.test_a" name="test_one"/><testcase classname="py.test_a" '
        'name="test_two"/></testsuite></testsuites>')
    (base / "py" / "package.xml").write_text("<package/>")  # not a result: ignored
    (base / "py" / ".hidden").mkdir()
    (base / "py" / ".hidden" / "old.xml").write_text(  # dot directories are not crawled
        '<testsuite tests="1" failures="1"><testcase name="x"><failure/></testcase></testsuite>')
    (base / "py" / "cut.xml").write_text("<testsuite")
    collected = collect_results(base)
    paths = [r.path.relative_to(base).as_posix() for r in collected.results]
    assert paths == ["lib/Testing/20250101-0000/Test.xml",
                     "lib/test_results/lib/test_limits.gtest.xml", "py/pytest.xml"]
    # the CTest entry of the gtest is left out: the gtest file holds its three cases
    assert [c.name for c in collected.results[0].cases] == ["plain"]
    assert collected.counts == Counts(tests=6, failures=1, skipped=1)
    assert len(collected.warnings) == 1 and "cut.xml" in collected.warnings[0]


def test_a_ctest_failure_without_its_result_file_still_counts(tmp_path: Path) -> None:
    base = tmp_path / "build"
    _ctest_tree(base)
    (base / "lib" / "test_results" / "lib" / "test_limits.gtest.xml").unlink()
    collected = collect_results(base)
    assert collected.counts == Counts(tests=2, failures=1)
    assert collected.counts.failed


def test_report_matches_colcon_test_result(tmp_path: Path) -> None:
    failing = ResultFile(tmp_path / "build/a/pytest.xml", Counts(tests=2, failures=1), (
        Case(name="test_x", classname="a.test_a", outcome=CaseOutcome.FAILURE,
             message="assert 1 == 2", details="test_a.py:3: in test_x\nE   assert 1 == 2",
             file="test_a.py", line="3"),
        Case(name="test_y", classname="a.test_a")))
    passing = ResultFile(tmp_path / "build/b/pytest.xml", Counts(tests=1))
    collected = Collected((failing, passing))
    plain = report_lines(collected, show_all=False, verbose=False, files_only=False, shown=tmp_path)
    assert plain == ["build/a/pytest.xml: 2 tests, 0 errors, 1 failure, 0 skipped", "",
                     "Summary: 3 tests, 0 errors, 1 failure, 0 skipped"]
    every = report_lines(collected, show_all=True, verbose=False, files_only=False, shown=tmp_path)
    assert every[1] == "build/b/pytest.xml: 1 test, 0 errors, 0 failures, 0 skipped"
    verbose = report_lines(collected, show_all=False, verbose=True, files_only=False,
                           shown=tmp_path)
    assert verbose[1:5] == ["- a.test_a test_x (test_a.py:3)", "  <<< failure message",
                            "    assert 1 == 2", "  >>>"]
    assert "    E   assert 1 == 2" in verbose
    files = report_lines(collected, show_all=False, verbose=False, files_only=True, shown=tmp_path)
    assert files == ["build/a/pytest.xml"]
    empty = report_lines(Collected(()), show_all=True, verbose=True, files_only=False,
                         shown=tmp_path)
    assert empty == ["Summary: 0 tests, 0 errors, 0 failures, 0 skipped"]


def test_case_details_show_output_blocks() -> None:
    case = Case(name="t", classname="c", outcome=CaseOutcome.ERROR, message="boom",
                stdout="line 1\nline 2\n", stderr="")
    assert case_details(case) == ["c t", "<<< error message", "  boom", ">>>",
                                  "<<< stdout output", "  line 1", "  line 2", ">>>"]


def test_headlines_say_why_in_one_line() -> None:
    generic = Case(name="t", outcome=CaseOutcome.FAILURE, message="Failed",
                   stdout="starting\nsegment 3 is out of range\n")
    assert generic.headline == "Failed: segment 3 is out of range"
    silent = Case(name="t", outcome=CaseOutcome.ERROR)
    assert silent.headline == "error"
    long = Case(name="t", outcome=CaseOutcome.FAILURE, message="x" * 500)
    assert len(long.headline) == 200 and long.headline.endswith("...")


def test_a_headline_ending_in_a_colon_carries_the_reason_below_it() -> None:
    """ament's "The test did not generate a result file:" is followed by why: the headline
    the summary and the report page show carries it, not the cut-off sentence."""
    missing = Case(name="cppcheck.xunit.missing_result", outcome=CaseOutcome.ERROR,
                   message="The test did not generate a result file:\n\n"
                           "Could not find 'cppcheck' executable\n")
    assert missing.headline == ("The test did not generate a result file: Could not find "
                                "'cppcheck' executable")
    below = Case(name="t", outcome=CaseOutcome.ERROR, message="It failed:",
                 details="Traceback (most recent call last):\nValueError: the reason\n")
    assert below.headline.startswith("It failed: ")
